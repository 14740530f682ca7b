// What the refinement says about its own quality once solved: the linearised leave-one-out over residual groups
// (each line's residual and how much the solution hangs on it, and the jackknife covariance over lines) and the
// covariance of the camera's parameters, in the manner of industrial_calibration's covariance_analysis.
#ifndef INSITU_CALIBRATION_REFINE_REFINEMENT_UNCERTAINTY_H
#define INSITU_CALIBRATION_REFINE_REFINEMENT_UNCERTAINTY_H

#include <vector>

#include <Eigen/Core>

#include <ceres/ceres.h>

#include "insitu_calibration/refine/refinement.h"
#include "refine/cost_functions.h"

namespace insitu_calibration
{
namespace refinement
{
// The free parameter blocks, in the order of the Jacobian's columns.
struct FreeBlocks
{
  std::vector<double*> blocks;
  std::vector<int> sizes;

  void add(double* block, int size)
  {
    blocks.push_back(block);
    sizes.push_back(size);
  }
  int columns() const;
  int columnOf(const double* block) const;  // -1 when the block is not free
};

// Per residual group (a line, a point, a plumb line): NaN for a group without residuals; infinite leave-one-out
// values where leaving the group out leaves the problem singular.
struct GroupDiagnostics
{
  std::vector<double> rms_px;
  std::vector<double> loo_rms_px;
  std::vector<double> influence;
  Eigen::MatrixXd jackknife;  // covariance of the parameters from leaving out one group at a time; empty on failure
  // The same from leaving out two of the first `pairable` groups at a time (the delete-2 jackknife), when there are
  // 3 to kMaxPairJackknifeGroups of them; else empty. Two wrong correspondences that agree hold the camera between
  // them, each alone moving it little: only leaving out both shows how far they hold it.
  Eigen::MatrixXd pair_jackknife;
  double reciprocal_condition = 0.0;
};

constexpr size_t kMaxPairJackknifeGroups = 32;  // C(32, 2) = 496 pairs, each a small linear solve

// row_group[r] is residual row r's group (>= groups: a prior, in no group). The problem's residuals are evaluated
// without the robust loss.
GroupDiagnostics analyseGroups(ceres::Problem& problem, const FreeBlocks& free, const std::vector<size_t>& row_group,
                               size_t groups, size_t pairable = 0);

// The covariance of focal, principal point, distortion, rotation and centre, scaled by the residual variance over
// residual_count - free_parameters degrees of freedom; u.reason says why when it cannot be given.
void computeCameraCovariance(ceres::Problem& problem, const Parameters& p, size_t residual_count,
                             size_t free_parameters, double r_ref2, bool single_focal, CameraUncertainty* u);

// Each sigma becomes the larger of itself and the jackknife's (lines whose errors are correlated along the line make
// the covariance too optimistic); u.line_correlation_factor records the largest ratio.
void widenByJackknife(const Eigen::MatrixXd& jackknife, const FreeBlocks& free, const Parameters& p, double r_ref2,
                      bool single_focal, CameraUncertainty* u);

// How the least-squares solution moves when the data move in ways the residuals do not see (a line's 3D position):
// group g's rows move by data_moves[g] (one column per move; an empty matrix: none) and the solution, linearised,
// by -H^-1 J_g^T data_moves[g], returned per group (columns x moves; empty for an empty group). Empty on failure.
std::vector<Eigen::MatrixXd> groupShifts(ceres::Problem& problem, const FreeBlocks& free,
                                         const std::vector<size_t>& row_group,
                                         const std::vector<Eigen::MatrixXd>& data_moves);

// The camera's blocks among the Jacobian's columns (-1: not free).
struct CameraColumns
{
  int focal = -1;
  int principal = -1;
  int distortion = -1;
  int delta = -1;
  int center = -1;
};
CameraColumns cameraColumns(const FreeBlocks& free, const Parameters& p);

// The standard deviations of focal, principal point, distortion, rotation and centre from a covariance of the free
// parameters; u.available set.
void setSigmasFromCovariance(const Eigen::MatrixXd& covariance, const CameraColumns& columns, double r_ref2,
                             bool single_focal, CameraUncertainty* u);

}  // namespace refinement
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_REFINE_REFINEMENT_UNCERTAINTY_H
