// xtion_record: records an OpenNI2 device (the Xtion, or DummyDevice) to an .oni file that xtion_node plays back
// (device_uri:=FILE.oni), or writes a synthetic recording at a mode DummyDevice does not have (benchmarks, tests).
#include <iostream>

#include "command_line.h"
#include "insitu_calibration/drivers/oni_writer.h"
#include "insitu_calibration/drivers/openni_device.h"

namespace ic = insitu_calibration;
namespace dr = insitu_calibration::drivers;

namespace
{
const char* kUsage = R"(Usage: xtion_record [options] OUT.oni
       xtion_record --synthetic [--mode 640x480@30] [--frames N] OUT.oni

Records both streams of an OpenNI2 device with OpenNI2's recorder (lossless), or writes a synthetic recording
(a moving square over a gradient; depth a slanted plane, the square at 1 m, no return along the bottom).

Options:
  --uri URI             device: empty = first device (default), '#N', serial number, device URI, Dummy
  --seconds S           how long to record (default 5)
  --color-mode MODE     WIDTHxHEIGHT@FPS (default 640x480@30)
  --depth-mode MODE     WIDTHxHEIGHT@FPS (default 640x480@30)
  --no-registration     record without hardware depth-to-colour registration
  --synthetic           write a synthetic recording instead of recording a device
  --mode MODE           synthetic: both streams' mode (default 640x480@30)
  --frames N            synthetic: frames per stream (default 300)
)";

int fail(const std::string& message)
{
  std::cerr << "xtion_record: " << message << "\n";
  return 1;
}
}  // namespace

int main(int argc, char** argv)
{
  ic::CommandLine cli(argc, argv, {"uri", "seconds", "color-mode", "depth-mode", "mode", "frames"},
                      {"synthetic", "no-registration"});
  if (cli.help())
  {
    std::cout << kUsage;
    return 0;
  }
  const double seconds = cli.number("seconds", 5.0);
  const double frames = cli.number("frames", 300);
  if (!cli.error().empty() || cli.positional().size() != 1)
  {
    std::cerr << "xtion_record: " << (cli.error().empty() ? "give one output file" : cli.error()) << "\n\n" << kUsage;
    return 2;
  }
  const std::string out = cli.positional().front();

  if (cli.flag("synthetic"))
  {
    dr::SyntheticOniOptions options;
    const auto mode = dr::parseVideoMode(cli.value("mode", "640x480@30"));
    if (!mode)
      return fail("--mode: " + mode.error().message());
    options.mode = *mode;
    options.frames = static_cast<int>(frames);
    const ic::Status written = dr::writeSyntheticOni(out, options);
    if (!written)
      return fail(written.error().message());
    std::cout << "wrote " << options.frames << " synthetic frames a stream at " << options.mode.toString() << " to "
              << out << "\n";
    return 0;
  }

  dr::OpenniConfig config;
  config.uri = cli.value("uri", "");
  config.registration = !cli.flag("no-registration");
  for (const auto& [option, target] :
       {std::make_pair("color-mode", &config.color_mode), std::make_pair("depth-mode", &config.depth_mode)})
  {
    const auto mode = dr::parseVideoMode(cli.value(option, "640x480@30"));
    if (!mode)
      return fail(std::string("--") + option + ": " + mode.error().message());
    *target = *mode;
  }
  dr::OpenniDevice device;
  const ic::Status opened = device.open(config);
  if (!opened)
    return fail(opened.error().message());
  std::cout << "recording " << device.summary().describe() << " for " << seconds << " s to " << out << "\n";
  int counts[2] = {0, 0};
  const ic::Status recorded = device.record(
      out, seconds, [&](const dr::FrameView& frame) { ++counts[frame.stream == dr::StreamKind::kColor ? 0 : 1]; });
  if (!recorded)
    return fail(recorded.error().message());
  std::cout << "read " << counts[0] << " colour and " << counts[1] << " depth frames while recording\n";
  return 0;
}
