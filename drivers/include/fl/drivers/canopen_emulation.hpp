// Emulated CANopen devices for the twin side: a CiA 402 drive (profile velocity mode) and
// a CiA 401 I/O module, each answering NMT, expedited SDO (and segmented upload of 0x1008),
// SYNC-triggered TPDOs and RPDOs by their configured mapping, producing heartbeats, and
// sending EMCY on an injected fault. Each watches the master's heartbeat when 0x1016:01 names
// it (CiA 301 7.2.8.3.2.2): silent longer than the consumer time, the device sends EMCY 0x8130,
// leaves operational as 0x1029:01 says and takes its application's safe reaction (a drive's
// abort connection option 0x6007, a module's output error values), as real devices do when the
// controller dies. State lives in small public structs; a drive's motion
// comes from a plant callback (the lead connects the fast plant) or a built-in ramp.
//
// EmulatedBusNodes owns the devices on one CanBus endpoint and steps them: call poll(now)
// as often as the bus should be served (every 100 us to 1 ms).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "fl/drivers/can_bus.hpp"
#include "fl/drivers/canopen.hpp"
#include "fl/drivers/canopen_cia402.hpp"

namespace fl::drivers::emulation {

// One object dictionary entry (values up to 32 bits).
struct ObjectEntry {
  std::uint16_t index = 0;
  std::uint8_t subindex = 0;
  std::uint8_t size_bytes = 0;
  bool writable = false;
  std::uint32_t value = 0;
};

class EmulatedNode {
 public:
  EmulatedNode(canopen::NodeId node, std::uint32_t device_type, std::string device_name);
  virtual ~EmulatedNode() = default;
  EmulatedNode(const EmulatedNode&) = delete;
  EmulatedNode& operator=(const EmulatedNode&) = delete;

  void handle(CanBus& bus, const CanFrame& frame, std::int64_t now_ns);
  void tick(CanBus& bus, std::int64_t now_ns);  // heartbeat producer, boot-up

  [[nodiscard]] canopen::NodeId node_id() const { return node_; }
  [[nodiscard]] canopen::NmtState nmt_state() const { return nmt_; }
  // A cut cable: neither receives nor transmits while silent.
  void set_silent(bool silent) { silent_ = silent; }
  // Power cycle: defaults restored, boot-up sent at the next tick.
  void power_cycle();
  // A device whose PDO mapping is built in: the mapping object (0x1600.. or 0x1A00..) holds
  // `mapping` from power-on and answers writes with "read only", as such devices do.
  void fix_mapping(std::uint16_t mapping_index, const canopen::PdoMapping& mapping);

  [[nodiscard]] const ObjectEntry* find(std::uint16_t index, std::uint8_t subindex) const;
  ObjectEntry* find(std::uint16_t index, std::uint8_t subindex);
  [[nodiscard]] std::uint32_t value(std::uint16_t index, std::uint8_t subindex) const;
  void set_value(std::uint16_t index, std::uint8_t subindex, std::uint32_t value);

  struct Counters {
    std::uint64_t syncs = 0;
    std::uint64_t rpdos = 0;
    std::uint64_t tpdos = 0;
    std::uint64_t sdo_requests = 0;
    std::uint64_t sdo_aborts_sent = 0;
    std::uint64_t refused_rpdos = 0;    // wrong length for the mapping
    std::uint64_t heartbeats_lost = 0;  // the consumed heartbeat's timeouts
  };
  [[nodiscard]] const Counters& counters() const { return counters_; }

 protected:
  void add(ObjectEntry entry);
  void send(CanBus& bus, const CanFrame& frame);
  void send_emcy(CanBus& bus, std::uint16_t code, std::uint8_t error_register);
  // Device application: an object was written by SDO or RPDO.
  virtual void on_write(std::uint16_t /*index*/, std::uint8_t /*subindex*/) {}
  // Device application, once per SYNC before the TPDOs are sampled.
  virtual void on_sync(CanBus& /*bus*/, std::int64_t /*now_ns*/) {}
  // Application objects back to defaults (reset node).
  virtual void reset_application() {}
  // Device application: the consumed heartbeat (the master's) fell silent.
  virtual void on_heartbeat_lost() {}
  // Sends an EMCY frame from the application while not silent (e.g. a pending fault).
  [[nodiscard]] bool silent() const { return silent_; }

 private:
  void add_communication_objects();
  void reset_communication();
  void handle_sdo(CanBus& bus, const CanFrame& frame);
  void handle_rpdo(std::size_t pdo, const CanFrame& frame);
  void apply_rpdo(std::size_t pdo);
  void send_tpdos(CanBus& bus);
  void heartbeat_lost(CanBus& bus);
  [[nodiscard]] canopen::PdoMapping mapping(std::uint16_t mapping_index) const;

