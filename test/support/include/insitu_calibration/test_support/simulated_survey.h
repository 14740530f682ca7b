// Shared by the survey tests: a simulated survey fed into a Survey as the node would feed it (RGB-D frames at their
// true poses, fixed-camera images in grey).
#ifndef INSITU_CALIBRATION_TEST_SUPPORT_SIMULATED_SURVEY_H
#define INSITU_CALIBRATION_TEST_SUPPORT_SIMULATED_SURVEY_H

#include <cstdint>
#include <string>

#include <opencv2/imgproc.hpp>

#include "insitu_calibration/simulation/survey.h"
#include "insitu_calibration/simulation/world.h"
#include "insitu_calibration/survey/survey.h"

namespace insitu_calibration
{
namespace test
{
// Returns the number of RGB-D frames fed.
inline int feedSimulatedSurvey(const simulation::SurveySimulator& simulator, Survey* survey)
{
  int xtion = 0;
  for (const simulation::SurveyEvent& event : simulator.events())
  {
    const double stamp = 1e-9 * static_cast<double>(event.stamp_ns);
    if (event.kind == simulation::SurveyEventKind::kXtion)
    {
      const simulation::XtionFrame x = simulator.xtionFrame(event.index);
      const simulation::ViewCamera view = simulator.xtionCamera(x.stamp_ns);
      RgbdFrame frame;
      cv::cvtColor(x.rgb, frame.rgb, cv::COLOR_RGB2BGR);
      frame.depth = x.depth_mm;
      frame.camera.width = view.width;
      frame.camera.height = view.height;
      frame.camera.intrinsics = view.intrinsics;
      frame.T_map_camera = x.map_from_optical;
      frame.stamp = stamp;
      survey->addRgbdFrame(frame);
      ++xtion;
    }
    else if (event.kind == simulation::SurveyEventKind::kFixed)
    {
      const simulation::FixedFrame f = simulator.fixedFrame(event.camera, event.index);
      cv::Mat grey;
      cv::cvtColor(f.image, grey, cv::COLOR_RGB2GRAY);
      survey->addFixedImage(simulator.world().fixed_cameras[event.camera].name, grey, stamp);
    }
  }
  return xtion;
}

// A world file surveyed by the simulator (seed, duration) and fed into survey; the world, for its truth.
inline Expected<simulation::World> surveyWorldFile(const std::string& world_file, uint64_t seed, double duration_s,
                                                   Survey* survey)
{
  auto world = simulation::loadWorldFile(world_file);
  if (!world)
    return world.error();
  simulation::SimulationOptions options;
  options.seed = seed;
  options.duration_s = duration_s;
  auto simulator = simulation::SurveySimulator::create(*world, options);
  if (!simulator)
    return simulator.error();
  feedSimulatedSurvey(*simulator, survey);
  return world;
}
}  // namespace test
}  // namespace insitu_calibration

#endif  // INSITU_CALIBRATION_TEST_SUPPORT_SIMULATED_SURVEY_H
