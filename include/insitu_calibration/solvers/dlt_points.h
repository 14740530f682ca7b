// DLT-Points (Hartley & Zisserman, Alg. 7.1) with Fitzgibbon's division model: m x (P M) = 0, i.e.
// [m]_x P M = 0, three rows (two independent) per point pair. With distortion m = m_d + lambda e_d, e_d = [0 0 s^2],
// so each row is again l^T P M with l = row of [m_d]_x + lambda row of [e_d]_x, the same form as DLT-Lines.
#ifndef INSITU_CALIBRATION_SOLVERS_DLT_POINTS_H
#define INSITU_CALIBRATION_SOLVERS_DLT_POINTS_H

#include "insitu_calibration/solvers/correspondences.h"
#include "insitu_calibration/solvers/dlt_system.h"
#include "insitu_calibration/solvers/normalization.h"

namespace insitu_calibration
{
void addPointConstraints(const PointCorrespondence& point, const ImageNormalization& image_norm,
                         const WorldNormalization& world_norm, DltSystem* system);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SOLVERS_DLT_POINTS_H
