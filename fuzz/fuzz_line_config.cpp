// YAML text into the strict line configuration loader (controller/config). The loader's
// contract: a LineConfig, or ConfigError listing the problems (also for invalid YAML); any
// other exception escapes and is a finding. A configuration it accepts must be one the line
// controller can run: it is built from it and runs a few scans.
#include <cstdint>
#include <string_view>

#include "fl/controller/config_loader.hpp"
#include "fl/controller/line_controller.hpp"

namespace {
volatile std::size_t g_sink = 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  fl::LineConfig config;
  try {
    config = fl::parse_line_config(text, "fuzz_line.yaml");
  } catch (const fl::ConfigError& error) {
    for (const fl::ConfigProblem& problem : error.problems()) {
      g_sink = g_sink + problem.to_string().size();
    }
    return 0;
  }
  fl::LineController controller(config);
  controller.request_start();
  fl::InputImage in{};
  in.estop_ok = true;
  for (fl::DriveFeedback& drive : in.drives) drive.ready = true;
  fl::OutputImage out{};
  for (int scan = 0; scan < 20; ++scan) {
    in.time_ns = std::int64_t{scan} * 10'000'000;
    controller.update(in, out);
  }
  g_sink = g_sink + controller.active_faults();
  return 0;
}
