// Error measures used everywhere: reprojection errors against the data, and errors of a camera against the truth
// (the paper's Sec. 5 measures).
#ifndef INSITU_CALIBRATION_METRICS_H
#define INSITU_CALIBRATION_METRICS_H

#include <vector>

#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/solvers/correspondences.h"

namespace insitu_calibration
{
// Distance in pixels from a point to an image polyline whose first and last parts extend to infinity (a 3D line's
// points may project beyond the detected segment's ends): the smallest distance to a part.
double distanceToPolyline(const Eigen::Vector2d& point, const std::vector<Eigen::Vector2d>& polyline);

struct ReprojectionStats
{
  double rms_px = 0.0;
  double median_px = 0.0;
  double max_px = 0.0;
  double mse_px2 = 0.0;  // the paper's epsilon = sum of squared errors / N
  size_t count = 0;
  size_t unprojectable = 0;  // world points behind the camera or outside the division model's domain
};

// One residual per (line, world point): the distance of its distorted projection to the image polyline; plus one
// per point correspondence: the distance of its projection to the image point.
std::vector<double> lineResiduals(const CameraModel& camera, const LineCorrespondence& line);
ReprojectionStats reprojectionStats(const CameraModel& camera, const CorrespondenceSet& data, bool use_lines = true,
                                    bool use_points = true);
ReprojectionStats summarize(std::vector<double> residuals, size_t unprojectable = 0);

// (f_true - f_est) / f_true on fx, as the paper's e_f.
double relativeFocalError(const Intrinsics& truth, const Intrinsics& estimate);
// The angle of R1^T R2 in radians, equal to the paper's ||logm(R1^T R2)||_F / sqrt(2).
double rotationDistance(const Eigen::Matrix3d& r1, const Eigen::Matrix3d& r2);
// Distance between optical centres in metres.
double centerDistance(const CameraPose& a, const CameraPose& b);

struct CameraErrors
{
  double focal_relative = 0.0;  // signed, fx
  double rotation_rad = 0.0;
  double center_m = 0.0;
  double principal_point_px = 0.0;
  double lambda_relative = 0.0;  // |lambda_est - lambda_true| / |lambda_true|, absolute difference when truth is 0
};
CameraErrors compareCameras(const CameraModel& truth, const CameraModel& estimate);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_METRICS_H
