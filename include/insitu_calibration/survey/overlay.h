// Pictures of a calibration for people: the map's edges transported into the fixed camera's image (the paper's
// Fig. 1b) and the camera's viewing frustum in the map.
#ifndef INSITU_CALIBRATION_SURVEY_OVERLAY_H
#define INSITU_CALIBRATION_SURVEY_OVERLAY_H

#include <vector>

#include <opencv2/core.hpp>

#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/geometry/segment.h"

namespace insitu_calibration
{
// The image (grey or colour) in colour with every map line the camera sees drawn through its division model (red),
// and the matched image lines (green), with a legend in the top left corner. An empty image gives a black canvas of
// the given size.
cv::Mat drawOverlay(const cv::Mat& image, int width, int height, const CameraModel& camera,
                    const std::vector<Segment3d>& map_lines,
                    const std::vector<std::vector<Eigen::Vector2d>>& matched_image_lines);

// The 8 edges of the camera's viewing pyramid out to `depth_m` (through the distorted image corners) in the world.
std::vector<Segment3d> frustumSegments(const CameraModel& camera, int width, int height, double depth_m);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SURVEY_OVERLAY_H
