// libFuzzer harness: the world reader with its limits, then the simulator's scene set-up (route, events) for a
// short survey of what it accepts.
#include <cstddef>
#include <cstdint>
#include <string>

#include "insitu_calibration/simulation/survey.h"
#include "insitu_calibration/simulation/world.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
  namespace sim = insitu_calibration::simulation;
  auto world = sim::parseWorld(std::string(reinterpret_cast<const char*>(data), size), "fuzz.yaml");
  if (!world)
    return 0;
  sim::SimulationOptions options;
  options.duration_s = 1.0;
  (void)sim::SurveySimulator::create(std::move(*world), options);
  return 0;
}
