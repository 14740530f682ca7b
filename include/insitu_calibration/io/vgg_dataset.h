// The Oxford VGG multi-view line data (Model House, Merton College I, ...): 3D line segments, 2D segments per view,
// the ground-truth projection matrix of each view. A view becomes a CorrespondenceSet: one line per 3D segment seen
// in it, image = the 2D segment's end points, world = the 3D segment's end points.
#ifndef INSITU_CALIBRATION_IO_VGG_DATASET_H
#define INSITU_CALIBRATION_IO_VGG_DATASET_H

#include <string>
#include <vector>

#include "insitu_calibration/camera/camera_model.h"
#include "insitu_calibration/error.h"
#include "insitu_calibration/solvers/correspondences.h"

namespace insitu_calibration
{
struct VggView
{
  std::string name;      // the .P file's stem, e.g. "house.000"
  Matrix34d projection;  // ground truth, pixels with (0,0) the top-left pixel
  CorrespondenceSet data;
  bool mirrored = false;  // the scene's frame was left-handed and z was negated (see loadVggScene)
};

// Reads every view of a scene folder: *.P files, their .lines, the *l3d file and the *nview-lines file.
// Some reconstructions (Model House) live in a left-handed frame: their P has det(P(:, 0:3)) < 0 while the scene
// is in front of the camera, which no camera with a proper rotation reproduces. Such a scene is mirrored (world
// z -> -z in the points and in every P) so that it is right-handed like every ROS frame; `mirrored` says so.
Expected<std::vector<VggView>> loadVggScene(const std::string& directory, int image_width, int image_height);

}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_IO_VGG_DATASET_H
