// A calibration whose camera cannot project its own inlier lines' points is refused, never returned with an RMS
// over the few points left (0 px when none are): wrong matches in the line matcher's search led there.
#include <gtest/gtest.h>

#include <random>
#include <string>

#include "insitu_calibration/calibration.h"
#include "insitu_calibration/matching/line_matcher.h"
#include "insitu_calibration/test_support/synthetic_lines.h"

namespace ic = insitu_calibration;

TEST(CalibrationProjectable, ACameraThatCannotProjectItsLinesIsNoSolution)
{
  // The matcher's calibration (no priors at the fit's noise, as its search calibrates) on building-like lines whose
  // world lines are handed to the wrong image lines, from the true camera: on these seeds the refinement used to end
  // tens of metres to kilometres away with none of its points projectable, and an RMS of 0 px.
  ic::CalibrationOptions options = ic::LineMatcherOptions().calibration;
  options.refinement.priors_at_fit_noise = false;
  int refused_unprojectable = 0;
  for (int seed = 1; seed <= 30; ++seed)
  {
    std::mt19937 rng(seed);
    const ic::CameraModel truth = ic::randomCamera({}, rng);
    ic::SyntheticLineOptions lines;
    lines.lines = 16;
    lines.axis_aligned = true;
    const ic::CorrespondenceSet data = ic::makeSyntheticLines(truth, 1280, 960, lines, rng).data;
    ic::CorrespondenceSet wrong = data;
    for (size_t k = 0; k < wrong.lines.size(); ++k)
      wrong.lines[k].world = data.lines[(k + 1 + seed % 5) % data.lines.size()].world;
    const auto result = ic::calibrateCamera(wrong, options, truth);
    if (!result)
    {
      refused_unprojectable += result.error().message().find("cannot project") != std::string::npos ? 1 : 0;
      continue;
    }
    EXPECT_GE(result->reprojection.count, result->reprojection.unprojectable) << "seed " << seed;  // at most half
  }
  EXPECT_GE(refused_unprojectable, 3);  // seeds 3, 4, 5, 11, 15 and 18 at the time of writing
}

TEST(CalibrationProjectable, RightCorrespondencesStillCalibrate)
{
  std::mt19937 rng(3);
  ic::SyntheticCameraOptions square;  // square pixels, as the matcher's calibration takes them
  square.aspect_jitter = 0.0;
  const ic::CameraModel truth = ic::randomCamera(square, rng);
  ic::SyntheticLineOptions lines;
  lines.lines = 16;
  lines.axis_aligned = true;
  lines.image_noise_px = 0.3;
  const ic::CorrespondenceSet data = ic::makeSyntheticLines(truth, 1280, 960, lines, rng).data;
  const auto result = ic::calibrateCamera(data, ic::LineMatcherOptions().calibration, truth);
  ASSERT_TRUE(result) << result.error().message();
  EXPECT_EQ(result->reprojection.unprojectable, 0u);
  EXPECT_LT((result->camera.pose().center() - truth.pose().center()).norm(), 0.05);
  EXPECT_NEAR(result->camera.intrinsics().fx / truth.intrinsics().fx, 1.0, 0.01);
}
