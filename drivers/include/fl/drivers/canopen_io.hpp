// The CANopen master as the controller's ProcessIo: read() drains the received frames into
// the input image, write() encodes the output image into RPDOs followed by SYNC. Both run
// inside the 10 ms cycle: no allocation, no lock, no blocking call (fixed receive buffer, a
// COB-ID routing table, a lock-free event ring drained by a non-real-time thread).
//
// Start-up (outside the cycle, start_up()): NMT reset of every node, wait for each boot-up
// message, SDO configuration (heartbeat producer time, PDO COB-IDs, mappings and
// transmission types, CiA 402 profile velocity mode and ramps), NMT start, then cycles until
// every node's process data has arrived and its heartbeat reports Operational (optionally
// with the CiA 402 enable sequence up to Operation Enabled).
//
// Safe reactions (each also reported as an event):
// - drive heartbeat lost (no heartbeat within its timeout), CiA 402 fault, an EMCY with a
//   non-zero error code, a node that left NMT Operational, bus off: the drive shows
//   fault = true, ready = false in the input image (the logic then stops the line);
// - an I/O module lost or not operational, or bus off: estop_ok = false, the inputs of that
//   module read as their safe values (no beam, no buttons), so the logic disables every drive.
// A drive fault is reset (controlword 0x80 edge) only while the operator's fault reset
// button is pressed: the same acknowledgement the line's state machine needs.
// A node that rebooted while running (a boot-up message: power cycle, watchdog reset) lost
// its SDO configuration. It is faulted until the cycle has configured it again with the
// start-up's own steps, one SDO transfer per write(), and started it (CiA 302's "boot slave"
// after a boot-up). A failed step leaves it faulted and is tried again every second
// (kReconfigureRetryNs) until it passes, the node boots again or start_up() runs.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "fl/controller/runtime.hpp"
#include "fl/drivers/can_bus.hpp"
#include "fl/drivers/can_config.hpp"
#include "fl/drivers/canopen.hpp"
#include "fl/drivers/canopen_cia402.hpp"
#include "fl/drivers/canopen_sdo_client.hpp"

namespace fl::drivers {

enum class CanopenEventKind : std::uint8_t {
  kHeartbeatLost,
  kHeartbeatRecovered,
  kBootUp,             // the node (re)booted
  kNmtStateChanged,    // heartbeat shows another NMT state
  kEmergency,          // code, error register
  kEmergencyCleared,   // EMCY 0x0000
  kDriveStateChanged,  // CiA 402 state, from the statusword
  kBusStateChanged,    // transport error state
  kReconfigured,       // a rebooted node configured again by the cycle and started
  // The cycle's configuration of a rebooted node stopped: code = index << 8 | subindex of the
  // step, detail = ReconfigurationFailure.
  kReconfigurationFailed,
};
const char* to_string(CanopenEventKind kind);

enum class ReconfigurationFailure : std::uint8_t {
  kAborted,     // the device aborted the transfer
  kTimeout,     // no answer within sdo_timeout_ms
  kProtocol,    // an answer that does not fit the request
  kWrongValue,  // a read-back (device type, mode, a built-in mapping) differs
  kSendFailed,  // the request could not be queued
};
const char* to_string(ReconfigurationFailure failure);

struct CanopenEvent {
  CanopenEventKind kind = CanopenEventKind::kHeartbeatLost;
  canopen::NodeId node = 0;
  std::int64_t time_ns = 0;
  std::uint32_t code = 0;   // EMCY error code, NMT state, CiA 402 state or bus error state
  std::uint8_t detail = 0;  // EMCY error register; for a state change the state before
  bool commanded = false;   // a boot-up or NMT change the master's own start-up or stop caused
};
// "node 3: EMCY 0x2310 continuous over current (register 0x03)"
std::string describe(const CanopenEvent& event);
// Whether the event raises a fault (true), clears one (false) or neither (nullopt): a lost
// heartbeat, an EMCY, a reboot, a node leaving Operational, a drive entering Fault and the
// bus going off raise; their counterparts clear (a reboot only by the next start-up). What
// the master commanded (the start-up's resets, the stop at shut-down) is neither.
std::optional<bool> fault_transition(const CanopenEvent& event);

struct CanopenCounters {
  std::uint64_t frames_handled = 0;
  std::uint64_t unknown_cob_id = 0;    // a frame no configured node sends
  std::uint64_t malformed_frames = 0;  // wrong DLC, invalid heartbeat byte, RTR, 29-bit id
  std::uint64_t unexpected_sdo = 0;    // SDO responses while no transfer runs
  std::uint64_t events_dropped = 0;    // event ring full: the consumer is too slow
  std::uint64_t send_failures = 0;     // RPDO or SYNC not queued
  std::uint64_t syncs_sent = 0;
  std::uint64_t heartbeats_sent = 0;     // the master's own
  std::uint64_t nodes_restarted = 0;     // NMT start sent to a node that fell to pre-operational
  std::uint64_t nodes_reconfigured = 0;  // rebooted nodes configured again and started
  std::uint64_t reconfigurations_failed = 0;
  std::uint64_t heartbeats_lost = 0;  // nodes that passed their heartbeat timeout (each time)
};

// Bus timing the master measures from the transport's send confirmations (all zero when the
// transport has none): how regular SYNC is on the wire, and how long a frame waits between
// send() and the bus. Counted from the end of start_up().
struct CanBusTiming {
  std::uint64_t syncs_on_bus = 0;
  std::uint64_t sync_periods = 0;  // intervals between consecutive SYNCs on the bus
  std::int64_t sync_period_min_ns = 0;
  std::int64_t sync_period_max_ns = 0;
  std::int64_t sync_period_sum_ns = 0;
  std::uint64_t frames_confirmed = 0;
  std::int64_t send_delay_max_ns = 0;  // send() to on the bus, over every confirmed frame
  std::int64_t send_delay_sum_ns = 0;

