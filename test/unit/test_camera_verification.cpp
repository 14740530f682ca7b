// The moved-camera watchdog's measurement (survey/camera_verification.h) against the simulator's truth: a fixed
// camera of the default world is calibrated exactly (its true model), the map is its view's true edges with a few
// millimetres of survey error, and its image is rendered again after the camera was rotated by 1 degree or
// translated by 5 cm (or not moved). The measured displacement, rotation and translation must be within 3 of their
// sigmas of the truth, the moved cameras flagged, the unmoved ones never. Image noise and map error seeds: 1 was
// used while choosing the options, 2-6 are held out.
#include <gtest/gtest.h>

#include <cstdio>
#include <algorithm>
#include <random>

#include <opencv2/imgproc.hpp>

#include "insitu_calibration/lines/image_lines.h"
#include "insitu_calibration/simulation/line_frames.h"
#include "insitu_calibration/simulation/survey.h"
#include "insitu_calibration/simulation/true_edges.h"
#include "insitu_calibration/simulation/world.h"
#include "insitu_calibration/survey/camera_verification.h"

namespace ic = insitu_calibration;
namespace sim = insitu_calibration::simulation;

namespace
{
const std::string kWorld = std::string(INSITU_SOURCE_DIR) + "/config/worlds/waiting_room.yaml";
constexpr double kDegToRad = M_PI / 180.0;

class CameraVerification : public ::testing::Test
{
protected:
  void SetUp() override
  {
    auto world = sim::loadWorldFile(kWorld);
    ASSERT_TRUE(world) << world.error().describe();
    world_ = *world;
    for (size_t c = 0; c < world_.fixed_cameras.size(); ++c)
      if (world_.fixed_cameras[c].name == "cam_east")
        camera_ = static_cast<int>(c);
    ASSERT_GE(camera_, 0);
  }

  const sim::SimulatedFixedCamera& fixed() const { return world_.fixed_cameras[camera_]; }

  // The true edges whose middle the calibrated camera sees, each end moved by ~3 mm (a survey's error); with
  // max_lines, that many of them drawn at random (a survey that saw fewer lines).
  std::vector<ic::Segment3d> surveyedMap(uint64_t seed, size_t max_lines = 0) const
  {
    const sim::Renderer renderer(world_);
    const sim::ViewCamera view = sim::ViewCamera::fromModel(fixed().camera, fixed().width, fixed().height);
    sim::RenderOptions options;
    options.color = false;
    const sim::RenderedView rendered = renderer.render(view, options);
    std::mt19937 rng(static_cast<unsigned>(seed));
    std::normal_distribution<double> error(0.0, 0.003);
    std::vector<ic::Segment3d> map;
    for (const auto& e : sim::computeTrueEdges(world_))
    {
      const Eigen::Vector3d m = 0.5 * (e.start + e.end);
      const auto p = fixed().camera.project(m);
      if (!p || p->x() < 0 || p->y() < 0 || p->x() > fixed().width - 1 || p->y() > fixed().height - 1)
        continue;
      const float depth = rendered.depth.at<float>(static_cast<int>(p->y() + 0.5), static_cast<int>(p->x() + 0.5));
      if (fixed().camera.toCamera(m).z() > depth + 0.05)
        continue;
      const Eigen::Vector3d da(error(rng), error(rng), error(rng)), db(error(rng), error(rng), error(rng));
      map.push_back({e.start + da, e.end + db});
    }
    if (max_lines > 0 && map.size() > max_lines)
    {
      std::shuffle(map.begin(), map.end(), rng);
      map.resize(max_lines);
    }
    return map;
  }

  // The image lines of the camera moved by `motion` (in its optical frame), with the sensor noise of `seed`.
  std::vector<std::vector<Eigen::Vector2d>> imageLinesAfter(const Eigen::Isometry3d& motion, uint64_t seed) const
  {
    sim::World moved = world_;
    ic::CameraModel& camera = moved.fixed_cameras[camera_].camera;
    camera.pose() = ic::CameraPose::fromWorldFromCamera(camera.pose().worldFromCamera() * motion);
    sim::SimulationOptions options;
    options.seed = seed;
    options.duration_s = 1.0;
    auto simulator = sim::SurveySimulator::create(moved, options);
    EXPECT_TRUE(simulator) << simulator.error().describe();
    cv::Mat grey;
    cv::cvtColor(simulator->fixedFrame(camera_, 0).image, grey, cv::COLOR_RGB2GRAY);
    const auto lines = ic::extractImageLines(grey, fixed().camera.distortion());
    EXPECT_TRUE(lines) << lines.error().describe();
    std::vector<std::vector<Eigen::Vector2d>> out;
    for (const auto& l : *lines)
      out.push_back(l.points);
    return out;
  }

