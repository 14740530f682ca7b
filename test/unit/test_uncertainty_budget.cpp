// The uncertainty budget read back from a calibration file's extras: its parts, their description, and the advice
// for the largest part of whichever sigma is over its limit.
#include <gtest/gtest.h>

#include <cmath>

#include "insitu_calibration/survey/uncertainty_budget.h"

namespace ic = insitu_calibration;

namespace
{
std::map<std::string, double> extras(double lines_m, double lines_deg, double map_m, double map_deg, double placement_m,
                                     double placement_deg)
{
  const auto sum = [](double a, double b, double c) { return std::sqrt(a * a + b * b + c * c); };
  return {{"sigma_position_m", sum(lines_m, map_m, placement_m)},
          {"sigma_rotation_deg", sum(lines_deg, map_deg, placement_deg)},
          {ic::kSigmaLinesPositionKey, lines_m},
          {ic::kSigmaLinesRotationKey, lines_deg},
          {"sigma_shared_map_position_m", map_m},
          {"sigma_shared_map_rotation_deg", map_deg},
          {ic::kSigmaPlacementAtCameraKey, placement_m},
          {"sigma_map_placement_deg", placement_deg}};
}
}  // namespace

TEST(UncertaintyBudget, ReadsThePartsBack)
{
  const auto budget = ic::uncertaintyBudgetOf(extras(0.005, 0.1, 0.008, 0.45, 0.021, 0.27));
  ASSERT_TRUE(budget);
  EXPECT_DOUBLE_EQ(budget->matched_lines.position_m, 0.005);
  EXPECT_DOUBLE_EQ(budget->map_lines.rotation_deg, 0.45);
  EXPECT_DOUBLE_EQ(budget->map_placement.position_m, 0.021);
  EXPECT_NEAR(budget->total.rotation_deg, std::sqrt(0.01 + 0.2025 + 0.0729), 1e-12);
  EXPECT_EQ(ic::describeBudget(*budget),
            "matched lines 5.0 mm / 0.100 deg, map lines 8.0 mm / 0.450 deg, map placement 21.0 mm / 0.270 deg");
}

TEST(UncertaintyBudget, AFileWithoutThePartsHasNoBudget)
{
  EXPECT_FALSE(ic::uncertaintyBudgetOf({}));
  EXPECT_FALSE(ic::uncertaintyBudgetOf({{"sigma_position_m", 0.02}, {"sigma_rotation_deg", 0.3}}));
  // Without the map parts (a calibration with tf taken as exact) they are 0, and the lines are the whole.
  const auto budget = ic::uncertaintyBudgetOf({{"sigma_position_m", 0.02},
                                               {"sigma_rotation_deg", 0.3},
                                               {ic::kSigmaLinesPositionKey, 0.02},
                                               {ic::kSigmaLinesRotationKey, 0.3}});
  ASSERT_TRUE(budget);
  EXPECT_EQ(budget->map_placement.position_m, 0.0);
  EXPECT_NE(ic::adviceFor(*budget, true).find("matched lines"), std::string::npos);
}

TEST(UncertaintyBudget, TheAdviceNamesTheLargestPartOfTheSigmaOverItsLimit)
{
  // Rotation dominated by the map lines, position by the placement.
  const auto budget = ic::uncertaintyBudgetOf(extras(0.005, 0.1, 0.008, 0.45, 0.021, 0.27));
  ASSERT_TRUE(budget);
  EXPECT_NE(ic::adviceFor(*budget, false).find("map lines' own errors"), std::string::npos);
  EXPECT_NE(ic::adviceFor(*budget, false).find("--depth-registration estimate"), std::string::npos);
  EXPECT_NE(ic::adviceFor(*budget, true).find("localization_sigma_m"), std::string::npos);
  const auto lines = ic::uncertaintyBudgetOf(extras(0.04, 0.6, 0.008, 0.1, 0.021, 0.27));
  ASSERT_TRUE(lines);
  EXPECT_NE(ic::adviceFor(*lines, true).find("survey more of the camera's view"), std::string::npos);
  EXPECT_NE(ic::adviceFor(*lines, false).find("survey more of the camera's view"), std::string::npos);
}

TEST(UncertaintyBudget, TheTooUncertainWarningGivesThePartsAndTheAdvice)
{
  const auto extra = extras(0.005, 0.1, 0.008, 0.45, 0.021, 0.27);
  const std::string warning = ic::describeTooUncertain(extra, 0.03, 0.5);
  EXPECT_EQ(warning.rfind("calibration too uncertain: 1 sigma 0.023 m, 0.53 deg (limits 0.030 m, 0.50 deg); of it "
                          "matched lines 5.0 mm / 0.100 deg, map lines 8.0 mm / 0.450 deg, map placement 21.0 mm / "
                          "0.270 deg; most of it is the map lines' own errors",
                          0),
            0u)
      << warning;
  // Without a budget (a calibration not from a survey) the sentence alone.
  EXPECT_EQ(ic::describeTooUncertain({{"sigma_position_m", 0.05}, {"sigma_rotation_deg", 0.2}}, 0.03, 0.5),
            "calibration too uncertain: 1 sigma 0.050 m, 0.20 deg (limits 0.030 m, 0.50 deg)");
}
