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
// The image (grey or colour) in colour with every map line the camera sees drawn through its division model (red,
// wider: a matched line on it shows green with red borders), the matched image lines (green) and, when given, the image
// lines left unmatched (yellow, beneath the others). An empty image gives a black canvas of the given size. Map lines
// are clipped to the image only: an edge hidden behind a foreground object is drawn across it.
cv::Mat drawOverlay(const cv::Mat& image, int width, int height, const CameraModel& camera,
                    const std::vector<Segment3d>& map_lines,
                    const std::vector<std::vector<Eigen::Vector2d>>& matched_image_lines,
                    const std::vector<std::vector<Eigen::Vector2d>>& unmatched_image_lines = {});
// drawOverlay for a report: each map line wide only where an image edge lies under it (sampleEdgeSupport of
// image_explanation.h, the final check's edge test) and in thin dashes elsewhere, so that a map edge hidden behind a
// foreground object is not drawn through it as if seen. Lines shorter than the check assesses (20 px) are left out.
// Without an image: drawOverlay.
cv::Mat drawOverlayWithHiddenEdges(const cv::Mat& image, int width, int height, const CameraModel& camera,
                                   const std::vector<Segment3d>& map_lines,
                                   const std::vector<std::vector<Eigen::Vector2d>>& matched_image_lines,
                                   const std::vector<std::vector<Eigen::Vector2d>>& unmatched_image_lines);
// The overlay's colours explained in a box in the top-left corner of its canvas (the unmatched entry only when
// with_unmatched; with_hidden: drawOverlayWithHiddenEdges's two kinds of map line).
void drawOverlayLegend(cv::Mat* canvas, bool with_unmatched, bool with_hidden = false);

// The 8 edges of the camera's viewing pyramid out to `depth_m` (through the distorted image corners) in the world.
std::vector<Segment3d> frustumSegments(const CameraModel& camera, int width, int height, double depth_m);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SURVEY_OVERLAY_H