  struct Outcome
  {
    ic::CameraMotion measured;
    ic::PoseDifference truth;
  };

  Outcome verify(const Eigen::Isometry3d& motion, uint64_t seed, const char* what, size_t max_lines = 0) const
  {
    const auto map = surveyedMap(seed, max_lines);
    const auto lines = imageLinesAfter(motion, seed);
    const auto measured = ic::verifyCameraPose(fixed().camera, fixed().width, fixed().height, map, lines);
    EXPECT_TRUE(measured) << measured.error().describe();
    const ic::CameraPose after = ic::CameraPose::fromWorldFromCamera(fixed().camera.pose().worldFromCamera() * motion);
    Outcome out{measured ? *measured : ic::CameraMotion{},
                ic::poseDifference(fixed().camera, after,
                                   ic::visibleMapPoints(fixed().camera, fixed().width, fixed().height, map))};
    std::printf("%s, seed %llu: measured %s; truth %.2f px / %.3f deg / %.1f mm (%zu map lines, %zu image lines)\n",
                what, static_cast<unsigned long long>(seed), out.measured.message.c_str(), out.truth.displacement_px,
                out.truth.rotation_deg, 1000.0 * out.truth.translation_m, map.size(), lines.size());
    return out;
  }

  // The magnitudes within 3 sigma of the truth (and the sigmas small enough to mean something).
  static void expectMagnitudes(const Outcome& o)
  {
    const ic::CameraMotion& m = o.measured;
    EXPECT_LT(std::abs(m.displacement_px - o.truth.displacement_px), 3.0 * m.displacement_sigma_px);
    EXPECT_LT(std::abs(m.rotation_deg - o.truth.rotation_deg), 3.0 * m.rotation_sigma_deg);
    EXPECT_LT(std::abs(m.translation_m - o.truth.translation_m), 3.0 * m.translation_sigma_m);
    EXPECT_LT(m.displacement_sigma_px, 0.1 * o.truth.displacement_px);
  }

  sim::World world_;
  int camera_ = -1;
};

Eigen::Isometry3d rotation(double deg, const Eigen::Vector3d& axis)
{
  Eigen::Isometry3d m = Eigen::Isometry3d::Identity();
  m.linear() = Eigen::AngleAxisd(deg * kDegToRad, axis.normalized()).toRotationMatrix();
  return m;
}

Eigen::Isometry3d translation(const Eigen::Vector3d& t)
{
  Eigen::Isometry3d m = Eigen::Isometry3d::Identity();
  m.translation() = t;
  return m;
}
}  // namespace

TEST_F(CameraVerification, RotatedByOneDegreeIsFlaggedWithItsMagnitude)
{
  // Pan (about the image's y axis), then a tilt and roll mixed in.
  const Eigen::Vector3d axes[] = {Eigen::Vector3d::UnitY(), Eigen::Vector3d(1.0, 0.5, 0.3)};
  uint64_t seed = 1;
  for (const Eigen::Vector3d& axis : axes)
  {
    const Outcome o = verify(rotation(1.0, axis), seed++, "rotated 1 deg");
    EXPECT_EQ(o.measured.verdict, ic::CameraMotionVerdict::kMoved) << o.measured.message;
    EXPECT_NEAR(o.truth.rotation_deg, 1.0, 1e-9);
    expectMagnitudes(o);
    EXPECT_NEAR(o.measured.rotation_deg, 1.0, 0.05);
  }
}

TEST_F(CameraVerification, TranslatedByFiveCentimetresIsFlaggedWithItsMagnitude)
{
  // Sideways (the image's x axis), then along a slanted direction with a forward part.
  const Eigen::Vector3d directions[] = {Eigen::Vector3d::UnitX(), Eigen::Vector3d(-0.3, 0.8, 0.5)};
  uint64_t seed = 1;
  for (const Eigen::Vector3d& direction : directions)
  {
    const Outcome o = verify(translation(0.05 * direction.normalized()), seed++, "translated 5 cm");
    EXPECT_EQ(o.measured.verdict, ic::CameraMotionVerdict::kMoved) << o.measured.message;
    expectMagnitudes(o);
  }
}

