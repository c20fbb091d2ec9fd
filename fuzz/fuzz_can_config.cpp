// YAML text into the CAN configuration loader (drivers, config/can.yaml), cross-checked
// against the shipped line configuration. The contract: a CanConfig or ConfigError; any other
// exception escapes and is a finding. An accepted configuration must give a bus load figure
// and a master (its COB-ID routing table is built from the configured identifiers).
#include <cstdint>
#include <string_view>

#include "fl/controller/config_loader.hpp"
#include "fl/drivers/can_config.hpp"
#include "fl/drivers/canopen_io.hpp"
#include "fl/drivers/loopback_bus.hpp"

namespace {

const fl::LineConfig& line_config() {
  static const fl::LineConfig config = fl::load_line_config(FL_SOURCE_DIR "/config/line.yaml");
  return config;
}

volatile double g_sink = 0.0;

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  fl::drivers::CanConfig config;
  try {
    config = fl::drivers::parse_can_config(text, "fuzz_can.yaml", line_config());
  } catch (const fl::ConfigError& error) {
    g_sink = g_sink + static_cast<double>(error.problems().size());
    return 0;
  }
  g_sink = g_sink + fl::drivers::estimate_bus_load(config);
  fl::drivers::LoopbackHub hub([] { return std::int64_t{0}; }, 16);
  fl::drivers::CanopenIo master(hub.add_endpoint(), config);
  fl::InputImage in{};
  master.read(0, in);
  master.write(fl::OutputImage{});
  return 0;
}
