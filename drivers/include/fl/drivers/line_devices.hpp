// The line's CANopen devices as config/can.yaml lays them out (13 CiA 402 belt drives, 3
// CiA 401 I/O modules), emulated on one bus endpoint with the plant's process data: what the
// master commands becomes the plant's output image, and the plant's measured state becomes
// the drives' actual velocity and position and the modules' inputs. This is the twin
// standing in for the real devices on the bus (issue 5 item 4); the master cannot tell.
//
// CanopenPlant runs a plant behind that bus in simulated time: the controller's images go
// through the real master (CanopenIo), every PDO, SYNC and heartbeat on an in-process bus, so
// a lock-step run exercises the whole CANopen path, its scaling and its one-SYNC delay.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "fl/controller/plant.hpp"
#include "fl/controller/process_image.hpp"
#include "fl/drivers/can_config.hpp"
#include "fl/drivers/canopen_emulation.hpp"
#include "fl/drivers/canopen_io.hpp"
#include "fl/drivers/loopback_bus.hpp"

namespace fl::drivers::emulation {

class LineDevices {
 public:
  // EMCY code a drive sends when the plant reports it faulted (CiA 402: 0x5400, power
  // section): the plant says only "fault", not which.
  static constexpr std::uint16_t kPlantDriveFaultCode = 0x5400;

  LineDevices(CanBus& bus, const CanConfig& config);
  // The drives' plant callbacks point back here.
  LineDevices(const LineDevices&) = delete;
  LineDevices& operator=(const LineDevices&) = delete;
  LineDevices(LineDevices&&) = delete;
  LineDevices& operator=(LineDevices&&) = delete;
  ~LineDevices() = default;

  // Serves the bus: receives pending frames, steps every device (SYNC, heartbeats).
  void poll(std::int64_t now_ns) { nodes_.poll(now_ns); }

  // What the devices were commanded at the last SYNC, as the plant's output image: a drive
  // runs only in Operation Enabled, at its target velocity and profile acceleration; the
  // modules' outputs decoded by config/can.yaml's channel table and scaling.
  [[nodiscard]] OutputImage commands() const;

  // The plant's state, sampled into the TPDOs at the next SYNC: drive velocity and encoder,
  // a drive fault (raised again after a reset while the plant still reports it), and the
  // modules' inputs.
  void set_plant_state(const InputImage& plant);

  EmulatedCia402Drive& drive(DriveId id) { return *drives_[index(id)]; }
  EmulatedCia401Io& module(IoModuleId id) { return *modules_[index(id)]; }
  [[nodiscard]] const EmulatedCia402Drive& drive(DriveId id) const { return *drives_[index(id)]; }
  [[nodiscard]] const EmulatedCia401Io& module(IoModuleId id) const { return *modules_[index(id)]; }

 private:
  CanConfig config_;
  EmulatedBusNodes nodes_;
  std::array<EmulatedCia402Drive*, kDriveCount> drives_{};
  std::array<EmulatedCia401Io*, kIoModuleCount> modules_{};
  InputImage plant_{};
};

}  // namespace fl::drivers::emulation

namespace fl::drivers {

class CanopenPlant final : public Plant {
 public:
  // Devices serve the bus this often within a period, as a device's CAN controller would.
  static constexpr std::int64_t kBusStepNs = 100'000;
  // After the SYNC, the devices have answered (TPDOs) within this; the plant then moves.
  static constexpr std::int64_t kSyncSettleNs = 1'000'000;

  // `inner` stays owned by the caller and must outlive this plant.
  CanopenPlant(Plant& inner, const CanConfig& config);

  [[nodiscard]] const char* name() const override { return name_.c_str(); }
  // Resets the inner plant, then runs the master's start-up (NMT, SDO configuration, drives
  // enabled) in simulated bus time. Throws std::runtime_error listing the start-up problems.
  void reset(std::uint64_t seed, InputImage& in) override;
  // The controller's image goes out as RPDOs and a SYNC; the devices apply it, answer with
  // the plant's state at that SYNC, the plant moves dt_ns, and the master reads what came.
  // Cameras are not on CAN: their frames come from the inner plant (DDS in a real line).
  void step(const OutputImage& out, std::int64_t dt_ns, InputImage& in) override;
  [[nodiscard]] std::span<const TrueFilletExit> drain_exits() override;
  [[nodiscard]] std::uint64_t fillets_fed() const override;
  [[nodiscard]] std::uint64_t fillets_on_line() const override;

  [[nodiscard]] const CanopenIo& master() const { return *master_; }
  [[nodiscard]] const StartupReport& startup() const { return startup_; }
  emulation::LineDevices& devices() { return *devices_; }

 private:
  void advance(std::int64_t duration_ns);
  void read_into(InputImage& in);

  Plant& inner_;
  CanConfig config_;
  std::string name_;
  std::int64_t bus_now_ns_ = 0;
  std::unique_ptr<LoopbackHub> hub_;
  std::unique_ptr<CanopenIo> master_;
  std::unique_ptr<emulation::LineDevices> devices_;
  InputImage inner_in_{};
  StartupReport startup_;
};

}  // namespace fl::drivers