  [[nodiscard]] double sync_period_mean_ns() const;
  // The largest deviation of a SYNC interval from `cycle_period_ns`: the SYNC jitter a
  // drive synchronised to it sees.
  [[nodiscard]] std::int64_t sync_jitter_ns(std::int64_t cycle_period_ns) const;
  [[nodiscard]] double send_delay_mean_ns() const;
};

// What a node looks like to the master now.
struct NodeStatus {
  canopen::NodeId node = 0;
  bool heard = false;  // any heartbeat since start-up
  bool lost = false;   // heartbeat timeout passed
  canopen::NmtState nmt = canopen::NmtState::kBootUp;
  bool rebooted = false;        // boot-up seen after start-up: not configured again yet
  std::uint16_t emcy_code = 0;  // latest EMCY error code (0: none or cleared)
  cia402::State drive_state = cia402::State::kUnknown;  // drives only
};

struct StartupReport {
  bool ok = false;
  std::vector<std::string> problems;  // one line each: node, step, reason
  std::int64_t duration_ns = 0;
};

class CanopenIo final : public ProcessIo {
 public:
  CanopenIo(CanBus& bus, CanConfig config);

  // Outside the cycle. Runs the whole start-up and ends after a cycle in which every node's
  // TPDOs had arrived, so that the next read() fills the whole image; enable_drives also takes
  // every drive to Operation Enabled at zero speed.
  StartupReport start_up(const BusClock& clock, bool enable_drives);
  // Outside the cycle, after the last scan: cycles with every drive disabled and every
  // actuator released until no drive reports Operation Enabled (within enable_timeout_ms),
  // then NMT stop to every node, so that the devices leave Operational at once instead of
  // running into their command timeouts. Returns whether every drive was seen disabled.
  bool shut_down(const BusClock& clock);

  void read(std::int64_t now_ns, InputImage& in) override;
  void write(const OutputImage& out) override;
  // The previous write()'s SYNC on the wire (its synchronous RPDOs take effect at it), when
  // the transport confirmed it by this read().
  [[nodiscard]] std::optional<std::int64_t> last_write_applied_ns() const override {
    return write_applied_ns_;
  }

  // Any one thread other than the scan thread (single consumer).
  bool pop_event(CanopenEvent& event);
  // Pops every pending event and logs it with spdlog, handing each to `observer` too (the
  // fault topic); returns how many.
  std::size_t log_events(const std::function<void(const CanopenEvent&)>& observer = {});

  // Read these while the cycle is not running (plain fields written by the scan thread).
  [[nodiscard]] NodeStatus drive_status(DriveId drive) const;
  [[nodiscard]] NodeStatus io_status(IoModuleId module) const;
  [[nodiscard]] const CanopenCounters& counters() const { return counters_; }
  [[nodiscard]] const CanBusTiming& bus_timing() const { return bus_timing_; }
  [[nodiscard]] const CanConfig& config() const { return config_; }

  // Scaling, exposed for tests and tools.
  [[nodiscard]] std::int32_t velocity_to_drive_units(DriveId drive, float speed_mps) const;
  [[nodiscard]] std::uint32_t acceleration_to_drive_units(DriveId drive, float accel_mps2) const;

  static constexpr std::size_t kReceiveBatch = 64;
  // Bounded drain: a babbling node cannot keep read() busy past 8 batches (512 frames,
  // more than five times one cycle's configured traffic).
  static constexpr std::size_t kMaxBatchesPerRead = 8;
  static constexpr std::size_t kEventCapacity = 256;
  // A rebooted node whose configuration failed is tried again after this long: a device that
  // answered late or was still initialising is configured at the next try.
  static constexpr std::int64_t kReconfigureRetryNs = 1'000'000'000;

