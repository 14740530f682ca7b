// Pictures of a calibration for people: the map's edges transported into the fixed camera's image (the paper's
// Fig. 1b) and the camera's viewing frustum in the map.
#ifndef INSITU_CALIBRATION_SURVEY_OVERLAY_H
#define INSITU_CALIBRATION_SURVEY_OVERLAY_H

#include <vector>

#include <opencv2/core.hpp>

#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/geometry/segment.h"
#include "insitu_calibration/survey/image_explanation.h"

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
// The report's overlay of a result the final check assessed: the map lines as it saw them (checked_map_lines:
// FixedCameraResult::checked_map_lines). Counted lines wide red where an image edge lies under them and thin red
// where none does (what counts against the camera); every other part of a map line in view in thin blue dashes:
// left out of the check, as hidden behind surfaces the survey measured, as floor joints where the floor looks plain,
// or as too short (under 20 px) or too near the border (3 px) to assess. Without an image: drawOverlay.
cv::Mat drawFinalCheckOverlay(const cv::Mat& image, int width, int height, const CameraModel& camera,
                              const std::vector<Segment3d>& map_lines,
                              const std::vector<EdgeSamples>& checked_map_lines,
                              const std::vector<std::vector<Eigen::Vector2d>>& matched_image_lines,
                              const std::vector<std::vector<Eigen::Vector2d>>& unmatched_image_lines);
// Which map-line styles an overlay's legend explains.
enum class MapLineLegend
{
  kThroughCalibration,  // drawOverlay: every map line alike
  kEdgeSupport,         // drawOverlayWithHiddenEdges: on an edge, or thin dashes
  kFinalCheck,          // drawFinalCheckOverlay: on an edge, counted without one, left out
};
// The overlay's colours explained in a box in the top-left corner of its canvas (the unmatched entry only when
// with_unmatched).
void drawOverlayLegend(cv::Mat* canvas, bool with_unmatched,
                       MapLineLegend map_lines = MapLineLegend::kThroughCalibration);

// The overlay that the node publishes (~<name>/overlay) and saves (<name>_overlay.png), and calibrate_survey saves:
// drawOverlay with its legend, so that it reads without the README in rviz's image panel.
cv::Mat drawCalibrationOverlay(const cv::Mat& image, int width, int height, const CameraModel& camera,
                               const std::vector<Segment3d>& map_lines,
                               const std::vector<std::vector<Eigen::Vector2d>>& matched_image_lines);

// The 8 edges of the camera's viewing pyramid out to `depth_m` (through the distorted image corners) in the world.
std::vector<Segment3d> frustumSegments(const CameraModel& camera, int width, int height, double depth_m);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SURVEY_OVERLAY_H
