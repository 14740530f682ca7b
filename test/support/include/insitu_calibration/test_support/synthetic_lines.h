// Synthetic cameras and line correspondences with known truth, for tests, benchmarks and the bundled example.
// Every random choice comes from the caller's seeded generator.
#ifndef INSITU_CALIBRATION_TEST_SUPPORT_SYNTHETIC_LINES_H
#define INSITU_CALIBRATION_TEST_SUPPORT_SYNTHETIC_LINES_H

#include <random>
#include <vector>

#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/geometry/segment.h"
#include "insitu_calibration/solvers/correspondences.h"

namespace insitu_calibration
{
struct SyntheticCameraOptions
{
  int image_width = 1280;
  int image_height = 960;
  double focal_min_px = 700.0;
  double focal_max_px = 1400.0;
  double aspect_jitter = 0.02;        // fy = fx (1 + u), |u| <= jitter
  double principal_jitter_px = 30.0;  // principal point offset from the image centre
  // Radial displacement of the image corner by the division model, in px (negative: barrel).
  double corner_displacement_px = -15.0;
  double height_m = 2.7;       // camera height above the floor (z up in the world)
  double tilt_min_deg = 15.0;  // looking down
  double tilt_max_deg = 40.0;
};

// A camera mounted like a surveillance camera: in the corner region of a room, looking down into it.
CameraModel randomCamera(const SyntheticCameraOptions& options, std::mt19937& rng);

struct SyntheticLineOptions
{
  int lines = 40;
  int image_points_per_line = 2;  // >= 2: a polyline along the distorted image of the segment
  int world_points_per_line = 2;  // >= 1: evenly spaced along the 3D segment, end points included
  double image_noise_px = 0.0;    // isotropic Gaussian noise on every image point
  double world_noise_m = 0.0;     // isotropic Gaussian noise on every world point
  double depth_min_m = 1.5;
  double depth_max_m = 8.0;
  double min_image_length_px = 60.0;
  double margin_px = 5.0;     // segments stay this far inside the image
  bool axis_aligned = false;  // building-like directions (x, y, z of the world) instead of random ones
};

struct SyntheticLines
{
  std::vector<Segment3d> segments;  // the true 3D segments
  CorrespondenceSet data;           // noisy correspondences
};

// Segments in front of the camera whose whole image lies inside the frame.
SyntheticLines makeSyntheticLines(const CameraModel& camera, int image_width, int image_height,
                                  const SyntheticLineOptions& options, std::mt19937& rng);

// Point correspondences from the segments' end points, with the same noise model.
std::vector<PointCorrespondence> endPointCorrespondences(const CameraModel& camera,
                                                         const std::vector<Segment3d>& segments, double image_noise_px,
                                                         std::mt19937& rng);

// Hand-clicked / surveyed data as calibrate_lines gets it (issue 13): every line with its own number of image points
// (a dense polyline) and of world points, both noisy, segments of a given 3D length.
struct DensePolylineOptions
{
  int lines = 40;
  int image_points_min = 2;
  int image_points_max = 12;
  int world_points_min = 2;
  int world_points_max = 6;
  double segment_min_m = 0.5;
  double segment_max_m = 2.0;
  double min_image_length_px = 80.0;
  double image_noise_px = 1.0;
  double world_noise_m = 0.003;
};
SyntheticLines makeDensePolylines(const CameraModel& camera, int image_width, int image_height,
                                  const DensePolylineOptions& options, std::mt19937& rng);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_TEST_SUPPORT_SYNTHETIC_LINES_H
