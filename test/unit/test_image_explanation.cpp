// The final check of a fixed camera's calibration (image_explanation.h): the true camera of a simulated view explains
// its image (its map lines lie on the image's edges), deliberately wrong cameras do not and are refused.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include <opencv2/imgproc.hpp>

#include "insitu_calibration/simulation/renderer.h"
#include "insitu_calibration/simulation/true_edges.h"
#include "insitu_calibration/simulation/world.h"
#include "insitu_calibration/survey/fixed_camera.h"
#include "insitu_calibration/survey/image_explanation.h"
#include "insitu_calibration/test_support/edges_in_view.h"

namespace ic = insitu_calibration;
namespace sim = insitu_calibration::simulation;

namespace
{
const std::string kWorld = std::string(INSITU_SOURCE_DIR) + "/config/worlds/waiting_room.yaml";

ic::CameraModel moved(ic::CameraModel c, const Eigen::Vector3d& shift_world)
{
  ic::CameraPose& pose = c.pose();
  pose.translation -= pose.rotation * shift_world;  // centre + shift
  return c;
}
// The centre lines of square tiles of side tile_m covering the default world's 8 x 6 m room at height z_m: lines
// where the image of a tile is plain.
std::vector<ic::Segment3d> tileCentreLines(double tile_m, double z_m)
{
  std::vector<ic::Segment3d> lines;
  for (double y = 0.5 * tile_m; y < 6.0; y += tile_m)
    lines.push_back({Eigen::Vector3d(0.0, y, z_m), Eigen::Vector3d(8.0, y, z_m)});
  for (double x = 0.5 * tile_m; x < 8.0; x += tile_m)
    lines.push_back({Eigen::Vector3d(x, 0.0, z_m), Eigen::Vector3d(x, 6.0, z_m)});
  return lines;
}

// What the report's overlay draws is what the test counted: the left-out lines and samples, the counted samples'
// share on an edge, each sample the image of its map point.
void expectCheckedLinesAsCounted(const cv::Mat& image, const sim::SimulatedFixedCamera& cam,
                                 const std::vector<ic::Segment3d>& map, const ic::ImageExplanationOptions& options,
                                 const ic::ImageExplanation& expected)
{
  std::vector<ic::EdgeSamples> checked;
  const auto with_samples = ic::explainImage(image, cam.camera, cam.width, cam.height, map, nullptr, options, &checked);
  size_t left_out = 0, left_out_samples = 0, counted_samples = 0, counted_on_edge = 0;
  for (const ic::EdgeSamples& line : checked)
  {
    left_out += line.counted ? 0 : 1;
    ASSERT_TRUE(line.left_out.empty() || line.left_out.size() == line.points.size()) << cam.name;
    ASSERT_EQ(line.map_points.size(), line.points.size()) << cam.name;
    for (size_t k = 0; k < line.points.size(); ++k)  // each sample is the image of its map point
    {
      const auto p = cam.camera.project(line.map_points[k]);
      ASSERT_TRUE(p.has_value()) << cam.name;
      EXPECT_LT((*p - line.points[k]).norm(), 1e-6) << cam.name;
    }
    for (size_t k = 0; line.counted && k < line.points.size(); ++k)
    {
      counted_samples += line.countedAt(k) ? 1 : 0;
      counted_on_edge += line.countedAt(k) && line.on_edge[k] ? 1 : 0;
      left_out_samples += line.countedAt(k) ? 0 : 1;
    }
  }
  EXPECT_EQ(checked.size(), expected.map_lines + expected.plain_lines) << cam.name;
  EXPECT_EQ(left_out, expected.plain_lines) << cam.name;
  EXPECT_EQ(counted_samples, expected.samples) << cam.name;
  EXPECT_EQ(left_out_samples, expected.plain_floor_samples + expected.plain_texture_samples + expected.amid_samples)
      << cam.name;
  EXPECT_DOUBLE_EQ(static_cast<double>(counted_on_edge) / counted_samples, expected.overlay_agreement) << cam.name;
  EXPECT_DOUBLE_EQ(with_samples.overlay_agreement, expected.overlay_agreement) << cam.name;
}

// Cameras the final check must refuse: 6 % off in focal length, 15 cm sideways, one floor tile along x, rolled 2 deg.
std::vector<std::pair<std::string, ic::CameraModel>> wrongCameras(const ic::CameraModel& truth)
{
  std::vector<std::pair<std::string, ic::CameraModel>> wrong;
  ic::CameraModel focal = truth;
  focal.intrinsics().fx *= 1.06;
  focal.intrinsics().fy *= 1.06;
  wrong.emplace_back("focal +6 %", focal);
  wrong.emplace_back("moved 0.15 m sideways", moved(truth, 0.15 * truth.pose().rotation.row(0).transpose()));
  wrong.emplace_back("moved one floor tile (0.5 m) along x", moved(truth, Eigen::Vector3d(0.5, 0, 0)));
  ic::CameraModel turned = truth;
  const Eigen::Matrix3d roll = Eigen::AngleAxisd(2.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  turned.pose().rotation = roll * truth.pose().rotation;
  turned.pose().translation = roll * truth.pose().translation;
  wrong.emplace_back("rolled 2 deg about its axis", turned);
  return wrong;
}
}  // namespace

TEST(ImageExplanation, TrueCameraAcceptedWrongCamerasRefused)
{
  const auto world = sim::loadWorldFile(kWorld);
  ASSERT_TRUE(world) << world.error().describe();
  const sim::Renderer renderer(*world);
  const ic::ImageExplanationOptions options = ic::FixedCameraOptions{}.explanation;
  for (const auto& cam : world->fixed_cameras)
  {
    const auto view = renderer.render(sim::ViewCamera::fromModel(cam.camera, cam.width, cam.height));
    const auto map = ic::edgesSeenInView(*world, cam.camera, view);
    const auto truth = ic::explainImage(view.rgb, cam.camera, cam.width, cam.height, map, nullptr, options);
    std::printf("%s true camera: %s; isolated %.3f of %zu\n", cam.name.c_str(), truth.describe().c_str(),
                truth.isolated_agreement, truth.isolated_samples);
    EXPECT_TRUE(ic::acceptExplanation(truth, options)) << cam.name;
    EXPECT_GT(truth.map_lines, 20u);
    EXPECT_GT(truth.isolated_agreement, 0.6) << cam.name;  // where nothing is beside them, its lines are on edges

    for (const auto& [what, camera] : wrongCameras(cam.camera))
    {
      const auto e = ic::explainImage(view.rgb, camera, cam.width, cam.height, map, nullptr, options);
      const ic::Status accepted = ic::acceptExplanation(e, options);
      std::printf("%s %s: %s; isolated %.3f of %zu\n", cam.name.c_str(), what.c_str(), e.describe().c_str(),
                  e.isolated_agreement, e.isolated_samples);
      EXPECT_FALSE(accepted) << cam.name << " " << what;
      EXPECT_LT(e.isolated_agreement, truth.isolated_agreement - 0.3) << cam.name << " " << what;
      if (!accepted)
      {
        EXPECT_NE(accepted.error().message().find("does not explain the image"), std::string::npos);
      }
    }
  }
}

// A map holds floor joints the fixed camera does not resolve (the Xtion saw them from 1-2 m): here lines through the
// middle of the floor's tiles, where the image is plain. Counted, they make two of the three true cameras fail the
// overlay test; left out as plain floor, every true camera passes and the wrong ones still fail.
TEST(ImageExplanation, UnresolvedFloorJointsDoNotRefuseTheTrueCamera)
{
  const auto world = sim::loadWorldFile(kWorld);
  ASSERT_TRUE(world) << world.error().describe();
  const sim::Renderer renderer(*world);
  // The whole-line rule (the default's by-sample rule has its own test below).
  ic::ImageExplanationOptions options = ic::FixedCameraOptions{}.explanation;
  options.plain_floor_by_sample = false;
  options.texture.min_neighbours = 0;     // the floor rule alone (texture lines: their own test)
  options.chance_mapped_radius_px = 0.0;  // nothing left out amid map lines (its own test)
  ic::ImageExplanationOptions every_floor_line = options;
  every_floor_line.leave_out_plain_floor = false;
  const std::vector<ic::Segment3d> joints = tileCentreLines(0.5, 0.0);  // 0.5 m floor tiles
  int refused_with_every_floor_line = 0;
  for (const auto& cam : world->fixed_cameras)
  {
    const auto view = renderer.render(sim::ViewCamera::fromModel(cam.camera, cam.width, cam.height));
    auto map = ic::edgesSeenInView(*world, cam.camera, view);
    map.insert(map.end(), joints.begin(), joints.end());
    const auto all = ic::explainImage(view.rgb, cam.camera, cam.width, cam.height, map, nullptr, every_floor_line);
    const auto plain_out = ic::explainImage(view.rgb, cam.camera, cam.width, cam.height, map, nullptr, options);
    std::printf("%s true camera, every floor line: %s\n  plain floor left out: %s\n", cam.name.c_str(),
                all.describe().c_str(), plain_out.describe().c_str());
    refused_with_every_floor_line += ic::acceptExplanation(all, every_floor_line) ? 0 : 1;
    expectCheckedLinesAsCounted(view.rgb, cam, map, options, plain_out);
    EXPECT_LT(all.overlay_agreement, plain_out.overlay_agreement - 0.05) << cam.name;
    EXPECT_TRUE(ic::acceptExplanation(plain_out, options)) << cam.name;
    EXPECT_GT(plain_out.plain_lines, 10u) << cam.name;
    EXPECT_EQ(all.map_lines, plain_out.map_lines + plain_out.plain_lines) << cam.name;
    ic::ImageExplanationOptions just_enough = options;  // exactly as many other lines as remain: left out
    just_enough.min_lines_without_plain_floor = plain_out.map_lines;
    EXPECT_EQ(ic::explainImage(view.rgb, cam.camera, cam.width, cam.height, map, nullptr, just_enough).plain_lines,
              plain_out.plain_lines)
        << cam.name;
    ic::ImageExplanationOptions too_few_others = options;  // one more needed than remain: every line counts
    too_few_others.min_lines_without_plain_floor = plain_out.map_lines + 1;
    const auto few = ic::explainImage(view.rgb, cam.camera, cam.width, cam.height, map, nullptr, too_few_others);
    EXPECT_EQ(few.plain_lines, 0u) << cam.name;
    EXPECT_EQ(few.samples, all.samples) << cam.name;
    ic::ImageExplanationOptions other_floor = options;  // the floor 1 m lower: no map line is a floor line
    other_floor.floor_height_m = -1.0;
    EXPECT_EQ(ic::explainImage(view.rgb, cam.camera, cam.width, cam.height, map, nullptr, other_floor).plain_lines, 0u)
        << cam.name;

    ic::CameraModel focal = cam.camera;
    focal.intrinsics().fx *= 1.06;
    focal.intrinsics().fy *= 1.06;
    for (const auto& [what, camera] :
         {std::make_pair(std::string("focal +6 %"), focal),
          std::make_pair(std::string("moved 0.15 m sideways"),
                         moved(cam.camera, 0.15 * cam.camera.pose().rotation.row(0).transpose())),
          std::make_pair(std::string("moved one floor tile (0.5 m) along x"),
                         moved(cam.camera, Eigen::Vector3d(0.5, 0, 0)))})
    {
      const auto e = ic::explainImage(view.rgb, camera, cam.width, cam.height, map, nullptr, options);
      std::printf("  %s: %s\n", what.c_str(), e.describe().c_str());
      EXPECT_FALSE(ic::acceptExplanation(e, options)) << cam.name << " " << what;
    }
  }
  EXPECT_GE(refused_with_every_floor_line, 2);  // the joints matter: cam_east and cam_desk (cam_wide sees more)
}

// A map holds a brick wall's mortar joints (both flanks of each bed joint, 1 cm apart, every 6.5 cm) that the fixed
// cameras do not resolve: here on the north wall, where the image is plain. Counted, they make the true cameras fail
// the overlay test; left out as texture where the image is plain, every true camera passes and the wrong ones still
// fail. A lone line on the same plain wall (not texture) still counts against every camera.
TEST(ImageExplanation, UnresolvedWallTextureDoesNotRefuseTheTrueCamera)
{
  const auto world = sim::loadWorldFile(kWorld);
  ASSERT_TRUE(world) << world.error().describe();
  const sim::Renderer renderer(*world);
  ic::ImageExplanationOptions options = ic::FixedCameraOptions{}.explanation;
  ASSERT_EQ(options.texture.min_neighbours, 0u);  // off by default
  options.texture.min_neighbours = 4;
  options.chance_mapped_radius_px = 0.0;  // nothing left out amid map lines (its own test)
  ic::ImageExplanationOptions no_texture = options;
  no_texture.texture.min_neighbours = 0;
  std::vector<ic::Segment3d> mortar;  // the north wall is y = 6, x 0-8
  for (double z = 0.4; z < 2.4; z += 0.065)
    for (const double flank : {0.0, 0.01})
      mortar.push_back({Eigen::Vector3d(0.5, 5.999, z + flank), Eigen::Vector3d(7.5, 5.999, z + flank)});
  const ic::Segment3d lone{Eigen::Vector3d(5.5, 5.999, 1.1), Eigen::Vector3d(5.5, 5.999, 2.3)};  // across them
  int refused_without = 0;
  for (const auto& cam : world->fixed_cameras)
  {
    const auto view = renderer.render(sim::ViewCamera::fromModel(cam.camera, cam.width, cam.height));
    auto map = ic::edgesSeenInView(*world, cam.camera, view);
    const size_t true_lines = map.size();
    map.insert(map.end(), mortar.begin(), mortar.end());
    const auto all = ic::explainImage(view.rgb, cam.camera, cam.width, cam.height, map, nullptr, no_texture);
    const auto out = ic::explainImage(view.rgb, cam.camera, cam.width, cam.height, map, nullptr, options);
    std::printf("%s true camera, every texture line: %s\n  plain texture left out: %s\n", cam.name.c_str(),
                all.describe().c_str(), out.describe().c_str());
    if (out.plain_texture_samples < 1000)  // this camera sees little of the north wall
      continue;
    refused_without += ic::acceptExplanation(all, no_texture) ? 0 : 1;
    expectCheckedLinesAsCounted(view.rgb, cam, map, options, out);
    EXPECT_TRUE(ic::acceptExplanation(out, options)) << cam.name;
    EXPECT_GT(out.plain_texture_samples, 100u) << cam.name;
    EXPECT_LT(all.overlay_agreement, out.overlay_agreement - 0.05) << cam.name;

    map.push_back(lone);  // counted where the wall is plain: the agreement drops
    const auto with_lone = ic::explainImage(view.rgb, cam.camera, cam.width, cam.height, map, nullptr, options);
    EXPECT_LT(with_lone.overlay_agreement, out.overlay_agreement) << cam.name;
    EXPECT_EQ(with_lone.plain_texture_samples, out.plain_texture_samples) << cam.name;
    map.pop_back();
    for (const auto& [what, camera] : wrongCameras(cam.camera))
    {
      const auto e = ic::explainImage(view.rgb, camera, cam.width, cam.height, map, nullptr, options);
      std::printf("  %s: %s\n", what.c_str(), e.describe().c_str());
      EXPECT_FALSE(ic::acceptExplanation(e, options)) << cam.name << " " << what;
    }
    EXPECT_GT(true_lines, 0u);
  }
  EXPECT_GE(refused_without, 1);  // the joints matter
}

// A camera that sees none of the map lines (here: turned to face away from them all, as a wrong camera behind a wall
// whose lines the measured surfaces all hide would) has nothing that speaks for it: refused. Without an image nothing
// was checked: not refused for that.
TEST(ImageExplanation, NoMapLineToCheckIsRefused)
{
  const auto world = sim::loadWorldFile(kWorld);
  ASSERT_TRUE(world) << world.error().describe();
  const sim::Renderer renderer(*world);
  const ic::ImageExplanationOptions options = ic::FixedCameraOptions{}.explanation;
  const auto& cam = world->fixed_cameras.front();
  const auto view = renderer.render(sim::ViewCamera::fromModel(cam.camera, cam.width, cam.height));
  const auto map = ic::edgesSeenInView(*world, cam.camera, view);
  ASSERT_FALSE(map.empty());
  ic::CameraModel away = cam.camera;  // turned 180 deg about the vertical through its centre
  const Eigen::Matrix3d half_turn = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Vector3d centre = cam.camera.pose().center();
  away.pose().rotation = cam.camera.pose().rotation * half_turn.transpose();
  away.pose().translation = -away.pose().rotation * centre;
  ASSERT_LT((away.pose().center() - centre).norm(), 1e-9);
  const auto e = ic::explainImage(view.rgb, away, cam.width, cam.height, map, nullptr, options);
  EXPECT_TRUE(e.image_checked);
  EXPECT_EQ(e.samples, 0u);
  const ic::Status refused = ic::acceptExplanation(e, options);
  ASSERT_FALSE(refused);
  EXPECT_NE(refused.error().message().find("sees none of the map lines"), std::string::npos);

  const auto unchecked = ic::explainImage(cv::Mat(), away, cam.width, cam.height, map, nullptr, options);
  EXPECT_FALSE(unchecked.image_checked);
  EXPECT_TRUE(ic::acceptExplanation(unchecked, options));
}

// A camera whose lines meet edges often (here 85 %, where floor and ceiling rules left out the samples that would
// speak against it) but miss them where the image beside them is plain is refused, given enough such samples.
TEST(ImageExplanation, LinesMissingEdgesWherePlainAroundAreRefused)
{
  const ic::ImageExplanationOptions options = ic::FixedCameraOptions{}.explanation;
  ic::ImageExplanation e;
  e.image_checked = true;
  e.map_lines = 120;
  e.samples = 4000;
  e.overlay_agreement = 0.85;
  e.overlay_chance = 0.1;
  e.isolated_samples = options.min_isolated_samples + 100;
  e.isolated_agreement = 0.1;
  const ic::Status refused = ic::acceptExplanation(e, options);
  ASSERT_FALSE(refused);
  EXPECT_NE(refused.error().message().find("where the image beside them is plain"), std::string::npos)
      << refused.error().message();
  EXPECT_NE(refused.error().message().find("10 % of 300 samples"), std::string::npos) << refused.error().message();
  ic::ImageExplanation plain_around = e;  // a right camera's lines lie on edges there
  plain_around.isolated_agreement = 0.5;
  EXPECT_TRUE(ic::acceptExplanation(plain_around, options));
  ic::ImageExplanation few = e;  // too few such samples to judge on
  few.isolated_samples = options.min_isolated_samples - 1;
  EXPECT_TRUE(ic::acceptExplanation(few, options));
  ic::ImageExplanationOptions off = options;
  off.min_isolated_agreement = 0.0;
  EXPECT_TRUE(ic::acceptExplanation(e, off));
}

// Floor samples left out one by one where the floor looks plain there (plain_floor_by_sample): the true cameras are
// still accepted and the wrong ones still refused; what is left out is exactly the floor lines' samples without an
// edge on or beside them (the samples on an edge are those of every floor line counted).
TEST(ImageExplanation, PlainFloorSamplesLeftOutOneByOne)
{
  const auto world = sim::loadWorldFile(kWorld);
  ASSERT_TRUE(world) << world.error().describe();
  const sim::Renderer renderer(*world);
  ic::ImageExplanationOptions by_sample = ic::FixedCameraOptions{}.explanation;
  by_sample.plain_floor_by_sample = true;
  by_sample.texture.min_neighbours = 0;     // the floor rule alone (texture lines: their own test)
  by_sample.chance_mapped_radius_px = 0.0;  // nothing left out amid map lines (its own test)
  ic::ImageExplanationOptions every_floor_line = by_sample;
  every_floor_line.leave_out_plain_floor = false;
  size_t left_out_samples = 0;
  for (const auto& cam : world->fixed_cameras)
  {
    const auto view = renderer.render(sim::ViewCamera::fromModel(cam.camera, cam.width, cam.height));
    const auto map = ic::edgesSeenInView(*world, cam.camera, view);
    const auto e = ic::explainImage(view.rgb, cam.camera, cam.width, cam.height, map, nullptr, by_sample);
    const auto all = ic::explainImage(view.rgb, cam.camera, cam.width, cam.height, map, nullptr, every_floor_line);
    std::printf("%s by sample: %s\n", cam.name.c_str(), e.describe().c_str());
    EXPECT_TRUE(ic::acceptExplanation(e, by_sample)) << cam.name;
    EXPECT_GT(e.overlay_agreement, all.overlay_agreement) << cam.name;
    const double on = e.overlay_agreement * e.samples;  // the same samples on an edge
    EXPECT_NEAR(on, all.overlay_agreement * all.samples, 1e-6) << cam.name;
    std::vector<ic::EdgeSamples> checked;  // the same samples assessed
    ic::explainImage(view.rgb, cam.camera, cam.width, cam.height, map, nullptr, by_sample, &checked);
    size_t assessed = 0;
    for (const ic::EdgeSamples& line : checked)
      assessed += line.points.size();
    EXPECT_EQ(assessed, all.samples) << cam.name;
    expectCheckedLinesAsCounted(view.rgb, cam, map, by_sample, e);
    left_out_samples += e.plain_floor_samples;
    for (const auto& [what, camera] : wrongCameras(cam.camera))
    {
      const auto w = ic::explainImage(view.rgb, camera, cam.width, cam.height, map, nullptr, by_sample);
      std::printf("  %s: %s\n", what.c_str(), w.describe().c_str());
      EXPECT_FALSE(ic::acceptExplanation(w, by_sample)) << cam.name << " " << what;
    }
  }
  EXPECT_GT(left_out_samples, 100u);  // the floor's joints are not all resolved
}

// A map holds ceiling joints the fixed cameras do not resolve (an Xtion pitched up mapped them from below): here lines
// through the middle of 0.3 m ceiling tiles. With the ceiling unknown they count against the true cameras that see
// the ceiling; with the survey's ceiling height they are tested as floor lines are, left out where the image looks
// plain, and the wrong cameras still fail; another height, or the rule off, leaves them counted.
TEST(ImageExplanation, UnresolvedCeilingJointsAreTestedAsFloorJoints)
{
  const auto world = sim::loadWorldFile(kWorld);
  ASSERT_TRUE(world) << world.error().describe();
  const sim::Renderer renderer(*world);
  ic::ImageExplanationOptions unknown = ic::FixedCameraOptions{}.explanation;
  ASSERT_FALSE(unknown.ceiling_height_m);
  unknown.chance_mapped_radius_px = 0.0;  // nothing left out amid map lines (its own test)
  ic::ImageExplanationOptions known = unknown;
  known.ceiling_height_m = 3.0;
  ic::ImageExplanationOptions off = known;
  off.plain_ceiling = false;
  ic::ImageExplanationOptions elsewhere = known;
  elsewhere.ceiling_height_m = 2.5;
  const std::vector<ic::Segment3d> joints = tileCentreLines(0.3, 3.0);  // 0.3 m ceiling tiles
  int seeing_the_ceiling = 0;
  for (const auto& cam : world->fixed_cameras)
  {
    const auto view = renderer.render(sim::ViewCamera::fromModel(cam.camera, cam.width, cam.height));
    auto map = ic::edgesSeenInView(*world, cam.camera, view);
    const auto without = ic::explainImage(view.rgb, cam.camera, cam.width, cam.height, map, nullptr, unknown);
    map.insert(map.end(), joints.begin(), joints.end());
    const auto counted = ic::explainImage(view.rgb, cam.camera, cam.width, cam.height, map, nullptr, unknown);
    if (counted.samples <= without.samples + 20)
      continue;  // hardly any ceiling in its view
    ++seeing_the_ceiling;
    const auto left_out = ic::explainImage(view.rgb, cam.camera, cam.width, cam.height, map, nullptr, known);
    std::printf("%s true camera, ceiling unknown: %s\n  ceiling known: %s\n", cam.name.c_str(),
                counted.describe().c_str(), left_out.describe().c_str());
    // (This world's ceiling is textured: many joint samples find an edge by chance, so the gain is a few points.)
    EXPECT_LT(counted.overlay_agreement, left_out.overlay_agreement - 0.02) << cam.name;
    EXPECT_TRUE(ic::acceptExplanation(left_out, known)) << cam.name;
    EXPECT_GT(left_out.plain_floor_samples, counted.plain_floor_samples + 20) << cam.name;
    expectCheckedLinesAsCounted(view.rgb, cam, map, known, left_out);
    for (const auto& same : {off, elsewhere})
      EXPECT_EQ(ic::explainImage(view.rgb, cam.camera, cam.width, cam.height, map, nullptr, same).samples,
                counted.samples)
          << cam.name;
    ic::CameraModel focal = cam.camera;
    focal.intrinsics().fx *= 1.06;
    focal.intrinsics().fy *= 1.06;
    for (const auto& camera : {focal, moved(cam.camera, 0.15 * cam.camera.pose().rotation.row(0).transpose())})
      EXPECT_FALSE(
          ic::acceptExplanation(ic::explainImage(view.rgb, camera, cam.width, cam.height, map, nullptr, known), known))
          << cam.name;
  }
  EXPECT_GE(seeing_the_ceiling, 1);
}

// A line along one of the default world's walls (x = 0 or 8, y = 0 or 6).
bool onRoomBorder(const ic::Segment3d& line)
{
  const auto along = [&](int axis, double at) {
    return std::abs(line.a[axis] - at) < 0.01 && std::abs(line.b[axis] - at) < 0.01;
  };
  return along(0, 0.0) || along(0, 8.0) || along(1, 0.0) || along(1, 6.0);
}

// Only a grid of ceiling lines is tested as floor joints: the ceiling's borders with the walls and a lone line across
// plain ceiling (here through the middle of the room, where a wrong camera's stray line could fall) count in full,
// with the ceiling known as without it.
TEST(ImageExplanation, LoneCeilingLinesAlwaysCount)
{
  const auto world = sim::loadWorldFile(kWorld);
  ASSERT_TRUE(world) << world.error().describe();
  const sim::Renderer renderer(*world);
  ic::ImageExplanationOptions known = ic::FixedCameraOptions{}.explanation;
  known.ceiling_height_m = 3.0;
  ic::ImageExplanationOptions off = known;
  off.plain_ceiling = false;
  const ic::Segment3d lone{Eigen::Vector3d(0.5, 3.15, 3.0), Eigen::Vector3d(7.5, 3.15, 3.0)};
  int seeing_it = 0;
  for (const auto& cam : world->fixed_cameras)
  {
    const auto view = renderer.render(sim::ViewCamera::fromModel(cam.camera, cam.width, cam.height));
    std::vector<ic::Segment3d> map;  // the ceiling's checker joints left out: its borders alone on the ceiling
    for (const ic::Segment3d& edge : ic::edgesSeenInView(*world, cam.camera, view))
      if (std::min(edge.a.z(), edge.b.z()) < 2.95 || onRoomBorder(edge))
        map.push_back(edge);
    const auto borders = ic::explainImage(view.rgb, cam.camera, cam.width, cam.height, map, nullptr, known);
    EXPECT_EQ(borders.samples, ic::explainImage(view.rgb, cam.camera, cam.width, cam.height, map, nullptr, off).samples)
        << cam.name;
    map.push_back(lone);
    const auto with_lone = ic::explainImage(view.rgb, cam.camera, cam.width, cam.height, map, nullptr, known);
    if (with_lone.samples < borders.samples + 20)
      continue;  // the line is not in its view
    ++seeing_it;
    EXPECT_EQ(with_lone.samples,
              ic::explainImage(view.rgb, cam.camera, cam.width, cam.height, map, nullptr, off).samples)
        << cam.name;
    EXPECT_EQ(with_lone.plain_floor_samples, borders.plain_floor_samples) << cam.name;
    EXPECT_LT(with_lone.overlay_agreement, borders.overlay_agreement) << cam.name;  // it finds hardly any edge
  }
  EXPECT_GE(seeing_it, 1);
}

// A faint crease (two faces painted alike: a 6 grey-level step blurred over a few px, under the per-sample gradient
// threshold, in image noise): averaged along the map line on it, the step counts its samples as on an edge; the same
// line on plain image, on a smooth lighting gradient, or 10 px beside the crease finds none; off (0), none either.
TEST(ImageExplanation, AFaintCreaseFoundByTheStepAveragedAlongTheLine)
{
  const int width = 640, height = 480;
  const ic::CameraModel camera({500.0, 500.0, 0.0, 320.0, 240.0}, {0.0, {320.0, 240.0}}, {});
  cv::Mat image(height, width, CV_32FC1);
  for (int row = 0; row < height; ++row)
    for (int col = 0; col < width; ++col)  // the crease at u = 320; a lighting gradient over the right half
      image.at<float>(row, col) = 120.0f + (col >= 320 ? 6.0f : 0.0f) + (col > 480 ? 0.3f * (col - 480) : 0.0f);
  cv::GaussianBlur(image, image, cv::Size(0, 0), 1.5);
  cv::Mat noise(height, width, CV_32FC1);
  cv::RNG(7).fill(noise, cv::RNG::NORMAL, 0.0, 2.0);
  image += noise;
  image.convertTo(image, CV_8UC1);
  // A vertical map line 5 m in front of the camera at image column u (200 px long).
  const auto line_at = [&](double u) {
    const double x = 5.0 * (u - 320.0) / 500.0;
    return std::vector<ic::Segment3d>{{Eigen::Vector3d(x, -1.0, 5.0), Eigen::Vector3d(x, 1.0, 5.0)}};
  };
  ic::ImageExplanationOptions options = ic::FixedCameraOptions{}.explanation;
  const auto agreement = [&](double u) {
    const auto e = ic::explainImage(image, camera, width, height, line_at(u), nullptr, options);
    EXPECT_GT(e.samples, 50u) << "u " << u;
    return e.overlay_agreement;
  };
  EXPECT_GT(agreement(319.5), 0.9);
  EXPECT_LT(agreement(150.0), 0.1);  // plain
  EXPECT_LT(agreement(560.0), 0.1);  // the lighting gradient
  EXPECT_LT(agreement(330.0), 0.1);  // beside the crease
  options.faint_edge_gradient = 0.0;
  EXPECT_LT(agreement(319.5), 0.1);  // one by one the samples find no edge
}

namespace
{
// A synthetic view of a wall with a joint texture: dark joints (1 px, blurred) every period_px over columns 100-400,
// painted over rows 100-300, and a bright box at columns 460-600, in image noise; and the map lines of a camera
// shifted by shift_px right and down: every joint over rows 100-379 (the lower part finds no edge: a right camera
// misses some map lines too) and the box's four edges, on a vertical plane 5 m in front of a 500 px camera.
struct TexturedView
{
  cv::Mat image;
  std::vector<ic::Segment3d> map;
  ic::CameraModel camera{{500.0, 500.0, 0.0, 320.0, 240.0}, {0.0, {320.0, 240.0}}, {}};
};

TexturedView texturedWall(double period_px, double shift_px)
{
  TexturedView v;
  cv::Mat image(480, 640, CV_32FC1, cv::Scalar(128.0f));
  for (double u = 100.0; u <= 400.0; u += period_px)
    image(cv::Rect(static_cast<int>(u), 100, 1, 200)).setTo(80.0f);
  image(cv::Rect(460, 150, 141, 201)).setTo(200.0f);
  cv::GaussianBlur(image, image, cv::Size(0, 0), 0.7);
  cv::Mat noise(480, 640, CV_32FC1);
  cv::RNG(11).fill(noise, cv::RNG::NORMAL, 0.0, 2.0);
  image += noise;
  image.convertTo(v.image, CV_8UC1);
  // The wall point seen at pixel (u, row) + the shift along both.
  const auto at = [&](double u, double row) {
    return Eigen::Vector3d(5.0 * (u + shift_px - 320.0) / 500.0, 5.0 * (row + shift_px - 240.0) / 500.0, 5.0);
  };
  for (double u = 100.0; u <= 400.0; u += period_px)
    v.map.push_back({at(u, 100.0), at(u, 379.0)});
  v.map.push_back({at(459.5, 149.5), at(459.5, 350.5)});
  v.map.push_back({at(600.5, 149.5), at(600.5, 350.5)});
  v.map.push_back({at(459.5, 149.5), at(600.5, 149.5)});
  v.map.push_back({at(459.5, 350.5), at(600.5, 350.5)});
  return v;
}
}  // namespace

// A wall whose texture the map holds (joints 6 px apart): 4 px beside each joint line lies the next joint's edge, an
// edge the camera explains. Counted as chance, it refuses the right camera; measured clear of the other map lines'
// projections, the joints' samples have no place to measure it and are left out, and the rest decide. Cameras
// shifted by half a joint spacing (3 px right and down: its lines between the joints, its box off the box) and by
// 40 px stay refused. Joints 12 px apart leave room between them: none of theirs is left out.
TEST(ImageExplanation, TheChanceLevelIsMeasuredClearOfOtherMapLines)
{
  ic::ImageExplanationOptions options = ic::FixedCameraOptions{}.explanation;
  ic::ImageExplanationOptions off = options;
  off.chance_mapped_radius_px = 0.0;
  const auto explain = [&](double period_px, double shift_px, const ic::ImageExplanationOptions& o) {
    const TexturedView v = texturedWall(period_px, shift_px);
    return ic::explainImage(v.image, v.camera, 640, 480, v.map, nullptr, o);
  };
  const ic::ImageExplanation right = explain(6.0, 0.0, options), right_off = explain(6.0, 0.0, off);
  EXPECT_GT(right_off.overlay_chance, 0.5) << right_off.describe();
  EXPECT_FALSE(ic::acceptExplanation(right_off, options)) << right_off.describe();
  EXPECT_EQ(right_off.amid_samples, 0u);
  EXPECT_GT(right.amid_samples, 3000u) << right.describe();
  EXPECT_LT(right.overlay_chance, 0.1) << right.describe();
  EXPECT_GT(right.overlay_agreement, 0.7) << right.describe();
  EXPECT_TRUE(ic::acceptExplanation(right, options)) << right.describe();
  for (const double shift_px : {3.0, 40.0})
  {
    const ic::ImageExplanation wrong = explain(6.0, shift_px, options);
    EXPECT_FALSE(ic::acceptExplanation(wrong, options)) << "shift " << shift_px << ": " << wrong.describe();
  }
  // Joints 12 px apart: none of theirs left out; only a few at the box's corners, whose place on one side lies in the
  // band of the edge meeting them (chance_needs_both_sides).
  const ic::ImageExplanation sparse = explain(12.0, 0.0, options), sparse_off = explain(12.0, 0.0, off);
  EXPECT_LE(sparse.amid_samples, 12u) << sparse.describe();
  EXPECT_EQ(sparse.samples + sparse.amid_samples, sparse_off.samples);
  EXPECT_NEAR(sparse.overlay_agreement, sparse_off.overlay_agreement, 0.005);
}

// The joints at the texture's two borders (u = 100 and u = 400) have a clear place on their outer side only: counted
// with either side clear, left out with both needed (chance_needs_both_sides), about 93 samples each (rows 100-379 at
// 3 px); every joint inside is left out either way, and the verdicts stay.
TEST(ImageExplanation, WithBothSidesNeededTheTexturesBorderLinesAreLeftOut)
{
  ic::ImageExplanationOptions both = ic::FixedCameraOptions{}.explanation, either = both;
  EXPECT_TRUE(both.chance_needs_both_sides);  // the default
  either.chance_needs_both_sides = false;
  const auto explain = [&](double shift_px, const ic::ImageExplanationOptions& o) {
    const TexturedView v = texturedWall(6.0, shift_px);
    return ic::explainImage(v.image, v.camera, 640, 480, v.map, nullptr, o);
  };
  const ic::ImageExplanation right_either = explain(0.0, either), right_both = explain(0.0, both);
  const size_t more = right_both.amid_samples - right_either.amid_samples;
  EXPECT_GT(right_both.amid_samples, right_either.amid_samples);
  EXPECT_GE(more, 170u) << right_both.describe();
  EXPECT_LE(more, 200u) << right_both.describe();
  EXPECT_EQ(right_both.samples + more, right_either.samples);
  EXPECT_TRUE(ic::acceptExplanation(right_both, both)) << right_both.describe();
  for (const double shift_px : {3.0, 40.0})
  {
    const ic::ImageExplanation wrong = explain(shift_px, both);
    EXPECT_FALSE(ic::acceptExplanation(wrong, both)) << "shift " << shift_px << ": " << wrong.describe();
  }
}
