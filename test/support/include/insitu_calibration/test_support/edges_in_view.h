// The map an ideal survey would give a fixed camera: the simulator's true edges whose middle its rendered view sees.
#ifndef INSITU_CALIBRATION_TEST_SUPPORT_EDGES_IN_VIEW_H
#define INSITU_CALIBRATION_TEST_SUPPORT_EDGES_IN_VIEW_H

#include <vector>

#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/geometry/segment.h"
#include "insitu_calibration/simulation/renderer.h"
#include "insitu_calibration/simulation/world.h"

namespace insitu_calibration
{
// The true edges whose middle projects into the view and is not hidden behind a surface (by more than 5 cm of the
// view's depth).
std::vector<Segment3d> edgesSeenInView(const simulation::World& world, const CameraModel& camera,
                                       const simulation::RenderedView& view);
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_TEST_SUPPORT_EDGES_IN_VIEW_H
