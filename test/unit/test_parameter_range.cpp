// The range check of a node's numeric parameters (io/parameter_range.h): what it accepts, and a message that names
// the parameter, its value and the allowed range.
#include <gtest/gtest.h>

#include <limits>

#include "insitu_calibration/io/parameter_range.h"

namespace ic = insitu_calibration;

TEST(ParameterRange, ClosedRangeAcceptsItsBounds)
{
  const ic::ParameterRange range = ic::ParameterRange::closed(0.0, 60.0, "s");
  EXPECT_TRUE(ic::checkParameter("tf_timeout", 0.0, range));
  EXPECT_TRUE(ic::checkParameter("tf_timeout", 60.0, range));
  EXPECT_TRUE(ic::checkParameter("tf_timeout", 0.2, range));
  const ic::Status below = ic::checkParameter("tf_timeout", -1.0, range);
  ASSERT_FALSE(below);
  EXPECT_EQ(below.error().code(), ic::ErrorCode::kInvalidInput);
  EXPECT_EQ(below.error().message(), "parameter ~tf_timeout is -1, allowed: a number in [0, 60] s");
  EXPECT_FALSE(ic::checkParameter("tf_timeout", 60.000001, range));
}

TEST(ParameterRange, PositiveRangeRefusesZero)
{
  const ic::ParameterRange range = ic::ParameterRange::positive(100.0, "px");
  EXPECT_TRUE(ic::checkParameter("max_rms_px", 1e-9, range));
  const ic::Status zero = ic::checkParameter("max_rms_px", 0.0, range);
  ASSERT_FALSE(zero);
  EXPECT_EQ(zero.error().message(), "parameter ~max_rms_px is 0, allowed: a number in (0, 100] px");
}

TEST(ParameterRange, NonFiniteValuesAreRefused)
{
  const ic::ParameterRange range = ic::ParameterRange::closed(-1e300, 1e300);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const ic::Status not_a_number = ic::checkParameter("sigma", nan, range);
  ASSERT_FALSE(not_a_number);
  EXPECT_EQ(not_a_number.error().message(), "parameter ~sigma is nan, allowed: a number in [-1e+300, 1e+300]");
  EXPECT_FALSE(ic::checkParameter("sigma", inf, range));
  EXPECT_FALSE(ic::checkParameter("sigma", -inf, range));
}

TEST(ParameterRange, IntegersRefuseFractions)
{
  const ic::ParameterRange range = ic::ParameterRange::integers(1, 255);
  EXPECT_TRUE(ic::checkParameter("median_images", 15.0, range));
  const ic::Status fraction = ic::checkParameter("median_images", 2.5, range);
  ASSERT_FALSE(fraction);
  EXPECT_EQ(fraction.error().message(), "parameter ~median_images is 2.5, allowed: an integer in [1, 255]");
  EXPECT_FALSE(ic::checkParameter("median_images", 0.0, range));
  EXPECT_FALSE(ic::checkParameter("median_images", 256.0, range));
}

TEST(ParameterRange, ValuesAreShownInTheirShortestForm)
{
  EXPECT_EQ(ic::formatParameterValue(0.2), "0.2");
  EXPECT_EQ(ic::formatParameterValue(0.1 + 0.2), "0.30000000000000004");
  EXPECT_EQ(ic::formatParameterValue(-1e9), "-1000000000");
  EXPECT_EQ(ic::formatParameterValue(86400.0), "86400");
  EXPECT_EQ(ic::formatParameterValue(1e20), "1e+20");
  EXPECT_EQ(ic::formatParameterValue(0.00001), "1e-05");
  EXPECT_EQ(ic::formatParameterValue(4.9e-324), "5e-324");  // the smallest subnormal
  EXPECT_EQ(ic::formatParameterValue(-std::numeric_limits<double>::infinity()), "-inf");
}

TEST(ParameterRange, TypeErrorNamesWhatTheParameterHolds)
{
  const ic::Error error =
      ic::parameterTypeError("tf_timeout", "the string 'fast'", ic::ParameterRange::closed(0.0, 60.0, "s"));
  EXPECT_EQ(error.message(), "parameter ~tf_timeout is the string 'fast', allowed: a number in [0, 60] s");
}
