// Solves a DltSystem for vec(P) (and lambda).
//
// Without distortion: vec(P) is the eigenvector of C11 = B1^T B1 with the smallest eigenvalue (the right singular
// vector of B1 for its smallest singular value).
// With distortion (Fitzgibbon 2001; the paper's Eq. 6): left-multiplying (B1 + lambda B2) p = 0 by B1^T gives the
// 12x12 generalised eigenvalue problem C11 p = -lambda C12 p, solved by QZ. Among its real, finite eigenvalues the one
// whose p leaves the smallest residual ||(B1 + lambda B2) p|| is kept. Optionally lambda is then polished to the
// joint least-squares minimum of ||(B1 + lambda B2) p||^2 over (lambda, p), which the left-multiplication by B1^T
// only approximates under noise (the "numerical accuracy of the polynomial eigenvalue problem" the paper leaves to
// future work).
#ifndef INSITU_CALIBRATION_SOLVERS_GENERALIZED_EIGEN_H
#define INSITU_CALIBRATION_SOLVERS_GENERALIZED_EIGEN_H

#include "insitu_calibration/error.h"
#include "insitu_calibration/solvers/dlt_system.h"

namespace insitu_calibration
{
struct DltSystemSolution
{
  Vector12d p = Vector12d::Zero();  // unit norm
  double lambda = 0.0;              // in the coordinates the system was built in
  double residual = 0.0;            // p^T N(lambda) p = ||(B1 + lambda B2) p||^2
  // Second-smallest over largest eigenvalue of N(lambda): near zero when the data leave a 2+ dimensional family of
  // solutions (a degenerate configuration).
  double null_space_gap = 0.0;
  int real_candidates = 0;  // real finite eigenvalues of the GEP (0 without distortion)
};

Expected<DltSystemSolution> solveDltSystem(const DltSystem& system, bool estimate_lambda, bool polish_lambda = true);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SOLVERS_GENERALIZED_EIGEN_H
