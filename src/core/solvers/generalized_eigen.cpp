#include "insitu_calibration/solvers/generalized_eigen.h"

#include <cmath>
#include <complex>
#include <limits>
#include <vector>

#include <Eigen/Eigenvalues>

namespace insitu_calibration
{
namespace
{
struct SmallestEigen
{
  Vector12d vector;
  double value;
  double gap;
};

SmallestEigen smallestEigen(const Matrix12d& normal)
{
  Eigen::SelfAdjointEigenSolver<Matrix12d> eig(normal);
  const auto& values = eig.eigenvalues();  // ascending
  const double largest = std::max(values(11), std::numeric_limits<double>::min());
  return {eig.eigenvectors().col(0), std::max(values(0), 0.0), values(1) / largest};
}

// Derivative of the smallest eigenvalue of N(lambda) (Hellmann-Feynman): p^T N'(lambda) p.
double residualSlope(const DltSystem& system, double lambda, const Vector12d& p)
{
  const Matrix12d derivative = (system.c12() + system.c12().transpose()) + (2.0 * lambda) * system.c22();
  return p.dot(derivative * p);
}

// Newton iterations on the slope of the residual, accepted only while the residual decreases.
void polishLambda(const DltSystem& system, DltSystemSolution* solution)
{
  double lambda = solution->lambda;
  SmallestEigen current = smallestEigen(system.normalMatrix(lambda));
  for (int iteration = 0; iteration < 30; ++iteration)
  {
    const double h = 1e-6 * std::max(1.0, std::abs(lambda));
    const double slope = residualSlope(system, lambda, current.vector);
    const SmallestEigen ahead = smallestEigen(system.normalMatrix(lambda + h));
    const double curvature = (residualSlope(system, lambda + h, ahead.vector) - slope) / h;
    if (!(curvature > 0.0))
      break;
    const double step = -slope / curvature;
    const SmallestEigen next = smallestEigen(system.normalMatrix(lambda + step));
    if (!(next.value < current.value))
      break;
    lambda += step;
    current = next;
    if (std::abs(step) <= 1e-14 * std::max(1.0, std::abs(lambda)))
      break;
  }
  solution->lambda = lambda;
  solution->p = current.vector;
  solution->residual = current.value;
  solution->null_space_gap = current.gap;
}
// The lambdas that start the residual minimisation, from the pencil C11 p = mu C12 p (lambda = -mu), solved by QZ;
// counts the real roots into *real_candidates and the finite ones into *finite.
Expected<std::vector<double>> lambdaCandidates(const DltSystem& system, bool polish_lambda, int* real_candidates,
                                               int* finite)
{
  // QZ gives (alpha, beta) pairs; beta ~ 0 is an infinite eigenvalue, which C12's rank deficiency always produces.
  // mu is unchanged when both matrices are scaled alike; scaled to 1, extreme inputs cannot overflow inside QZ (at
  // 1e155 px its iterations never ended). Eigen's QZ stops after 40 sweeps per eigenvalue and then reports failure.
  const double scale = std::max(system.c11().cwiseAbs().maxCoeff(), system.c12().cwiseAbs().maxCoeff());
  if (!(scale > 0.0) || !(scale < 1e200))
    return Error(ErrorCode::kInvalidInput, "the linear system is zero or beyond double range; normalise the input");
  Eigen::GeneralizedEigenSolver<Matrix12d> gep(system.c11() / scale, system.c12() / scale, false);
  if (gep.info() != Eigen::Success)
    return Error(ErrorCode::kNoSolution, "the generalised eigenvalue problem did not converge (QZ failed)");
  const auto alphas = gep.alphas();
  const auto betas = gep.betas();
  // lambda = 0 is always a start: when the data fit a pin-hole camera exactly, C11 and C12 share the left null vector
  // p (C12^T p = B2^T B1 p = 0), the pencil is singular and QZ returns arbitrary values instead of 0. Under noise the
  // roots near the true lambda can turn into a complex pair; their real part still starts the polish in the right
  // valley.
  std::vector<double> candidates = {0.0};
  for (int i = 0; i < 12; ++i)
  {
    const double beta = betas(i);
    const std::complex<double> alpha = alphas(i);
    if (std::abs(beta) <= 1e-12 * std::max(std::abs(alpha), 1e-300))
      continue;  // infinite
    ++*finite;
    const std::complex<double> mu = alpha / beta;
    const double lambda = -mu.real();
    // In normalised coordinates (mean radius sqrt(2)) |lambda| beyond 1e3 would fold the image onto itself.
    if (!std::isfinite(lambda) || std::abs(lambda) > 1e3)
      continue;
    if (std::abs(mu.imag()) <= 1e-8 * std::max(1.0, std::abs(mu.real())))
      ++*real_candidates;
    else if (!polish_lambda)
      continue;  // a complex root is only a starting point for the polish
    candidates.push_back(lambda);
  }
  return candidates;
}
}  // namespace

Expected<DltSystemSolution> solveDltSystem(const DltSystem& system, bool estimate_lambda, bool polish_lambda)
{
  if (!system.c11().allFinite() || !system.c12().allFinite() || !system.c22().allFinite())
    return Error(ErrorCode::kInvalidInput, "the linear system holds NaN or infinite values");

  DltSystemSolution best;
  if (!estimate_lambda)
  {
    const SmallestEigen e = smallestEigen(system.c11());
    best.p = e.vector;
    best.residual = e.value;
    best.null_space_gap = e.gap;
    return best;
  }
  int finite = 0;
  const auto candidates = lambdaCandidates(system, polish_lambda, &best.real_candidates, &finite);
  if (!candidates)
    return candidates.error();
  // Without a finite (or, unpolished, a real) root only an exact pin-hole fit (the singular pencil above) is an answer.
  if (finite == 0 || (!polish_lambda && best.real_candidates == 0))
  {
    const SmallestEigen pinhole = smallestEigen(system.c11());
    if (!(pinhole.value <= 1e-12 * system.c11().diagonal().sum()))
      return Error(ErrorCode::kNoSolution,
                   "the distortion eigenproblem has no real finite solution, so the data cannot support a division "
                   "model; calibrate without distortion or check the correspondences");
  }
  best.residual = std::numeric_limits<double>::infinity();
  for (double lambda : *candidates)
  {
    const SmallestEigen e = smallestEigen(system.normalMatrix(lambda));
    if (e.value < best.residual)
    {
      best.lambda = lambda;
      best.p = e.vector;
      best.residual = e.value;
      best.null_space_gap = e.gap;
    }
  }
  if (polish_lambda)
  {
    const int real_candidates = best.real_candidates;
    polishLambda(system, &best);
    best.real_candidates = real_candidates;
  }
  return best;
}

}  // namespace insitu_calibration
