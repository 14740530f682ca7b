#include "refine/refinement_uncertainty.h"

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <numeric>
#include <utility>

#include <Eigen/Dense>

namespace insitu_calibration
{
namespace refinement
{
int FreeBlocks::columns() const
{
  return std::accumulate(sizes.begin(), sizes.end(), 0);
}

int FreeBlocks::columnOf(const double* block) const
{
  int c = 0;
  for (size_t b = 0; b < blocks.size(); ++b)
  {
    if (blocks[b] == block)
      return c;
    c += sizes[b];
  }
  return -1;
}

namespace
{
// The Jacobian of the free blocks and the plain residuals (no robust loss) at the current parameters.
bool denseJacobian(ceres::Problem& problem, const FreeBlocks& free, Eigen::MatrixXd* j, std::vector<double>* residuals)
{
  ceres::Problem::EvaluateOptions evaluate_options;
  evaluate_options.apply_loss_function = false;
  evaluate_options.parameter_blocks = free.blocks;
  ceres::CRSMatrix crs;
  if (!problem.Evaluate(evaluate_options, nullptr, residuals, nullptr, &crs) || crs.num_cols != free.columns())
    return false;
  *j = Eigen::MatrixXd::Zero(crs.num_rows, crs.num_cols);
  for (int r = 0; r < crs.num_rows; ++r)
    for (int k = crs.rows[r]; k < crs.rows[r + 1]; ++k)
      (*j)(r, crs.cols[k]) = crs.values[k];
  return true;
}

// Column scaling, then a pseudo-inverse of the normal matrix (directions the data do not constrain get none).
Eigen::MatrixXd scaledNormalInverse(const Eigen::MatrixXd& j, double* reciprocal_condition)
{
  const int columns = static_cast<int>(j.cols());
  Eigen::VectorXd scale(columns);
  for (int c = 0; c < columns; ++c)
  {
    const double n = j.col(c).norm();
    scale(c) = n > 0.0 ? 1.0 / n : 0.0;
  }
  const Eigen::MatrixXd js = j * scale.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(js.transpose() * js);
  const Eigen::VectorXd values = eig.eigenvalues();
  const double largest = values.maxCoeff();
  *reciprocal_condition = largest > 0.0 ? std::max(0.0, values.minCoeff()) / largest : 0.0;
  Eigen::VectorXd inverse_values = Eigen::VectorXd::Zero(columns);
  for (int c = 0; c < columns; ++c)
    if (values(c) > 1e-12 * largest)
      inverse_values(c) = 1.0 / values(c);
  return scale.asDiagonal() * eig.eigenvectors() * inverse_values.asDiagonal() * eig.eigenvectors().transpose() *
         scale.asDiagonal();
}

// One group's rows left out, linearised: r_(-g) = (I - J_g H^-1 J_g^T)^-1 r_g, and the parameters move by
// H^-1 J_g^T r_(-g). Returns false (the problem would be singular without the group) when no shift is defined.
bool leaveGroupOut(const Eigen::MatrixXd& jg, const Eigen::VectorXd& rg, const Eigen::MatrixXd& h_inverse,
                   Eigen::VectorXd* loo_residuals, Eigen::VectorXd* shift)
{
  const Eigen::MatrixXd m = Eigen::MatrixXd::Identity(jg.rows(), jg.rows()) - jg * h_inverse * jg.transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> meig(m);
  if (!(meig.eigenvalues().minCoeff() > 1e-6))
    return false;
  *loo_residuals =
      meig.eigenvectors() * (meig.eigenvalues().cwiseInverse().asDiagonal() * (meig.eigenvectors().transpose() * rg));
  *shift = h_inverse * jg.transpose() * *loo_residuals;
  return true;
}

// The Jacobian rows and residuals of the given row sets, stacked in order.
void gatherRows(const Eigen::MatrixXd& j, const Eigen::VectorXd& res,
                std::initializer_list<const std::vector<int>*> row_sets, Eigen::MatrixXd* jg, Eigen::VectorXd* rg)
{
  size_t count = 0;
  for (const std::vector<int>* rows : row_sets)
    count += rows->size();
  jg->resize(static_cast<Eigen::Index>(count), j.cols());
  rg->resize(static_cast<Eigen::Index>(count));
  Eigen::Index k = 0;
  for (const std::vector<int>* rows : row_sets)
    for (const int r : *rows)
    {
      jg->row(k) = j.row(r);
      (*rg)(k++) = res(r);
    }
}

// The delete-2 jackknife over the groups with rows among the first `pairable` (Shao and Wu's delete-d jackknife,
// d = 2: (n - 2) / (2 C(n, 2)) times the sum of the pairs' shifts' outer products); empty outside 3 to
// kMaxPairJackknifeGroups groups, and when a pair leaves the problem singular (that pair alone holds a direction: no
// pair widening then, the covariance and the delete-1 jackknife stand; skipping the pair would bias the sum).
Eigen::MatrixXd pairJackknife(const Eigen::MatrixXd& j, const Eigen::VectorXd& res, const Eigen::MatrixXd& h_inverse,
                              const std::vector<std::vector<int>>& rows_of, size_t pairable)
{
  std::vector<size_t> used;
  for (size_t g = 0; g < std::min(pairable, rows_of.size()); ++g)
    if (!rows_of[g].empty())
      used.push_back(g);
  if (used.size() < 3 || used.size() > kMaxPairJackknifeGroups)
    return {};
  Eigen::MatrixXd sum = Eigen::MatrixXd::Zero(j.cols(), j.cols());
  for (size_t a = 0; a < used.size(); ++a)
    for (size_t b = a + 1; b < used.size(); ++b)
    {
      Eigen::MatrixXd jp;
      Eigen::VectorXd rp, loo, shift;
      gatherRows(j, res, {&rows_of[used[a]], &rows_of[used[b]]}, &jp, &rp);
      if (!leaveGroupOut(jp, rp, h_inverse, &loo, &shift))
        return {};
      sum += shift * shift.transpose();
    }
  const double n = static_cast<double>(used.size());
  return sum * ((n - 2.0) / (n * (n - 1.0)));  // (n - 2) / (2 C(n, 2))
}
}  // namespace

GroupDiagnostics analyseGroups(ceres::Problem& problem, const FreeBlocks& free, const std::vector<size_t>& row_group,
                               size_t groups, size_t pairable)
{
  const double nan = std::numeric_limits<double>::quiet_NaN();
  GroupDiagnostics out{std::vector<double>(groups, nan),
                       std::vector<double>(groups, nan),
                       std::vector<double>(groups, nan),
                       Eigen::MatrixXd(),
                       Eigen::MatrixXd(),
                       0.0};
  Eigen::MatrixXd j;
  std::vector<double> residuals;
  if (!denseJacobian(problem, free, &j, &residuals) || residuals.size() != row_group.size())
    return out;
  const int rows = static_cast<int>(j.rows());
  const int columns = static_cast<int>(j.cols());
  const Eigen::Map<const Eigen::VectorXd> res(residuals.data(), rows);
  const Eigen::MatrixXd h_inverse = scaledNormalInverse(j, &out.reciprocal_condition);
  std::vector<std::vector<int>> rows_of(groups);
  for (int r = 0; r < rows; ++r)
    if (row_group[r] < groups)
      rows_of[row_group[r]].push_back(r);
  out.jackknife = Eigen::MatrixXd::Zero(columns, columns);
  size_t used_groups = 0;
  const double variance = rows > columns ? res.squaredNorm() / (rows - columns) : 0.0;
  for (size_t g = 0; g < groups; ++g)
  {
    const std::vector<int>& own = rows_of[g];
    if (own.empty())
      continue;
    ++used_groups;
    Eigen::MatrixXd jg;
    Eigen::VectorXd rg;
    gatherRows(j, res, {&own}, &jg, &rg);
    out.rms_px[g] = std::sqrt(rg.squaredNorm() / own.size());
    out.loo_rms_px[g] = out.influence[g] = std::numeric_limits<double>::infinity();
    Eigen::VectorXd loo, shift;
    if (!leaveGroupOut(jg, rg, h_inverse, &loo, &shift))
      continue;
    out.loo_rms_px[g] = std::sqrt(loo.squaredNorm() / own.size());
    out.jackknife += shift * shift.transpose();
    out.influence[g] = variance > 0.0 ? (j * shift).squaredNorm() / (columns * variance) : 0.0;
  }
  if (used_groups > 1)
    out.jackknife *= static_cast<double>(used_groups - 1) / used_groups;
  out.pair_jackknife = pairJackknife(j, res, h_inverse, rows_of, pairable);
  return out;
}

void computeCameraCovariance(ceres::Problem& problem, const Parameters& p, size_t residual_count,
                             size_t free_parameters, double r_ref2, bool single_focal, CameraUncertainty* u)
{
  if (residual_count <= free_parameters)
  {
    u->reason = "as many parameters as residuals: no redundancy to estimate uncertainty from";
    return;
  }
  ceres::Covariance::Options covariance_options;
  covariance_options.algorithm_type = ceres::DENSE_SVD;
  covariance_options.null_space_rank = 0;
  covariance_options.min_reciprocal_condition_number = 1e-14;
  ceres::Covariance covariance(covariance_options);
  const std::vector<std::pair<const double*, const double*>> blocks = {{p.focal, p.focal},
                                                                       {p.principal, p.principal},
                                                                       {p.distortion, p.distortion},
                                                                       {p.delta, p.delta},
                                                                       {p.center, p.center}};
  if (!covariance.Compute(blocks, &problem))
  {
    u->reason =
        "rank deficient: the data leave the camera under-constrained (for example all lines in one "
        "plane or too few directions); no uncertainty can be given";
    return;
  }
  // Ceres assumes unit-variance residuals: scale by the residual variance, from the plain squared residuals (the
  // robust loss's cost would understate it) over the degrees of freedom.
  ceres::Problem::EvaluateOptions evaluate_options;
  evaluate_options.apply_loss_function = false;
  double plain_cost = 0.0;
  problem.Evaluate(evaluate_options, &plain_cost, nullptr, nullptr, nullptr);
  const double sigma2 = 2.0 * plain_cost / static_cast<double>(residual_count - free_parameters);
  u->residual_sigma_px = std::sqrt(sigma2);
  double focal[4], principal[4], distortion[1], delta[9], center[9];
  covariance.GetCovarianceBlock(p.focal, p.focal, focal);
  covariance.GetCovarianceBlock(p.principal, p.principal, principal);
  covariance.GetCovarianceBlock(p.distortion, p.distortion, distortion);
  covariance.GetCovarianceBlock(p.delta, p.delta, delta);
  covariance.GetCovarianceBlock(p.center, p.center, center);
  u->available = true;
  u->fx = std::sqrt(sigma2 * focal[0]);
  u->fy = single_focal ? u->fx : std::sqrt(sigma2 * focal[3]);
  u->cx = std::sqrt(sigma2 * principal[0]);
  u->cy = std::sqrt(sigma2 * principal[3]);
  u->lambda = std::sqrt(sigma2 * distortion[0]) / r_ref2;
  u->rotation_deg = std::sqrt(sigma2 * (delta[0] + delta[4] + delta[8])) * 180.0 / M_PI;
  u->position_m = std::sqrt(sigma2 * (center[0] + center[4] + center[8]));
}

void widenByJackknife(const Eigen::MatrixXd& jackknife, const FreeBlocks& free, const Parameters& p, double r_ref2,
                      bool single_focal, CameraUncertainty* u)
{
  const auto widen = [&](double* sigma, double variance) {
    const double jack = std::sqrt(std::max(0.0, variance));
    if (*sigma > 0.0)
      u->line_correlation_factor = std::max(u->line_correlation_factor, jack / *sigma);
    *sigma = std::max(*sigma, jack);
  };
  const int f = free.columnOf(p.focal), c = free.columnOf(p.principal), d = free.columnOf(p.delta),
            x = free.columnOf(p.center), k = free.columnOf(p.distortion);
  widen(&u->fx, jackknife(f, f));
  if (single_focal)
    u->fy = u->fx;
  else
    widen(&u->fy, jackknife(f + 1, f + 1));
  if (c >= 0)
  {
    widen(&u->cx, jackknife(c, c));
    widen(&u->cy, jackknife(c + 1, c + 1));
  }
  if (k >= 0)
    widen(&u->lambda, jackknife(k, k) / (r_ref2 * r_ref2));
  widen(&u->rotation_deg, jackknife.block(d, d, 3, 3).trace() * std::pow(180.0 / M_PI, 2));
  widen(&u->position_m, jackknife.block(x, x, 3, 3).trace());
}

std::vector<Eigen::MatrixXd> groupShifts(ceres::Problem& problem, const FreeBlocks& free,
                                         const std::vector<size_t>& row_group,
                                         const std::vector<Eigen::MatrixXd>& data_moves)
{
  Eigen::MatrixXd j;
  std::vector<double> residuals;
  if (!denseJacobian(problem, free, &j, &residuals) || residuals.size() != row_group.size())
    return {};
  double reciprocal_condition = 0.0;
  const Eigen::MatrixXd h_inverse = scaledNormalInverse(j, &reciprocal_condition);
  std::vector<std::vector<int>> rows_of(data_moves.size());
  for (size_t r = 0; r < row_group.size(); ++r)
    if (row_group[r] < data_moves.size())
      rows_of[row_group[r]].push_back(static_cast<int>(r));
  std::vector<Eigen::MatrixXd> shifts(data_moves.size());
  for (size_t g = 0; g < data_moves.size(); ++g)
  {
    const std::vector<int>& own = rows_of[g];
    if (data_moves[g].size() == 0 || own.empty())
      continue;
    if (data_moves[g].rows() != static_cast<Eigen::Index>(own.size()))
      return {};
    Eigen::MatrixXd jg(own.size(), j.cols());
    for (size_t k = 0; k < own.size(); ++k)
      jg.row(k) = j.row(own[k]);
    shifts[g] = -h_inverse * jg.transpose() * data_moves[g];
  }
  return shifts;
}

CameraColumns cameraColumns(const FreeBlocks& free, const Parameters& p)
{
  return {free.columnOf(p.focal), free.columnOf(p.principal), free.columnOf(p.distortion), free.columnOf(p.delta),
          free.columnOf(p.center)};
}

void setSigmasFromCovariance(const Eigen::MatrixXd& covariance, const CameraColumns& columns, double r_ref2,
                             bool single_focal, CameraUncertainty* u)
{
  const auto sigma = [](double variance) { return std::sqrt(std::max(0.0, variance)); };
  const int f = columns.focal, c = columns.principal, d = columns.delta, x = columns.center, k = columns.distortion;
  u->available = true;
  u->fx = sigma(covariance(f, f));
  u->fy = single_focal ? u->fx : sigma(covariance(f + 1, f + 1));
  u->cx = c >= 0 ? sigma(covariance(c, c)) : 0.0;
  u->cy = c >= 0 ? sigma(covariance(c + 1, c + 1)) : 0.0;
  u->lambda = k >= 0 ? sigma(covariance(k, k)) / r_ref2 : 0.0;
  u->rotation_deg = sigma(covariance.block(d, d, 3, 3).trace()) * 180.0 / M_PI;
  u->position_m = sigma(covariance.block(x, x, 3, 3).trace());
}

}  // namespace refinement
}  // namespace insitu_calibration
