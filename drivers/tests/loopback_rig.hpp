// The master against emulated devices on the in-process loopback bus, on a simulated clock:
// every wait lets time pass in 100 us steps during which the devices serve the bus, so a
// test runs thousands of 10 ms cycles in milliseconds and is deterministic.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "fl/controller/config_loader.hpp"
#include "fl/drivers/can_config.hpp"
#include "fl/drivers/canopen_emulation.hpp"
#include "fl/drivers/canopen_io.hpp"
#include "fl/drivers/loopback_bus.hpp"

namespace fl::drivers::test {

inline LineConfig reference_line_config() {
  return load_line_config(std::string(FL_SOURCE_DIR) + "/config/line.yaml");
}

inline CanConfig reference_can_config() {
  return load_can_config(std::string(FL_SOURCE_DIR) + "/config/can.yaml", reference_line_config());
}

struct LoopbackRig {
  static constexpr std::int64_t kStepNs = 100'000;      // device service interval
  static constexpr std::int64_t kCycleNs = 10'000'000;  // the scan period of line.yaml

  explicit LoopbackRig(const CanConfig& can_config = reference_can_config())
      : config(can_config),
        hub([this] { return now_ns; }),
        master_bus(hub.add_endpoint()),
        device_bus(hub.add_endpoint()),
        devices(device_bus),
        io(master_bus, config) {
    for (std::size_t d = 0; d < kDriveCount; ++d) {
      const DriveNodeConfig& node = config.drives[d];
      // Velocity in counts/s when velocity units per m/s = counts per mm * 1000.
      drives[d] = &devices.add_drive(
          node.node_id, node.position_counts_per_mm * 1000.0 / node.velocity_units_per_mps);
    }
    for (std::size_t m = 0; m < kIoModuleCount; ++m) {
      modules[m] = &devices.add_io(config.io_modules[m].node_id);
    }
    clock =
        BusClock{[this] { return now_ns; }, [this](std::int64_t duration) { advance(duration); }};
    // E-stop chain closed unless a test opens it.
    modules[index(IoModuleId::kSafety)]->state().digital_inputs = 0x01;
  }

  void advance(std::int64_t duration_ns) {
    const std::int64_t end = now_ns + duration_ns;
    while (now_ns < end) {
      now_ns = std::min(end, now_ns + kStepNs);
      devices.poll(now_ns);
    }
  }

  // One scan: read, (the test's logic), write, then a period passes.
  void scan(const OutputImage& out) {
    io.read(now_ns, in);
    io.write(out);
    advance(kCycleNs);
  }

  StartupReport start(bool enable) { return io.start_up(clock, enable); }

  emulation::EmulatedCia402Drive& drive(DriveId id) { return *drives[index(id)]; }
  emulation::EmulatedCia401Io& module(IoModuleId id) { return *modules[index(id)]; }

  CanConfig config;
  std::int64_t now_ns = 1'000'000'000;
  LoopbackHub hub;
  LoopbackBus& master_bus;
  LoopbackBus& device_bus;
  emulation::EmulatedBusNodes devices;
  CanopenIo io;
  BusClock clock;
  InputImage in{};
  std::array<emulation::EmulatedCia402Drive*, kDriveCount> drives{};
  std::array<emulation::EmulatedCia401Io*, kIoModuleCount> modules{};
};

inline OutputImage all_drives(bool enable, float speed_mps, LineState state = LineState::kRunning) {
  OutputImage out{};
  out.state = state;
  for (DriveCommand& command : out.drives) {
    command.enable = enable;
    command.speed_mps = speed_mps;
    command.accel_mps2 = 0.0F;
  }
  return out;
}

}  // namespace fl::drivers::test
