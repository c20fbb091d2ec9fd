#include "fl/drivers/can_config.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <map>
#include <string>

#include "fl/controller/config_loader.hpp"
#include "fl/controller/yaml_reader.hpp"

namespace fl::drivers {
namespace {

using canopen::NodeId;

// COB-IDs are written in hex, as in every device manual ("0x181"); the strict reader's
// integers are decimal only, so they are read as text and parsed here.
std::uint32_t read_cob_id(YamlMapReader& map, std::string_view key) {
  const std::string text = map.read_string(key);
  if (text.empty()) {
    return 0;  // missing or wrong type: already reported
  }
  std::uint32_t value = 0;
  const bool hex = text.size() > 2 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X');
  const char* first = text.data() + (hex ? 2 : 0);
  const char* last = text.data() + text.size();
  const auto [end, error] = std::from_chars(first, last, value, hex ? 16 : 10);
  if (error != std::errc{} || end != last) {
    map.report(key, ProblemKind::kWrongType,
               "expected a COB-ID such as 0x181, found \"" + text + "\"");
    return 0;
  }
  // 0x001..0x07F are NMT error control/reserved low ids; 0x080 is SYNC; above 0x7FF is not
  // an 11-bit id. PDOs live in 0x181..0x57F (CiA 301 table 44; we also allow the user range).
  if (value < 0x181 || value > 0x57F) {
    map.report(key, ProblemKind::kOutOfRange,
               "got " + text + ", a PDO COB-ID must be in 0x181..0x57F (CiA 301 table 44)");
    return 0;
  }
  return value;
}

NodeId read_node_id(YamlMapReader& map) {
  return map.read_int<std::uint8_t>("node_id",
                                    Range::closed(canopen::kMinNodeId, canopen::kMaxNodeId));
}

std::uint16_t read_ms(YamlMapReader& map, std::string_view key, double min_ms, double max_ms) {
  return map.read_int<std::uint16_t>(key, Range::closed(min_ms, max_ms));
}

struct DriveDefaults {
  double velocity_units_per_mps = 0.0;
  double acceleration_units_per_mps2 = 0.0;
  double position_counts_per_mm = 0.0;
  std::uint16_t heartbeat_producer_ms = 0;
  std::uint16_t heartbeat_timeout_ms = 0;
  std::uint8_t tpdo2_every_syncs = 1;
};

}  // namespace

std::string_view config_name(IoModuleId id) {
  switch (id) {
    case IoModuleId::kInfeed:
      return "infeed";
    case IoModuleId::kStations:
      return "stations";
    case IoModuleId::kSafety:
      return "safety";
    case IoModuleId::kCount:
      break;
  }
  return "unknown";
}

namespace {

CanConfig read_can_config(YamlReader& reader, const LineConfig& line) {
  CanConfig config;
  config.cycle_period_ns = std::llround(static_cast<double>(line.watchdog.cycle_period_s) * 1e9);
  {
    YamlMapReader root = reader.root();
    {
      YamlMapReader bus = root.map("bus");
      config.interface_name = bus.read_string("interface");
      if (config.interface_name.empty() || config.interface_name.size() > 15) {
        bus.report("interface", ProblemKind::kInvalidValue,
                   "an interface name has 1..15 characters (IFNAMSIZ)");
      }
      // Classic CAN bitrates of CiA 301 table 1 that a line-length bus can use.
      config.bitrate_bps =
          bus.read_int<std::uint32_t>("bitrate_bps", Range::closed(10000, 1000000));
      config.max_bus_load = bus.read_float("max_bus_load", Range::above(0.0).and_at_most(1.0));
      bus.finish();
    }
    {
      YamlMapReader startup = root.map("startup");
      config.sdo_timeout_ms = read_ms(startup, "sdo_timeout_ms", 1, 10000);
      config.boot_timeout_ms = read_ms(startup, "boot_timeout_ms", 1, 60000);
      config.enable_timeout_ms = read_ms(startup, "enable_timeout_ms", 1, 60000);
      startup.finish();
    }
    DriveDefaults defaults;
    {
      YamlMapReader scaling = root.map("drive_defaults");
      defaults.velocity_units_per_mps =
          scaling.read_double("velocity_units_per_mps", Range::positive());
      defaults.acceleration_units_per_mps2 =
          scaling.read_double("acceleration_units_per_mps2", Range::positive());
      defaults.position_counts_per_mm =
          scaling.read_double("position_counts_per_mm", Range::positive());
      defaults.heartbeat_producer_ms = read_ms(scaling, "heartbeat_producer_ms", 1, 65535);
      defaults.heartbeat_timeout_ms = read_ms(scaling, "heartbeat_timeout_ms", 1, 65535);
      defaults.tpdo2_every_syncs =
          scaling.read_int<std::uint8_t>("tpdo2_every_syncs", Range::closed(1, 240));
      scaling.finish();
    }
    {
      YamlMapReader drives = root.map("drives");
      for (std::size_t i = 0; i < kDriveCount; ++i) {
        const auto id = static_cast<DriveId>(i);
        YamlMapReader drive = drives.map(config_name(id));
        DriveNodeConfig& node = config.drives[i];
        node.node_id = read_node_id(drive);
        node.rpdo1_cob_id = read_cob_id(drive, "rpdo1_cob_id");
        node.rpdo2_cob_id = read_cob_id(drive, "rpdo2_cob_id");
        node.tpdo1_cob_id = read_cob_id(drive, "tpdo1_cob_id");
        node.tpdo2_cob_id = read_cob_id(drive, "tpdo2_cob_id");
        // Per-drive overrides of the defaults (a different gearbox or roller diameter).
        node.velocity_units_per_mps = drive.read_double_or(
            "velocity_units_per_mps", defaults.velocity_units_per_mps, Range::positive());
        node.acceleration_units_per_mps2 = drive.read_double_or(
            "acceleration_units_per_mps2", defaults.acceleration_units_per_mps2, Range::positive());
        node.position_counts_per_mm = drive.read_double_or(
            "position_counts_per_mm", defaults.position_counts_per_mm, Range::positive());
        node.heartbeat_producer_ms = defaults.heartbeat_producer_ms;
        node.heartbeat_timeout_ms = defaults.heartbeat_timeout_ms;
        node.tpdo2_every_syncs = defaults.tpdo2_every_syncs;
        node.max_speed_mps = line.limits[i].max_speed_mps;
        node.max_accel_mps2 = line.limits[i].max_accel_mps2;
        drive.finish();
        // Cross-check with line.yaml: the encoder the logic reads is 0x6064, so its scale
        // must be the line's (a mismatch shows as wrong positions everywhere downstream).
        const std::string key =
            "drives." + std::string(config_name(id)) + ".position_counts_per_mm";
        const bool agrees = std::fabs(node.position_counts_per_mm -
                                      static_cast<double>(line.limits[i].counts_per_mm)) <=
                            1e-6 * node.position_counts_per_mm;
        if (!agrees && reader.all_read_ok({key}) && reader.ok()) {
          reader.report_at(key, ProblemKind::kInconsistent,
                           "position counts per mm " + format_number(node.position_counts_per_mm) +
                               " differ from line.yaml drives." + std::string(config_name(id)) +
                               ".counts_per_mm " + format_number(line.limits[i].counts_per_mm));
        }
        // The target velocity at the speed limit must fit 0x60FF (INTEGER32).
        if (node.velocity_units_per_mps * node.max_speed_mps > 2147483647.0) {
          reader.report_at("drives." + std::string(config_name(id)) + ".velocity_units_per_mps",
                           ProblemKind::kOutOfRange,
                           "max_speed_mps times velocity_units_per_mps exceeds INTEGER32");
        }
      }
      drives.finish();
    }
    {
      YamlMapReader io = root.map("io_modules");
      for (std::size_t i = 0; i < kIoModuleCount; ++i) {
        YamlMapReader module = io.map(config_name(static_cast<IoModuleId>(i)));
        IoModuleConfig& node = config.io_modules[i];
        node.node_id = read_node_id(module);
        node.rpdo1_cob_id = read_cob_id(module, "rpdo1_cob_id");
        node.tpdo1_cob_id = read_cob_id(module, "tpdo1_cob_id");
        node.heartbeat_producer_ms = read_ms(module, "heartbeat_producer_ms", 1, 65535);
        node.heartbeat_timeout_ms = read_ms(module, "heartbeat_timeout_ms", 1, 65535);
        module.finish();
      }
      io.finish();
    }
    {
      YamlMapReader scaling = root.map("io_scaling");
      config.io_scaling.level_mm_per_count =
          scaling.read_float("level_mm_per_count", Range::positive());
      config.io_scaling.hopper_opening_mm_per_count =
          scaling.read_float("hopper_opening_mm_per_count", Range::positive());
      config.io_scaling.leveller_rpm_per_count =
          scaling.read_float("leveller_rpm_per_count", Range::positive());
      config.io_scaling.centring_mm_per_count =
          scaling.read_float("centring_mm_per_count", Range::positive());
      scaling.finish();
    }
    root.finish();
  }
  if (!reader.ok()) {
    reader.throw_if_problems();
  }

  // Cross-checks that need the whole file.
  std::map<unsigned, std::string> node_owner;
  std::map<std::uint32_t, std::string> cob_owner;
  const auto claim_node = [&](NodeId id, const std::string& path) {
    const auto [it, inserted] = node_owner.emplace(id, path);
    if (!inserted) {
      reader.report_at(path + ".node_id", ProblemKind::kInconsistent,
                       "node id " + std::to_string(id) + " is also used by " + it->second);
    }
  };
  const auto claim_cob = [&](std::uint32_t cob_id, const std::string& path) {
    const auto [it, inserted] = cob_owner.emplace(cob_id, path);
    if (!inserted) {
      reader.report_at(path, ProblemKind::kInconsistent, "COB-ID is also used by " + it->second);
    }
  };
  const auto check_heartbeat = [&](std::uint16_t producer_ms, std::uint16_t timeout_ms,
                                   const std::string& path) {
    // One lost heartbeat must not fault the line: the timeout spans at least two periods.
    if (timeout_ms < 2U * producer_ms) {
      reader.report_at(path, ProblemKind::kInconsistent,
                       "heartbeat_timeout_ms " + std::to_string(timeout_ms) +
                           " must be at least twice heartbeat_producer_ms " +
                           std::to_string(producer_ms) + " (one lost heartbeat is not a fault)");
    }
  };
  for (std::size_t i = 0; i < kDriveCount; ++i) {
    const std::string path = "drives." + std::string(config_name(static_cast<DriveId>(i)));
    const DriveNodeConfig& node = config.drives[i];
    claim_node(node.node_id, path);
    claim_cob(node.rpdo1_cob_id, path + ".rpdo1_cob_id");
    claim_cob(node.rpdo2_cob_id, path + ".rpdo2_cob_id");
    claim_cob(node.tpdo1_cob_id, path + ".tpdo1_cob_id");
    claim_cob(node.tpdo2_cob_id, path + ".tpdo2_cob_id");
    if (i == 0) {
      check_heartbeat(node.heartbeat_producer_ms, node.heartbeat_timeout_ms,
                      "drive_defaults.heartbeat_timeout_ms");
    }
  }
  for (std::size_t i = 0; i < kIoModuleCount; ++i) {
    const std::string path = "io_modules." + std::string(config_name(static_cast<IoModuleId>(i)));
    const IoModuleConfig& node = config.io_modules[i];
    claim_node(node.node_id, path);
    claim_cob(node.rpdo1_cob_id, path + ".rpdo1_cob_id");
    claim_cob(node.tpdo1_cob_id, path + ".tpdo1_cob_id");
    check_heartbeat(node.heartbeat_producer_ms, node.heartbeat_timeout_ms,
                    path + ".heartbeat_timeout_ms");
  }
  // A heartbeat timeout shorter than a cycle cannot be checked by a cyclic consumer.
  const double cycle_ms = static_cast<double>(config.cycle_period_ns) / 1e6;
  if (static_cast<double>(config.drives[0].heartbeat_timeout_ms) < 2.0 * cycle_ms) {
    reader.report_at("drive_defaults.heartbeat_timeout_ms", ProblemKind::kInconsistent,
                     "must be at least two scan cycles (" + format_number(2.0 * cycle_ms) + " ms)");
  }
  const double load = estimate_bus_load(config);
  if (reader.ok() && load > config.max_bus_load) {
    reader.report_at("bus.bitrate_bps", ProblemKind::kInconsistent,
                     "cyclic traffic needs " + format_number(load * 100.0) +
                         " % of the bitrate in the worst case, over bus.max_bus_load " +
                         format_number(static_cast<double>(config.max_bus_load) * 100.0) + " %");
  }
  reader.throw_if_problems();
  return config;
}

}  // namespace

CanConfig parse_can_config(std::string_view yaml_text, std::string_view source_name,
                           const LineConfig& line) {
  YamlReader reader = YamlReader::from_text(yaml_text, source_name);
  return read_can_config(reader, line);
}

CanConfig load_can_config(const std::filesystem::path& file, const LineConfig& line) {
  YamlReader reader = YamlReader::from_file(file);
  return read_can_config(reader, line);
}

double estimate_bus_load(const CanConfig& config) {
  using canopen::worst_case_frame_bits;
  namespace layout = canopen::layout;
  const double cycle_s = static_cast<double>(config.cycle_period_ns) / 1e9;
  if (cycle_s <= 0.0 || config.bitrate_bps == 0) {
    return 0.0;
  }
  double bits_per_cycle = worst_case_frame_bits(0);  // SYNC
  for (const DriveNodeConfig& drive : config.drives) {
    bits_per_cycle +=
        worst_case_frame_bits(static_cast<std::uint32_t>(layout::kDriveRpdo1.bytes()));
    bits_per_cycle +=
        worst_case_frame_bits(static_cast<std::uint32_t>(layout::kDriveTpdo1.bytes()));
    bits_per_cycle +=
        worst_case_frame_bits(static_cast<std::uint32_t>(layout::kDriveTpdo2.bytes())) /
        static_cast<double>(std::max<std::uint8_t>(drive.tpdo2_every_syncs, 1));
    // RPDO2 is sent on change; a takt stroke changes it twice per second at most: one per
    // 50 cycles is a generous average.
    bits_per_cycle +=
        worst_case_frame_bits(static_cast<std::uint32_t>(layout::kDriveRpdo2.bytes())) / 50.0;
    bits_per_cycle += worst_case_frame_bits(1) * cycle_s * 1000.0 /
                      std::max<double>(drive.heartbeat_producer_ms, 1.0);
  }
  for (const IoModuleConfig& module : config.io_modules) {
    bits_per_cycle += worst_case_frame_bits(static_cast<std::uint32_t>(layout::kIoRpdo1.bytes()));
    bits_per_cycle += worst_case_frame_bits(static_cast<std::uint32_t>(layout::kIoTpdo1.bytes()));
    bits_per_cycle += worst_case_frame_bits(1) * cycle_s * 1000.0 /
                      std::max<double>(module.heartbeat_producer_ms, 1.0);
  }
  return bits_per_cycle / cycle_s / static_cast<double>(config.bitrate_bps);
}

}  // namespace fl::drivers