 private:
  static constexpr std::size_t kNodeCount = kDriveCount + kIoModuleCount;
  enum class Route : std::uint8_t {
    kNone,
    kHeartbeat,
    kEmergency,
    kSdoResponse,
    kDriveTpdo1,
    kDriveTpdo2,
    kIoTpdo1
  };
  struct RouteEntry {
    Route route = Route::kNone;
    std::uint8_t slot = 0;  // node slot (0..15) or drive/module index
  };
  struct NodeRuntime {
    canopen::NodeId id = 0;
    std::int64_t timeout_ns = 0;
    std::int64_t last_heartbeat_ns = 0;
    bool heard = false;
    bool lost = false;
    bool rebooted = false;
    bool reconfigure_wanted = false;             // rebooted while running: the cycle configures it
    std::int64_t reconfigure_not_before_ns = 0;  // a failed try waits kReconfigureRetryNs
    // The last failed try's step (index << 8 | subindex) and reason, since the node's boot-up:
    // a repeat of it is counted, not reported again.
    struct FailedTry {
      std::uint32_t code = 0;
      std::uint8_t reason = 0;
      friend bool operator==(const FailedTry&, const FailedTry&) = default;
    };
    std::optional<FailedTry> last_failure;
    // It reported pre-operational on its own (a device that lost the master's heartbeat, or
    // another communication error): the next write() sends it NMT start (CiA 302's restart of
    // a node after an error control event). Its configuration is kept in pre-operational.
    bool start_wanted = false;
    canopen::NmtState nmt = canopen::NmtState::kBootUp;
    std::uint16_t emcy_code = 0;
  };
  struct DriveRuntime {
    std::uint16_t statusword = 0;
    cia402::State state = cia402::State::kUnknown;
    bool status_received = false;
    std::int32_t last_position_raw = 0;
    bool position_received = false;
    std::int64_t encoder_counts = 0;  // unwrapped from the 32-bit position actual
    std::int32_t velocity_raw = 0;
    // What each RPDO last carried: a ramp-only RPDO goes again only when this changes.
    std::array<std::array<std::uint32_t, canopen::kMaxPdoEntries>, 2> rpdo_last{};
    std::array<bool, 2> rpdo_sent{};
  };
  // A drive's RPDO objects for one cycle, raw as on the wire.
  struct DriveRpdoValues {
    std::uint32_t controlword = 0;
    std::uint32_t target_velocity = 0;
    std::uint32_t acceleration = 0;  // also the deceleration
  };
  // A module's outputs for one cycle, raw as on the wire.
  struct IoOutputs {
    std::uint32_t digital = 0;
    std::array<std::uint32_t, 3> analog{};
  };
  struct IoRuntime {
    std::uint8_t digital_inputs = 0;
    std::array<std::int16_t, 3> analog_inputs{};
    bool received = false;
  };

  void build_routes();
  void handle_frame(const CanFrame& frame, std::int64_t now_ns);
  void check_timeouts(std::int64_t now_ns);
  void take_send_confirmations();
  // A configured mapping with the signal of each entry and whether it is cyclic, worked out
  // once at construction: the cycle packs and unpacks by them.
  struct MappedPdo {
    canopen::PdoMapping mapping;
    std::array<PdoSignal, canopen::kMaxPdoEntries> signals{};
    bool cyclic = false;  // an RPDO that goes every cycle (carries_cyclic_command)
  };
  static MappedPdo map_pdo(const canopen::PdoMapping& mapping);
  void apply_drive_signal(std::size_t slot, PdoSignal signal, std::uint32_t raw,
                          std::int64_t now_ns);
  static void fill_drive_rpdo(const MappedPdo& pdo, const DriveRpdoValues& command,
                              std::array<std::uint32_t, canopen::kMaxPdoEntries>& values);
  void send_drive_rpdo(std::size_t drive_index, std::size_t rpdo, std::uint32_t cob_id,
                       const DriveRpdoValues& command);
  StartupReport run_start_up(const BusClock& clock, bool enable_drives);
  // Outside the cycle: write `out`, a cycle period, read into `in`, until done() or
  // enable_timeout_ms passed; whether done() came true.
  bool cycle_until(const BusClock& clock, const OutputImage& out, InputImage& in,
                   const std::function<bool()>& done);
  // "node 5 (drive takt)": how start-up problems name a node.
  std::string node_label(std::size_t slot) const;
  void fill_image(InputImage& in) const;
  void push_event(CanopenEventKind kind, canopen::NodeId node, std::int64_t time_ns,
                  std::uint32_t code, std::uint8_t detail = 0);
  [[nodiscard]] bool node_healthy(std::size_t slot) const;
  [[nodiscard]] NodeStatus status_of(std::size_t slot) const;
  // 0x1016:01 for every device: the master's node id and the consumer time.
  [[nodiscard]] std::uint32_t master_heartbeat_consumer() const;

