// The CAN bus configuration (config/can.yaml): interface, bitrate, node ids of the drives
// and I/O modules, PDO COB-IDs, scaling from line units to drive units, heartbeat timeouts
// and SDO start-up parameters. Loaded with the strict YAML reader: every problem named with
// file, key and line, unknown keys refused, and cross-checked against the line config (the
// encoder scaling must agree with line.yaml's counts_per_mm).
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "fl/controller/line_config.hpp"
#include "fl/controller/process_image.hpp"
#include "fl/drivers/canopen.hpp"

namespace fl::drivers {

struct DriveNodeConfig {
  canopen::NodeId node_id = 0;
  std::uint32_t rpdo1_cob_id = 0;  // controlword + target velocity, every cycle
  std::uint32_t rpdo2_cob_id = 0;  // profile acceleration + deceleration, on change
  std::uint32_t tpdo1_cob_id = 0;  // statusword + position actual, every SYNC
  std::uint32_t tpdo2_cob_id = 0;  // velocity actual, every tpdo2_every_syncs SYNCs
  std::uint8_t tpdo2_every_syncs = 1;
  // Drive velocity units (0x60FF, 0x606C) per m/s of belt surface speed.
  double velocity_units_per_mps = 0.0;
  // Drive acceleration units (0x6083, 0x6084) per m/s^2 at the belt surface.
  double acceleration_units_per_mps2 = 0.0;
  // Position actual (0x6064) counts per mm of belt travel: line.yaml's counts_per_mm.
  double position_counts_per_mm = 0.0;
  std::uint16_t heartbeat_producer_ms = 0;  // written to the drive's 0x1017
  std::uint16_t heartbeat_timeout_ms = 0;   // the master's consumer timeout
  // Copied from line.yaml's drive limits: commands are clamped to them.
  float max_speed_mps = 0.0F;
  float max_accel_mps2 = 0.0F;
};

// The I/O modules (CiA 401) and which signal sits on which channel: see config/can.yaml.
enum class IoModuleId : std::uint8_t {
  kInfeed,    // laser barrier, leveller overload; level, hopper, leveller speed; outputs
  kStations,  // flip plate and squeeze roller switches, centring position; their outputs
  kSafety,    // E-stop chain and operator buttons; lamps
  kCount
};
inline constexpr std::size_t kIoModuleCount = static_cast<std::size_t>(IoModuleId::kCount);
inline constexpr std::size_t index(IoModuleId id) { return static_cast<std::size_t>(id); }
std::string_view config_name(IoModuleId id);

struct IoModuleConfig {
  canopen::NodeId node_id = 0;
  std::uint32_t rpdo1_cob_id = 0;
  std::uint32_t tpdo1_cob_id = 0;
  std::uint16_t heartbeat_producer_ms = 0;
  std::uint16_t heartbeat_timeout_ms = 0;
};

// The controller's own node: it produces a heartbeat that every device consumes (0x1016:01),
// so that a controller that dies or hangs stops the devices by their own safe reactions (a
// drive's quick stop, a module's outputs off) instead of leaving the belts at the last command.
struct MasterConfig {
  canopen::NodeId node_id = 0;
  std::uint16_t heartbeat_producer_ms = 0;  // the master's heartbeat period
  std::uint16_t heartbeat_timeout_ms = 0;   // each device's consumer time for it
};

// Analogue channel scaling: engineering unit per count of the 16-bit value.
struct IoScaling {
  float level_mm_per_count = 0.0F;
  float hopper_opening_mm_per_count = 0.0F;
  float leveller_rpm_per_count = 0.0F;
  float centring_mm_per_count = 0.0F;
};

// The process data this master exchanges, whichever PDO carries it (config/can.yaml
// pdo_mapping). Drives: CiA 402 profile velocity mode; I/O modules: CiA 401.
enum class PdoSignal : std::uint8_t {
  kControlword,          // 0x6040, master -> drive
  kTargetVelocity,       // 0x60FF
  kProfileAcceleration,  // 0x6083
  kProfileDeceleration,  // 0x6084
  kStatusword,           // 0x6041, drive -> master
  kPositionActual,       // 0x6064
  kVelocityActual,       // 0x606C
  kDigitalOutputs,       // 0x6200:01, master -> module
  kAnalogOutput1,        // 0x6411:01..03
  kAnalogOutput2,
  kAnalogOutput3,
  kDigitalInputs,  // 0x6000:01, module -> master
  kAnalogInput1,   // 0x6401:01..03
  kAnalogInput2,
  kAnalogInput3,
  kCount
};
struct PdoSignalInfo {
  PdoSignal signal;
  canopen::PdoEntry object;  // index, sub-index and length in bits, as the device has it
  bool drive;                // a drive's object (else an I/O module's)
  bool to_device;            // carried by an RPDO (else by a TPDO)
  std::string_view name;
};
// Every signal, in PdoSignal order.
std::span<const PdoSignalInfo> pdo_signals();
const PdoSignalInfo& info(PdoSignal signal);
// The signal a mapping entry carries: the same index, sub-index and length; nullopt if none.
std::optional<PdoSignal> find_pdo_signal(const canopen::PdoEntry& entry);

// The PDO mappings the start-up writes, shared by every drive and every module. Defaults:
// canopen::layout. An RPDO that carries the controlword or target velocity is synchronous
// and goes every cycle; one with only the ramps goes when they change.
struct DrivePdoMappings {
  canopen::PdoMapping rpdo1 = canopen::layout::kDriveRpdo1;
  canopen::PdoMapping rpdo2 = canopen::layout::kDriveRpdo2;
  canopen::PdoMapping tpdo1 = canopen::layout::kDriveTpdo1;  // every SYNC
  canopen::PdoMapping tpdo2 = canopen::layout::kDriveTpdo2;  // every tpdo2_every_syncs SYNCs
};
struct IoPdoMappings {
  canopen::PdoMapping rpdo1 = canopen::layout::kIoRpdo1;  // every cycle
  canopen::PdoMapping tpdo1 = canopen::layout::kIoTpdo1;  // every SYNC
};

struct CanConfig {
  std::string interface_name;
  std::uint32_t bitrate_bps = 0;     // set by the OS (ip link), used here for the bus load check
  std::int64_t cycle_period_ns = 0;  // SYNC period = the scan period from line.yaml
  std::uint16_t sdo_timeout_ms = 0;
  std::uint16_t boot_timeout_ms = 0;    // NMT reset to every boot-up message
  std::uint16_t enable_timeout_ms = 0;  // CiA 402 enable sequence at start-up
  float max_bus_load = 0.0F;            // share of the bitrate the cyclic traffic may use
  MasterConfig master;
  std::array<DriveNodeConfig, kDriveCount> drives{};
  std::array<IoModuleConfig, kIoModuleCount> io_modules{};
  IoScaling io_scaling;
  DrivePdoMappings drive_pdos;
  IoPdoMappings io_pdos;
  // false: the devices' mappings are built in; the start-up reads them back and checks them
  // against drive_pdos and io_pdos instead of writing them (pdo_mapping.write_to_devices).
  bool write_pdo_mappings = true;
};

// Throws fl::ConfigError listing every problem.
CanConfig load_can_config(const std::filesystem::path& file, const LineConfig& line);
CanConfig parse_can_config(std::string_view yaml_text, std::string_view source_name,
                           const LineConfig& line);

// Worst-case share of the bitrate used by one cycle's traffic (SYNC, PDOs, heartbeats).
double estimate_bus_load(const CanConfig& config);
// Whether an RPDO goes every cycle (it carries a drive's controlword or target velocity, or a
// module's outputs) rather than on change (only the ramps).
bool carries_cyclic_command(const canopen::PdoMapping& mapping);

}  // namespace fl::drivers
