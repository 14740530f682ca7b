// The survey guidance of a refused camera as a file (DIR/<camera>_survey_hint.yaml beside its picture), so that a
// program can act on it: the simulator drives the robot to each standpoint (generate_world --visit-hints), a robot's
// mission planner could do the same. Coordinates are in the map frame (the simulator's world frame), metres.
//
//   camera: cam_a
//   frame: map
//   image_width: 1280
//   image_height: 720
//   regions:                      # largest first (by unexplained image lines)
//     - where: left               # the part of the camera's view
//       image_lines: 29           # image lines there that no map line explains
//       standpoint: [16.7, 0.4]   # where the robot should stand, x, y
//       look_direction: [-0.97, -0.23]  # unit vector: where its Xtion should look
//       floor_polygon: [[x, y], ...]    # the floor the region shows (convex, counter-clockwise)
//       structure_height_m: [0.0, 2.6]  # optional (the Xtion's view known): how high what the region shows is
//       xtion_share: 0.82              # optional: the share of it in the Xtion's view from the standpoint (under
//                                      # 0.5: out of its reach; mount it higher or tilted, or use CAD lines)
//       xtion_pitch_deg: 8              # optional, for a region out of its reach: the Xtion's pitch that brings it
//                                      # into view (UnmappedRegion::mountToSee; above the horizontal, deg)
//       xtion_height_m: 1.2             # optional, with xtion_pitch_deg: the Xtion's height above the floor that
//                                      # mount needs, where its own does not do
#ifndef INSITU_CALIBRATION_SURVEY_SURVEY_HINT_FILE_H
#define INSITU_CALIBRATION_SURVEY_SURVEY_HINT_FILE_H

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "insitu_calibration/error.h"
#include "insitu_calibration/survey/survey_guidance.h"

namespace insitu_calibration
{
struct SurveyHintRegion
{
  std::string where;
  size_t image_lines = 0;
  Eigen::Vector2d standpoint = Eigen::Vector2d::Zero();
  Eigen::Vector2d look_direction = Eigen::Vector2d::UnitX();
  std::vector<Eigen::Vector2d> floor_polygon;
  double xtion_share = -1.0;  // -1: not in the file
  Eigen::Vector2d structure_height_m = Eigen::Vector2d::Zero();
  std::optional<double> xtion_pitch_deg;  // the mount advice's pitch (a region out of the Xtion's reach)
  std::optional<double> xtion_height_m;   // and its height, where the survey's does not do
};

struct SurveyHint
{
  std::string camera;
  int image_width = 0;
  int image_height = 0;
  std::vector<SurveyHintRegion> regions;  // largest first
};

// The hint of a camera from its guidance (its regions, in their order).
SurveyHint surveyHintOf(const std::string& camera, const SurveyGuidance& guidance);

// The file's text (format above; millimetre precision, 4 decimals for directions).
std::string surveyHintYaml(const SurveyHint& hint);

// Reads the text back. Errors: not YAML, a missing or malformed field (with its place), a look direction that is
// not a direction (zero length; it is normalised otherwise), more than 64 regions or 10000 polygon points.
Expected<SurveyHint> parseSurveyHint(const std::string& yaml_text, const std::string& source = "survey hint");

// The file at a path (readFile's limits apply).
Expected<SurveyHint> readSurveyHint(const std::string& path);

// The one mount for a survey that follows the mount advice of several hints (an operator re-mounts the Xtion once per
// survey): the advising region's mount that serves the most unmapped image lines, counting those of every advising
// region whose mount is the same within kSameMountPitchDeg of pitch (and of the same height); with its height when
// it advises one; the first of equals; none when no region carries a pitch. (The middle pitch chose before: on set
// V's hall it served one image line where 23 wanted another mount, docs/measurements.md.)
constexpr double kSameMountPitchDeg = 5.0;
struct AdvisedMount
{
  double pitch_deg = 0.0;
  std::optional<double> height_m;
};
std::optional<AdvisedMount> advisedXtionMount(const std::vector<SurveyHint>& hints);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SURVEY_SURVEY_HINT_FILE_H