  // One step of a node's SDO configuration: the start-up and the cycle's reconfiguration of a
  // rebooted node run the same list.
  struct SetupStep {
    enum class Kind : std::uint8_t { kWrite, kExpect };
    Kind kind = Kind::kWrite;
    canopen::SdoAddress address;
    std::uint32_t value = 0;           // written, or expected under `mask`
    std::uint8_t size_bytes = 0;       // kWrite
    std::uint32_t mask = 0xFFFFFFFFU;  // kExpect
    const char* mismatch = "";         // kExpect: what another value means
    // kExpect of a built-in mapping (pdo_mapping.write_to_devices false): the start-up then
    // reads the device's whole mapping to show both.
    const canopen::PdoMapping* mapping = nullptr;
    // A kExpect step's read-back passes (the start-up and the cycle judge alike).
    [[nodiscard]] bool accepts(std::uint32_t read_value) const {
      return (read_value & mask) == value;
    }
  };
  // Built once at construction: the cycle allocates nothing.
  void build_setup_plans();
  void append_pdo_steps(std::vector<SetupStep>& steps, std::uint16_t communication_index,
                        std::uint16_t mapping_index, std::uint32_t cob_id,
                        std::uint8_t transmission_type, const canopen::PdoMapping& mapping) const;
  // Start-up: the node's steps through the blocking client; a failure goes into `problems`.
  bool configure_node(SdoClient& sdo, std::size_t slot, std::vector<std::string>& problems);
  // After a node's steps all passed: the ramps just written are what a ramp-only RPDO
  // carries now.
  void node_configured(std::size_t slot);
  std::string describe_mapping_mismatch(SdoClient& sdo, std::size_t slot, const SetupStep& step);
  // In write(): the rebooted node's next step, its timeout, its end.
  void advance_reconfiguration(std::int64_t now_ns);
  void take_reconfiguration_response(const CanFrame& frame, std::int64_t now_ns);
  void end_reconfiguration(std::int64_t now_ns, std::optional<ReconfigurationFailure> failure);

  CanBus& bus_;
  CanConfig config_;
  std::array<MappedPdo, 2> drive_rpdos_{};  // RPDO1, RPDO2
  std::array<MappedPdo, 2> drive_tpdos_{};  // TPDO1, TPDO2
  MappedPdo io_rpdo_{};
  MappedPdo io_tpdo_{};
  std::array<RouteEntry, 2048> routes_{};        // by 11-bit COB-ID
  std::array<NodeRuntime, kNodeCount> nodes_{};  // drives first, then I/O modules
  std::array<DriveRuntime, kDriveCount> drives_{};
  std::array<IoRuntime, kIoModuleCount> io_{};
  std::array<std::vector<SetupStep>, kNodeCount> setup_plans_;
  // The rebooted node the cycle is configuring: one transfer in flight at most.
  struct Reconfiguration {
    bool active = false;
    std::size_t slot = 0;
    std::size_t step = 0;
    bool awaiting = false;
    std::int64_t sent_ns = 0;
  };
  Reconfiguration reconfiguration_;
  std::array<CanFrame, kReceiveBatch> receive_buffer_{};
  std::array<CanSendConfirmation, kReceiveBatch> confirmation_buffer_{};
  std::int64_t last_sync_sent_ns_ = 0;  // 0: no SYNC confirmed yet
  std::int64_t last_sync_queued_ns_ = 0;
  std::optional<std::int64_t> write_applied_ns_;
  CanBusTiming bus_timing_;
  std::int64_t now_ns_ = 0;
  bool fault_reset_pressed_ = false;
  bool reset_phase_ = false;
  // Scans since the master's last heartbeat: it goes out every heartbeat_every_ scans.
  std::uint32_t scans_since_heartbeat_ = 0;
  std::uint32_t heartbeat_every_ = 1;
  bool nmt_commanded_ = false;  // start-up running, or the nodes stopped by shut_down()
  CanErrorState bus_state_ = CanErrorState::kErrorActive;
  CanopenCounters counters_;

  std::array<CanopenEvent, kEventCapacity> events_{};
  std::atomic<std::size_t> event_head_{0};  // next to pop (consumer)
  std::atomic<std::size_t> event_tail_{0};  // next to push (producer: the scan thread)
};

}  // namespace fl::drivers