// A map of 40 lines, as a short survey gives (the node's test survey has about 30 in cam_east's view): rotation and
// translation are less well told apart, the displacement is still measured.
TEST_F(CameraVerification, SparseMap)
{
  uint64_t seed = 1;
  for (const Eigen::Isometry3d& motion :
       {rotation(1.0, Eigen::Vector3d(1.0, 0.5, 0.3)), translation(0.05 * Eigen::Vector3d(-0.3, 0.8, 0.5).normalized()),
        rotation(1.0, Eigen::Vector3d::UnitY())})
  {
    const Outcome o = verify(motion, seed++, "sparse map", 40);
    EXPECT_EQ(o.measured.verdict, ic::CameraMotionVerdict::kMoved) << o.measured.message;
    expectMagnitudes(o);
  }
  for (uint64_t unmoved = 1; unmoved <= 3; ++unmoved)
  {
    const Outcome o = verify(Eigen::Isometry3d::Identity(), unmoved, "sparse map, unmoved", 40);
    EXPECT_EQ(o.measured.verdict, ic::CameraMotionVerdict::kUnmoved) << o.measured.message;
  }
}

TEST_F(CameraVerification, UnmovedCameraIsNeverFlagged)
{
  for (uint64_t seed = 1; seed <= 6; ++seed)
  {
    const Outcome o = verify(Eigen::Isometry3d::Identity(), seed, "unmoved");
    EXPECT_EQ(o.measured.verdict, ic::CameraMotionVerdict::kUnmoved) << o.measured.message;
    EXPECT_LT(o.measured.displacement_px, 3.0 * o.measured.displacement_sigma_px);
    EXPECT_LT(o.measured.rotation_deg, 3.0 * o.measured.rotation_sigma_deg);
  }
}

TEST_F(CameraVerification, TooFewMatchingLinesCannotBeVerified)
{
  // A map of four lines: whatever the image shows, the verdict is "unknown", never "unmoved".
  auto map = surveyedMap(1);
  map.resize(4);
  const auto lines = imageLinesAfter(Eigen::Isometry3d::Identity(), 1);
  const auto measured = ic::verifyCameraPose(fixed().camera, fixed().width, fixed().height, map, lines);
  ASSERT_TRUE(measured) << measured.error().describe();
  EXPECT_EQ(measured->verdict, ic::CameraMotionVerdict::kUnknown) << measured->message;
  EXPECT_NE(measured->message.find("cannot verify"), std::string::npos) << measured->message;
  // No image lines at all: the same.
  const auto blind = ic::verifyCameraPose(fixed().camera, fixed().width, fixed().height, surveyedMap(1), {});
  ASSERT_TRUE(blind) << blind.error().describe();
  EXPECT_EQ(blind->verdict, ic::CameraMotionVerdict::kUnknown);
  EXPECT_FALSE(ic::verifyCameraPose(fixed().camera, fixed().width, fixed().height, {}, lines));
}

TEST_F(CameraVerification, UncertainMapLinesAreLeftOut)
{
  // Beside each precise map line the same edge 12 mm off, as a line fused from uncertain depth may be (sigma 8 mm):
  // the fit weighs every line alike, so those lines are left out and the motion is measured on the precise ones.
  const auto precise = surveyedMap(1);
  std::vector<ic::Segment3d> map = precise;
  std::vector<double> sigmas(precise.size(), 0.003);
  const Eigen::Vector3d offset(0.012, 0.0, 0.0);
  for (const auto& s : precise)
  {
    map.push_back({s.a + offset, s.b + offset});
    sigmas.push_back(0.008);
  }
  const ic::CameraVerificationOptions options;
  const auto used = ic::verificationMapLines(map, sigmas, options);
  ASSERT_EQ(used.size(), precise.size());
  for (size_t i = 0; i < used.size(); ++i)
    EXPECT_EQ(used[i].a, precise[i].a);
  ic::CameraVerificationOptions every = options;
  every.max_map_line_sigma_m = 0.0;
  EXPECT_EQ(ic::verificationMapLines(map, sigmas, every).size(), map.size());
  EXPECT_EQ(ic::verificationMapLines(map, {}, options).size(), map.size());  // no sigmas: every line

  // The fit on the precise lines; the displacement at every map line in view, as an operator sees the overlay.
  const Eigen::Isometry3d motion = translation(Eigen::Vector3d(0.05, 0.0, 0.0));
  const auto measured = ic::verifyCameraPose(fixed().camera, fixed().width, fixed().height, map,
                                             imageLinesAfter(motion, 1), options, sigmas);
  ASSERT_TRUE(measured) << measured.error().describe();
  const ic::CameraPose after = ic::CameraPose::fromWorldFromCamera(fixed().camera.pose().worldFromCamera() * motion);
  const Outcome o{*measured,
                  ic::poseDifference(fixed().camera, after,
                                     ic::visibleMapPoints(fixed().camera, fixed().width, fixed().height, map))};
  EXPECT_EQ(o.measured.verdict, ic::CameraMotionVerdict::kMoved) << o.measured.message;
  expectMagnitudes(o);
}
