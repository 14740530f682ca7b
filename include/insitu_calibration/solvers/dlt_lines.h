// DLT-Lines (Bouafif et al., the paper's Eqs. 4-7): a 3D point M on a 3D line whose image is the line l satisfies
// l^T P M = 0, one linear equation per (3D point, image line part). Under the division model the line through two
// distorted points m1, m2 (relative to the distortion centre, s_i^2 = |m_i|^2) is exactly linear in lambda:
//   l = [u1, v1, 1 + lambda s1^2] x [u2, v2, 1 + lambda s2^2] = l_d + lambda e12,
//   l_d = [u1 v1 1] x [u2 v2 1],  e12 = [v1 s2^2 - v2 s1^2, u2 s1^2 - u1 s2^2, 0].
#ifndef INSITU_CALIBRATION_SOLVERS_DLT_LINES_H
#define INSITU_CALIBRATION_SOLVERS_DLT_LINES_H

#include "insitu_calibration/solvers/correspondences.h"
#include "insitu_calibration/solvers/dlt_system.h"
#include "insitu_calibration/solvers/normalization.h"

namespace insitu_calibration
{
// Adds every (world point, image part) pair of the line to the system, in normalised coordinates. Each part's row is
// scaled by 1 / |l_d(0:2)| so that its residual is a point-to-line distance (times depth) rather than growing with
// the part's length.
void addLineConstraints(const LineCorrespondence& line, const ImageNormalization& image_norm,
                        const WorldNormalization& world_norm, DltSystem* system);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SOLVERS_DLT_LINES_H
