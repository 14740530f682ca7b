// Internal to the world generator: the four kinds of building, each drawn from a random source into a Scene.
#ifndef INSITU_CALIBRATION_SIMULATION_GENERATOR_LAYOUTS_H
#define INSITU_CALIBRATION_SIMULATION_GENERATOR_LAYOUTS_H

#include <string>
#include <vector>

#include "generator_scene.h"
#include "insitu_calibration/simulation/world_generator.h"

namespace insitu_calibration
{
namespace simulation
{
namespace generator
{
struct Layout
{
  Scene scene;
  double ceiling_height = 3.0;
  std::vector<Eigen::Vector2d> camera_sites;  // where an installer mounts a camera: corners and walls, inset 0.25 m
  std::string description;
};

Layout buildLayout(BuildingKind kind, Rng& rng);

}  // namespace generator
}  // namespace simulation
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_SIMULATION_GENERATOR_LAYOUTS_H
