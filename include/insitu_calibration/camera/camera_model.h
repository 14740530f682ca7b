// Pin-hole camera with Fitzgibbon's one-parameter division model of radial distortion.
//
// World point X (metres, world frame) -> camera frame X_c = R X + t (REP 103 optical frame: z forward, x right,
// y down) -> undistorted pixel m_u = K X_c / z -> distorted pixel m_d with
//   m_u - c = (m_d - c) / (1 + lambda |m_d - c|^2)
// where c is the distortion centre (normally the principal point) and lambda is in 1/px^2 (barrel: lambda < 0).
// Pixel (0,0) is the centre of the top-left pixel.
#ifndef INSITU_CALIBRATION_CAMERA_CAMERA_MODEL_H
#define INSITU_CALIBRATION_CAMERA_CAMERA_MODEL_H

#include <optional>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace insitu_calibration
{
using Matrix34d = Eigen::Matrix<double, 3, 4>;

struct Intrinsics
{
  double fx = 1.0;
  double fy = 1.0;
  double skew = 0.0;
  double cx = 0.0;
  double cy = 0.0;

  Eigen::Matrix3d matrix() const;
  static Intrinsics fromMatrix(const Eigen::Matrix3d& k);
  Eigen::Vector2d principalPoint() const { return {cx, cy}; }
};

// The centre of a width x height image (pixel (0,0) is the centre of the top-left pixel): the principal point and
// distortion centre assumed before calibration.
inline Eigen::Vector2d imageCenter(int width, int height)
{
  return {0.5 * (width - 1), 0.5 * (height - 1)};
}

// Fitzgibbon's division model. Stateless maths on pixel coordinates.
struct DivisionModel
{
  double lambda = 0.0;                               // 1/px^2
  Eigen::Vector2d center = Eigen::Vector2d::Zero();  // px

  // Distorted -> undistorted pixel. Always defined except where 1 + lambda r^2 = 0 (then nullopt).
  std::optional<Eigen::Vector2d> undistort(const Eigen::Vector2d& distorted) const;
  // Undistorted -> distorted pixel: the root of lambda r_u r_d^2 - r_d + r_u = 0 that tends to r_u as lambda -> 0.
  // For lambda > 0 it exists only while 4 lambda r_u^2 <= 1 (nullopt beyond).
  std::optional<Eigen::Vector2d> distort(const Eigen::Vector2d& undistorted) const;
};

// lambda such that the image corner farthest from center moves radially by displacement_px (negative: inwards,
// barrel), the way distortion is specified for simulated cameras (0 px at the corner: no distortion).
double lambdaForCornerDisplacement(const Eigen::Vector2d& center, int width, int height, double displacement_px);

// World-to-camera transform: X_c = rotation * X_w + translation.
struct CameraPose
{
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  // Optical centre in the world frame.
  Eigen::Vector3d center() const { return -rotation.transpose() * translation; }
  // Pose of the camera (optical frame) in the world: the transform camera -> world.
  Eigen::Isometry3d worldFromCamera() const;
  static CameraPose fromWorldFromCamera(const Eigen::Isometry3d& world_from_camera);
};

class CameraModel
{
public:
  CameraModel() = default;
  CameraModel(const Intrinsics& intrinsics, const DivisionModel& distortion, const CameraPose& pose)
      : intrinsics_(intrinsics), distortion_(distortion), pose_(pose)
  {}

  const Intrinsics& intrinsics() const { return intrinsics_; }
  const DivisionModel& distortion() const { return distortion_; }
  const CameraPose& pose() const { return pose_; }
  Intrinsics& intrinsics() { return intrinsics_; }
  DivisionModel& distortion() { return distortion_; }
  CameraPose& pose() { return pose_; }

  // P = K [R | t]: world metres to undistorted pixels.
  Matrix34d projectionMatrix() const;

  // World point -> camera frame.
  Eigen::Vector3d toCamera(const Eigen::Vector3d& world) const { return pose_.rotation * world + pose_.translation; }
  // World point -> undistorted pixel; nullopt when the point is not in front of the camera.
  std::optional<Eigen::Vector2d> projectUndistorted(const Eigen::Vector3d& world) const;
  // World point -> distorted pixel; nullopt behind the camera or outside the division model's domain.
  std::optional<Eigen::Vector2d> project(const Eigen::Vector3d& world) const;
  // Distorted pixel -> unit ray in the camera frame (nullopt where the model is not invertible).
  std::optional<Eigen::Vector3d> backProject(const Eigen::Vector2d& distorted) const;

private:
  Intrinsics intrinsics_;
  DivisionModel distortion_;
  CameraPose pose_;
};

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_CAMERA_CAMERA_MODEL_H
