// The surfaces the survey's depth measured, inserted again under the map adjustment's corrected keyframe poses
// (rebuildSurfaces, map/line_map_adjustment.h), against geometry known exactly: a wall seen from keyframes whose tf
// poses carry a localiser's error (2 cm, 0.5 deg) is smeared at those poses, and comes back exactly as at the true
// poses when the corrections undo the error; the thinned samples a keyframe keeps lose none of the wall.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "insitu_calibration/map/line_map_adjustment.h"
#include "insitu_calibration/test_support/test_helpers.h"

namespace ic = insitu_calibration;

namespace
{
// The depth a camera at the true pose measures of the wall y = 0 (exact, 0 where the ray misses it), posed at tf.
ic::RgbdFrame wallFrame(const Eigen::Isometry3d& truth, const Eigen::Isometry3d& tf)
{
  ic::RgbdFrame frame;
  frame.camera.width = 160;
  frame.camera.height = 120;
  frame.camera.intrinsics.fx = frame.camera.intrinsics.fy = 140.0;
  frame.camera.intrinsics.cx = 79.5;
  frame.camera.intrinsics.cy = 59.5;
  frame.depth = cv::Mat(120, 160, CV_32FC1, cv::Scalar(0.0f));
  for (int row = 0; row < 120; ++row)
    for (int col = 0; col < 160; ++col)
    {
      const Eigen::Vector3d ray = truth.linear() * frame.camera.normalize(Eigen::Vector2d(col, row)).homogeneous();
      const double s = -truth.translation().y() / ray.y();  // ray (x, y, 1): s is the depth z
      if (s > 0.0)
        frame.depth.at<float>(row, col) = static_cast<float>(s);
    }
  frame.T_map_camera = tf;
  return frame;
}

struct WallSurvey
{
  std::vector<ic::Keyframe> keyframes;        // at tf's poses, with their depth samples
  std::vector<ic::PoseCorrection> undo;       // the corrections that bring tf's poses back to the truth
  std::vector<Eigen::Isometry3d> true_poses;  //
};

// Keyframes along a route 1.5 m from the wall, looking 40 degrees towards it, tf off by a localiser's error.
WallSurvey makeWallSurvey(const ic::SurfaceVoxels& sampler)
{
  std::mt19937 rng(1111);
  std::normal_distribution<double> n(0.0, 1.0);
  WallSurvey s;
  for (int k = 0; k < 12; ++k)
  {
    const Eigen::Isometry3d truth = ic::test::levelCameraPose(0.25 * k, 1.5, -40.0 * M_PI / 180.0);
    const ic::PoseCorrection error{0.02 * n(rng), 0.02 * n(rng), 0.5 * M_PI / 180.0 * n(rng)};
    ic::Keyframe kf;
    kf.T_map_camera = error.apply(truth);
    kf.surface = sampler.depthSamples(wallFrame(truth, kf.T_map_camera), sampler.options().kept_cell_m);
    s.keyframes.push_back(kf);
    s.undo.push_back({-error.x, -error.y, -error.yaw});
    s.true_poses.push_back(truth);
  }
  return s;
}

// How many of the probes (a grid over the wall's neighbourhood) are occupied in a but not in b.
int occupiedOnlyIn(const ic::SurfaceVoxels& a, const ic::SurfaceVoxels& b)
{
  int count = 0;
  for (double x = -1.0; x < 8.0; x += 0.025)
    for (double y = -0.3; y < 0.3; y += 0.0125)
      for (double z = 0.0; z < 2.5; z += 0.1)
        count += a.occupied({x, y, z}) && !b.occupied({x, y, z});
  return count;
}
}  // namespace

TEST(AdjustedSurfaces, SamplesInsertedUnderThePoseAreTheDepthInsertedThere)
{
  const Eigen::Isometry3d pose = ic::test::levelCameraPose(0.3, 1.5, -0.7);
  const ic::RgbdFrame frame = wallFrame(pose, pose);
  ic::SurfaceVoxelOptions every_pixel;
  every_pixel.pixel_step = 1;  // samples 0.7 cm apart per metre of range: up to 3.5 m, several in a 2.5 cm cell
  ic::SurfaceVoxels direct(every_pixel), sampled(every_pixel), thinned(every_pixel);
  direct.insertDepth(frame);
  sampled.insertSamples(pose, sampled.depthSamples(frame));
  thinned.insertSamples(pose, thinned.depthSamples(frame, thinned.options().kept_cell_m));
  ASSERT_GT(direct.size(), 100u);
  EXPECT_EQ(sampled.size(), direct.size());
  EXPECT_EQ(occupiedOnlyIn(direct, sampled), 0);
  // Thinned to one sample per 2.5 cm cell: at most a few per cent of the voxels (those a surface grazes) lost.
  EXPECT_LT(thinned.depthSamples(frame, 0.025).size(), thinned.depthSamples(frame).size());
  EXPECT_GT(static_cast<double>(thinned.size()), 0.97 * static_cast<double>(direct.size()));
  EXPECT_EQ(occupiedOnlyIn(thinned, direct), 0);
}

TEST(AdjustedSurfaces, CorrectedPosesUndoTheLocalisersSmear)
{
  const ic::SurfaceVoxels sampler;
  const WallSurvey s = makeWallSurvey(sampler);
  std::vector<ic::Keyframe> at_truth = s.keyframes;
  for (size_t k = 0; k < at_truth.size(); ++k)
    at_truth[k].T_map_camera = s.true_poses[k];
  const ic::SurfaceVoxels truth = ic::rebuildSurfaces(at_truth, {}, sampler.options());
  const ic::SurfaceVoxels smeared = ic::rebuildSurfaces(s.keyframes, {}, sampler.options());
  const ic::SurfaceVoxels corrected = ic::rebuildSurfaces(s.keyframes, s.undo, sampler.options());

  EXPECT_EQ(corrected.size(), truth.size());
  EXPECT_EQ(occupiedOnlyIn(corrected, truth), 0);
  EXPECT_EQ(occupiedOnlyIn(truth, corrected), 0);
  // At tf's poses the wall is smeared: thicker, with voxels the truth does not have.
  EXPECT_GT(smeared.size(), truth.size() + truth.size() / 10);
  EXPECT_GT(occupiedOnlyIn(smeared, truth), 100);
}
