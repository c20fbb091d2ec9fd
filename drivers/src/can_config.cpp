#include "fl/drivers/can_config.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <map>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "fl/controller/config_loader.hpp"
#include "fl/controller/yaml_reader.hpp"
#include "hex_text.hpp"

namespace fl::drivers {
namespace {

using canopen::NodeId;

// COB-IDs and mapping values are written in hex, as in every device manual ("0x181"); the
// strict reader's integers are decimal only, so they are read as text and parsed here: an
// unsigned 32-bit number, "0x"-prefixed hex, or decimal unless `hex_only`; nullopt otherwise.
std::optional<std::uint32_t> parse_number(std::string_view text, bool hex_only) {
  const bool hex = text.size() > 2 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X');
  if (hex_only && !hex) return std::nullopt;
  std::uint32_t value = 0;
  const char* last = text.data() + text.size();
  const auto [end, error] =
      std::from_chars(text.data() + (hex ? 2 : 0), last, value, hex ? 16 : 10);
  if (error != std::errc{} || end != last) return std::nullopt;
  return value;
}

std::uint32_t read_cob_id(YamlMapReader& map, std::string_view key) {
  const std::string text = map.read_string(key);
  if (text.empty()) {
    return 0;  // missing or wrong type: already reported
  }
  const std::optional<std::uint32_t> parsed = parse_number(text, false);
  if (!parsed) {
    map.report(key, ProblemKind::kWrongType,
               "expected a COB-ID such as 0x181, found \"" + text + "\"");
    return 0;
  }
  const std::uint32_t value = *parsed;
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

constexpr std::array<PdoSignalInfo, static_cast<std::size_t>(PdoSignal::kCount)> kPdoSignals{{
    {PdoSignal::kControlword, {0x6040, 0, 16}, true, true, "controlword"},
    {PdoSignal::kTargetVelocity, {0x60FF, 0, 32}, true, true, "target velocity"},
    {PdoSignal::kProfileAcceleration, {0x6083, 0, 32}, true, true, "profile acceleration"},
    {PdoSignal::kProfileDeceleration, {0x6084, 0, 32}, true, true, "profile deceleration"},
    {PdoSignal::kStatusword, {0x6041, 0, 16}, true, false, "statusword"},
    {PdoSignal::kPositionActual, {0x6064, 0, 32}, true, false, "position actual"},
    {PdoSignal::kVelocityActual, {0x606C, 0, 32}, true, false, "velocity actual"},
    {PdoSignal::kDigitalOutputs, {0x6200, 1, 8}, false, true, "digital outputs 1-8"},
    {PdoSignal::kAnalogOutput1, {0x6411, 1, 16}, false, true, "analogue output 1"},
    {PdoSignal::kAnalogOutput2, {0x6411, 2, 16}, false, true, "analogue output 2"},
    {PdoSignal::kAnalogOutput3, {0x6411, 3, 16}, false, true, "analogue output 3"},
    {PdoSignal::kDigitalInputs, {0x6000, 1, 8}, false, false, "digital inputs 1-8"},
    {PdoSignal::kAnalogInput1, {0x6401, 1, 16}, false, false, "analogue input 1"},
    {PdoSignal::kAnalogInput2, {0x6401, 2, 16}, false, false, "analogue input 2"},
    {PdoSignal::kAnalogInput3, {0x6401, 3, 16}, false, false, "analogue input 3"},
}};

// "0x60400010 (controlword)": how problems name a mapped object.
std::string describe_object(const canopen::PdoEntry& entry) {
  std::string text = hex_text(entry.mapping_value(), 8);
  if (const std::optional<PdoSignal> signal = find_pdo_signal(entry)) {
    text += " (" + std::string(info(*signal).name) + ")";
  }
  return text;
}

// One PDO's mapping: a sequence of mapping values as the device's 0x16xx/0x1Axx sub-entries
// hold them ("0x60400010": index 0x6040, sub-index 0x00, 16 bits), each an object of this
// device kind and direction.
canopen::PdoMapping read_pdo_mapping(YamlMapReader& map, std::string_view key, bool drive,
                                     bool to_device) {
  canopen::PdoMapping mapping;
  const std::vector<std::string> texts = map.read_strings(key);
  if (texts.size() > canopen::kMaxPdoEntries) {
    map.report(key, ProblemKind::kInvalidValue,
               "maps " + std::to_string(texts.size()) + " objects, a PDO holds at most " +
                   std::to_string(canopen::kMaxPdoEntries));
    return mapping;
  }
  const char* device = drive ? "a drive" : "an I/O module";
  for (std::size_t i = 0; i < texts.size(); ++i) {
    const std::string& text = texts[i];
    const std::string element = "element " + std::to_string(i) + " \"" + text + "\": ";
    const std::optional<std::uint32_t> value = parse_number(text, true);
    if (!value) {
      map.report(key, ProblemKind::kWrongType,
                 element +
                     "expected a mapping value such as 0x60400010 (index 0x6040, "
                     "sub-index 0x00, 16 bits)");
      continue;
    }
    const canopen::PdoEntry entry = canopen::PdoEntry::from_mapping_value(*value);
    const std::optional<PdoSignal> signal = find_pdo_signal(entry);
    if (!signal || info(*signal).drive != drive) {
      std::string known;
      for (const PdoSignalInfo& candidate : pdo_signals()) {
        if (candidate.drive == drive && candidate.to_device == to_device) {
          known += (known.empty() ? "" : ", ") + describe_object(candidate.object);
        }
      }
      map.report(key, ProblemKind::kInvalidValue,
                 element + "not an object this master exchanges with " + device +
                     " (index, sub-index and length must match); this PDO can carry " + known);
      continue;
    }
    if (info(*signal).to_device != to_device) {
      map.report(key, ProblemKind::kInvalidValue,
                 element + std::string(info(*signal).name) +
                     (to_device ? " is sent by the device: it belongs in a TPDO"
                                : " is sent by the master: it belongs in an RPDO"));
      continue;
    }
    mapping.entries[mapping.count++] = entry;
  }
  if (mapping.bytes() > kCanMaxDataBytes) {
    map.report(key, ProblemKind::kInvalidValue,
               "carries " + std::to_string(mapping.bytes()) + " bytes, more than a CAN frame's " +
                   std::to_string(kCanMaxDataBytes));
  }
  return mapping;
}

// Every signal of the device kind is carried, and by one PDO only.
void check_pdo_signals(
    YamlReader& reader, const std::string& path, bool drive,
    std::span<const std::pair<std::string_view, const canopen::PdoMapping*>> pdos) {
  std::array<std::string_view, static_cast<std::size_t>(PdoSignal::kCount)> carrier{};
  for (const auto& [key, mapping] : pdos) {
    for (std::uint8_t i = 0; i < mapping->count; ++i) {
      const std::optional<PdoSignal> signal = find_pdo_signal(mapping->entries[i]);
      if (!signal) continue;  // already reported
      std::string_view& owner = carrier[static_cast<std::size_t>(*signal)];
      if (!owner.empty()) {
        reader.report_at(
            path + "." + std::string(key), ProblemKind::kInconsistent,
            describe_object(mapping->entries[i]) + " is also mapped in " + std::string(owner));
      }
      owner = key;
    }
  }
  for (const PdoSignalInfo& signal : pdo_signals()) {
    if (signal.drive == drive && carrier[static_cast<std::size_t>(signal.signal)].empty()) {
      reader.report_at(path, ProblemKind::kInconsistent,
                       "no PDO carries " + describe_object(signal.object) +
                           ": the master exchanges it every cycle");
    }
  }
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

std::span<const PdoSignalInfo> pdo_signals() { return kPdoSignals; }

const PdoSignalInfo& info(PdoSignal signal) {
  return kPdoSignals[static_cast<std::size_t>(signal)];
}

std::optional<PdoSignal> find_pdo_signal(const canopen::PdoEntry& entry) {
  for (const PdoSignalInfo& candidate : kPdoSignals) {
    if (candidate.object.index == entry.index && candidate.object.subindex == entry.subindex &&
        candidate.object.bits == entry.bits) {
      return candidate.signal;
    }
  }
  return std::nullopt;
}

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
    {
      YamlMapReader master = root.map("master");
      config.master.node_id = read_node_id(master);
      config.master.heartbeat_producer_ms = read_ms(master, "heartbeat_producer_ms", 1, 65535);
      config.master.heartbeat_timeout_ms = read_ms(master, "heartbeat_timeout_ms", 1, 65535);
      master.finish();
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
    // Optional: without it, canopen::layout's mappings (the defaults of CanConfig).
    if (root.has("pdo_mapping")) {
      YamlMapReader mapping = root.map("pdo_mapping");
      config.write_pdo_mappings = mapping.read_bool_or("write_to_devices", true);
      if (mapping.has("drive")) {
        YamlMapReader drive = mapping.map("drive");
        DrivePdoMappings& pdos = config.drive_pdos;
        pdos.rpdo1 = read_pdo_mapping(drive, "rpdo1", true, true);
        pdos.rpdo2 = read_pdo_mapping(drive, "rpdo2", true, true);
        pdos.tpdo1 = read_pdo_mapping(drive, "tpdo1", true, false);
        pdos.tpdo2 = read_pdo_mapping(drive, "tpdo2", true, false);
        drive.finish();
        const std::array<std::pair<std::string_view, const canopen::PdoMapping*>, 4> all{
            {{"rpdo1", &pdos.rpdo1},
             {"rpdo2", &pdos.rpdo2},
             {"tpdo1", &pdos.tpdo1},
             {"tpdo2", &pdos.tpdo2}}};
        check_pdo_signals(reader, "pdo_mapping.drive", true, all);
      }
      if (mapping.has("io_module")) {
        YamlMapReader io = mapping.map("io_module");
        IoPdoMappings& pdos = config.io_pdos;
        pdos.rpdo1 = read_pdo_mapping(io, "rpdo1", false, true);
        pdos.tpdo1 = read_pdo_mapping(io, "tpdo1", false, false);
        io.finish();
        const std::array<std::pair<std::string_view, const canopen::PdoMapping*>, 2> all{
            {{"rpdo1", &pdos.rpdo1}, {"tpdo1", &pdos.tpdo1}}};
        check_pdo_signals(reader, "pdo_mapping.io_module", false, all);
      }
      mapping.finish();
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
  claim_node(config.master.node_id, "master");
  check_heartbeat(config.master.heartbeat_producer_ms, config.master.heartbeat_timeout_ms,
                  "master.heartbeat_timeout_ms");
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
  // The master sends its heartbeat from the scan: at most once a cycle.
  if (static_cast<double>(config.master.heartbeat_producer_ms) < cycle_ms) {
    reader.report_at("master.heartbeat_producer_ms", ProblemKind::kInconsistent,
                     "must be at least one scan cycle (" + format_number(cycle_ms) +
                         " ms): the scan sends the master's heartbeat");
  }
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
  const auto frame_bits = [](const canopen::PdoMapping& mapping) {
    // An empty PDO is never sent.
    return mapping.count == 0
               ? 0.0
               : canopen::worst_case_frame_bits(static_cast<std::uint32_t>(mapping.bytes()));
  };
  const double cycle_s = static_cast<double>(config.cycle_period_ns) / 1e9;
  if (cycle_s <= 0.0 || config.bitrate_bps == 0) {
    return 0.0;
  }
  const DrivePdoMappings& drive_pdos = config.drive_pdos;
  double bits_per_cycle = canopen::worst_case_frame_bits(0);  // SYNC
  bits_per_cycle += canopen::worst_case_frame_bits(1) * cycle_s * 1000.0 /
                    std::max<double>(config.master.heartbeat_producer_ms, 1.0);
  for (const DriveNodeConfig& drive : config.drives) {
    // An RPDO with only the ramps is sent on change; a takt stroke changes them twice per
    // second at most: one per 50 cycles is a generous average.
    for (const canopen::PdoMapping* rpdo : {&drive_pdos.rpdo1, &drive_pdos.rpdo2}) {
      bits_per_cycle += frame_bits(*rpdo) / (carries_cyclic_command(*rpdo) ? 1.0 : 50.0);
    }
    bits_per_cycle += frame_bits(drive_pdos.tpdo1);
    bits_per_cycle += frame_bits(drive_pdos.tpdo2) /
                      static_cast<double>(std::max<std::uint8_t>(drive.tpdo2_every_syncs, 1));
    bits_per_cycle += canopen::worst_case_frame_bits(1) * cycle_s * 1000.0 /
                      std::max<double>(drive.heartbeat_producer_ms, 1.0);
  }
  for (const IoModuleConfig& module : config.io_modules) {
    bits_per_cycle += frame_bits(config.io_pdos.rpdo1);
    bits_per_cycle += frame_bits(config.io_pdos.tpdo1);
    bits_per_cycle += canopen::worst_case_frame_bits(1) * cycle_s * 1000.0 /
                      std::max<double>(module.heartbeat_producer_ms, 1.0);
  }
  return bits_per_cycle / cycle_s / static_cast<double>(config.bitrate_bps);
}

bool carries_cyclic_command(const canopen::PdoMapping& mapping) {
  for (std::uint8_t i = 0; i < mapping.count; ++i) {
    const std::optional<PdoSignal> signal = find_pdo_signal(mapping.entries[i]);
    if (signal == PdoSignal::kControlword || signal == PdoSignal::kTargetVelocity ||
        (signal && !info(*signal).drive)) {
      return true;
    }
  }
  return false;
}

}  // namespace fl::drivers
