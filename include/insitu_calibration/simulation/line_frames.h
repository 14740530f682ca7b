// The survey simulator's frames as the line extraction's inputs, and its true edges as the evaluation's segments:
// what the ROS layer builds from a simulated bag (cv_bridge "bgr8", the camera_info's K with D = 0, the tf pose at the
// frame's stamp), without the bag. For the accuracy tests and bench_lines on simulator frames.
#ifndef INSITU_CALIBRATION_SIMULATION_LINE_FRAMES_H
#define INSITU_CALIBRATION_SIMULATION_LINE_FRAMES_H

#include <vector>

#include <opencv2/core.hpp>

#include "insitu_calibration/geometry/segment.h"
#include "insitu_calibration/lines/rgbd_frame.h"
#include "insitu_calibration/simulation/survey.h"
#include "insitu_calibration/simulation/true_edges.h"

namespace insitu_calibration
{
namespace simulation
{
// An Xtion frame as an RgbdFrame: rgb in BGR order, depth 16UC1 millimetres (shared, not copied), the Xtion's
// camera_info (size, K, no distortion), the true pose of the optical frame in the map, the stamp in seconds
// (start time + the frame's offset, as in the bag).
RgbdFrame toRgbdFrame(const SurveySimulator& survey, const XtionFrame& frame);

// A fixed camera's RGB image in BGR order (as cv_bridge gives it for "bgr8").
cv::Mat toBgr(const cv::Mat& rgb);

// The true edges as segments (lines/line_evaluation.h); kinds is a filter (empty: every kind).
std::vector<Segment3d> toSegments(const std::vector<TrueEdge>& edges, const std::vector<std::string>& kinds = {});

}  // namespace simulation
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SIMULATION_LINE_FRAMES_H