  canopen::NodeId node_;
  std::string device_name_;
  std::vector<ObjectEntry> objects_;
  std::vector<ObjectEntry> defaults_;
  canopen::NmtState nmt_ = canopen::NmtState::kPreOperational;
  bool boot_pending_ = true;
  bool silent_ = false;
  std::int64_t last_heartbeat_ns_ = 0;
  // Heartbeat consumer (0x1016:01): armed by the first heartbeat after it was configured.
  bool consumer_armed_ = false;
  std::int64_t last_consumed_heartbeat_ns_ = 0;
  bool heartbeat_error_ = false;  // EMCY 0x8130 sent, not yet reset
  std::array<std::uint32_t, 4> sync_counters_{};
  // Synchronous RPDO data waits for the next SYNC (CiA 301, 7.2.2.2).
  std::array<CanFrame, 4> pending_rpdo_{};
  std::array<bool, 4> rpdo_pending_{};
  // Segmented upload in progress.
  std::string upload_data_;
  std::size_t upload_offset_ = 0;
  bool upload_toggle_ = false;
  bool upload_active_ = false;
  Counters counters_;
};

// The drive's process data, for the plant and for tests.
struct DriveState {
  cia402::State state = cia402::State::kSwitchOnDisabled;
  std::int8_t mode = 0;                       // 0x6060 as written
  std::int32_t target_velocity = 0;           // 0x60FF, as applied at the last SYNC
  std::int32_t velocity_actual = 0;           // 0x606C
  std::int64_t position_actual = 0;           // 0x6064 (sent modulo 2^32)
  std::uint32_t acceleration = 1;             // 0x6083, velocity units per s
  std::uint32_t deceleration = 1;             // 0x6084
  std::uint32_t quick_stop_deceleration = 1;  // 0x6085
  std::uint16_t error_code = 0;               // 0x603F
};

class EmulatedCia402Drive final : public EmulatedNode {
 public:
  // Position counts per velocity unit and second: 1 means velocity is in counts per second.
  using Plant = std::function<void(DriveState& state, double dt_s)>;
  explicit EmulatedCia402Drive(canopen::NodeId node, double counts_per_velocity_unit_s = 1.0);

  [[nodiscard]] const DriveState& state() const { return state_; }
  DriveState& state() { return state_; }
  // Replaces the built-in ramp (velocity towards target within acceleration, position
  // integrated) with the plant's own motion.
  void set_plant(Plant plant) { plant_ = std::move(plant); }
  // A drive fault: fault reaction, then Fault; EMCY `error_code` with error register bit 0.
  void inject_fault(std::uint16_t error_code);

 protected:
  void on_write(std::uint16_t index, std::uint8_t subindex) override;
  void on_sync(CanBus& bus, std::int64_t now_ns) override;
  void reset_application() override;
  void on_heartbeat_lost() override;

 private:
  void publish();
  DriveState state_;
  Plant plant_;
  double counts_per_velocity_unit_s_;
  double position_remainder_ = 0.0;
  std::uint16_t last_controlword_ = 0;
  std::int64_t last_sync_ns_ = 0;
  bool fault_emcy_pending_ = false;
  bool clear_emcy_pending_ = false;
};

struct IoState {
  std::uint8_t digital_inputs = 0;               // 0x6000:01
  std::array<std::int16_t, 3> analog_inputs{};   // 0x6401:01..03
  std::uint8_t digital_outputs = 0;              // 0x6200:01, as applied at the last SYNC
  std::array<std::int16_t, 3> analog_outputs{};  // 0x6411:01..03
};

class EmulatedCia401Io final : public EmulatedNode {
 public:
  explicit EmulatedCia401Io(canopen::NodeId node);
  [[nodiscard]] const IoState& state() const { return state_; }
  IoState& state() { return state_; }

 protected:
  void on_write(std::uint16_t index, std::uint8_t subindex) override;
  void on_sync(CanBus& bus, std::int64_t now_ns) override;
  void reset_application() override;
  void on_heartbeat_lost() override;

 private:
  IoState state_;
};

// The devices on one bus endpoint.
class EmulatedBusNodes {
 public:
  explicit EmulatedBusNodes(CanBus& bus) : bus_(bus) {}
  EmulatedCia402Drive& add_drive(canopen::NodeId node, double counts_per_velocity_unit_s = 1.0);
  EmulatedCia401Io& add_io(canopen::NodeId node);
  // Receives every pending frame, hands it to every device, then ticks them.
  void poll(std::int64_t now_ns);
  [[nodiscard]] CanBus& bus() { return bus_; }

 private:
  CanBus& bus_;
  std::vector<std::unique_ptr<EmulatedNode>> nodes_;
  std::array<CanFrame, 64> batch_{};
};

}  // namespace fl::drivers::emulation
