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
  double reciprocal_condition = 0.0;
};

// row_group[r] is residual row r's group (>= groups: a prior, in no group). The problem's residuals are evaluated
// without the robust loss.
GroupDiagnostics analyseGroups(ceres::Problem& problem, const FreeBlocks& free, const std::vector<size_t>& row_group,
                               size_t groups);

// The covariance of focal, principal point, distortion, rotation and centre, scaled by the residual variance over
// residual_count - free_parameters degrees of freedom; u.reason says why when it cannot be given.
void computeCameraCovariance(ceres::Problem& problem, const Parameters& p, size_t residual_count,
                             size_t free_parameters, double r_ref2, bool single_focal, CameraUncertainty* u);

// Each sigma becomes the larger of itself and the jackknife's (lines whose errors are correlated along the line make
// the covariance too optimistic); u.line_correlation_factor records the largest ratio.
void widenByJackknife(const Eigen::MatrixXd& jackknife, const FreeBlocks& free, const Parameters& p, double r_ref2,
                      bool single_focal, CameraUncertainty* u);

}  // namespace refinement
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_REFINE_REFINEMENT_UNCERTAINTY_H
