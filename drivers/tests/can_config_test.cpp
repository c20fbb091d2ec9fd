// config/can.yaml: the reference file loads and agrees with line.yaml; every kind of
// mistake is named with file, key and line.
#include "fl/drivers/can_config.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <string>
#include <vector>

#include "fl/controller/config_loader.hpp"
#include "fl/controller/yaml_reader.hpp"
#include "loopback_rig.hpp"

namespace fl::drivers {
namespace {

std::string reference_text() {
  std::ifstream stream(std::string(FL_SOURCE_DIR) + "/config/can.yaml");
  return std::string((std::istreambuf_iterator<char>(stream)), std::istreambuf_iterator<char>());
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) {
    text.replace(at, from.size(), to);
  }
  return text;
}

// The problems' text, one per line, for EXPECT_THAT-free substring checks.
std::string problems_of(const std::string& text, const LineConfig& line) {
  try {
    parse_can_config(text, "can.yaml", line);
  } catch (const ConfigError& error) {
    std::string all;
    for (const ConfigProblem& problem : error.problems()) {
      all += problem.to_string() + "\n";
    }
    return all;
  }
  return "";
}

TEST(CanConfig, ReferenceFileLoads) {
  const CanConfig config = test::reference_can_config();
  EXPECT_EQ(config.interface_name, "vcan0");
  EXPECT_EQ(config.drives[index(DriveId::kTakt)].node_id, 2);
  EXPECT_EQ(config.drives[index(DriveId::kTakt)].tpdo1_cob_id, 0x182U);
  EXPECT_EQ(config.drives[index(DriveId::kMultilane2Left)].rpdo1_cob_id, 0x20AU);
  EXPECT_EQ(config.io_modules[index(IoModuleId::kSafety)].heartbeat_timeout_ms, 60);
  EXPECT_EQ(config.cycle_period_ns, 10'000'000);  // line.yaml watchdog.cycle_period_s 0.01
  // Limits come from line.yaml: takt 8 m/s^2.
  EXPECT_FLOAT_EQ(config.drives[index(DriveId::kTakt)].max_accel_mps2, 8.0F);
}

TEST(CanConfig, BusLoadOfTheReferenceIsAboutHalfOfOneMegabit) {
  const double load = estimate_bus_load(test::reference_can_config());
  // Hand count: 13 drives x (115 + 115 + 95) bits + 3 modules x 2 x 125 + SYNC 55 + heartbeats
  // and RPDO2 share about 260 per 10 ms: about 5.3 kbit per cycle = 53 %.
  EXPECT_GT(load, 0.50);
  EXPECT_LT(load, 0.56);
}

TEST(CanConfig, EncoderScaleMustAgreeWithLineYaml) {
  const std::string text =
      replaced(reference_text(), "position_counts_per_mm: 10.0 ", "position_counts_per_mm: 12.5 ");
  const std::string problems = problems_of(text, test::reference_line_config());
  EXPECT_NE(problems.find("drives.bulk.position_counts_per_mm"), std::string::npos) << problems;
  EXPECT_NE(problems.find("counts_per_mm 10"), std::string::npos) << problems;
}

TEST(CanConfig, UnknownKeyIsRefusedWithItsLine) {
  const std::string text =
      replaced(reference_text(), "  max_bus_load: 0.6", "  max_bus_load: 0.6\n  bitrate: 500000");
  const std::string problems = problems_of(text, test::reference_line_config());
  EXPECT_NE(problems.find("can.yaml:"), std::string::npos) << problems;
  EXPECT_NE(problems.find("bus.bitrate: unknown key"), std::string::npos) << problems;
}

TEST(CanConfig, DuplicateNodeIdsAndCobIdsAreNamed) {
  std::string text = replaced(reference_text(), "takt:             {node_id: 2,",
                              "takt:             {node_id: 1,");
  text = replaced(text, "tpdo1_cob_id: \"0x182\"", "tpdo1_cob_id: \"0x181\"");
  const std::string problems = problems_of(text, test::reference_line_config());
  EXPECT_NE(problems.find("drives.takt.node_id"), std::string::npos) << problems;
  EXPECT_NE(problems.find("also used by drives.bulk"), std::string::npos) << problems;
  EXPECT_NE(problems.find("drives.takt.tpdo1_cob_id"), std::string::npos) << problems;
}

TEST(CanConfig, CobIdMustBeHexInThePdoRange) {
  std::string text = replaced(reference_text(), "\"0x201\"", "\"0x2G1\"");
  text = replaced(text, "\"0x302\"", "\"0x080\"");  // SYNC's id
  const std::string problems = problems_of(text, test::reference_line_config());
  EXPECT_NE(problems.find("drives.bulk.rpdo1_cob_id: wrong type"), std::string::npos) << problems;
  EXPECT_NE(problems.find("drives.takt.rpdo2_cob_id: out of range"), std::string::npos) << problems;
}

TEST(CanConfig, HeartbeatTimeoutMustSpanTwoPeriods) {
  const std::string text =
      replaced(reference_text(), "heartbeat_producer_ms: 20, heartbeat_timeout_ms: 60",
               "heartbeat_producer_ms: 40, heartbeat_timeout_ms: 60");
  const std::string problems = problems_of(text, test::reference_line_config());
  EXPECT_NE(problems.find("io_modules.safety.heartbeat_timeout_ms"), std::string::npos) << problems;
}

TEST(CanConfig, TheMastersHeartbeatIsCheckedLikeADevices) {
  const CanConfig config = test::reference_can_config();
  EXPECT_EQ(config.master.node_id, 127);
  EXPECT_EQ(config.master.heartbeat_producer_ms, 20);
  EXPECT_EQ(config.master.heartbeat_timeout_ms, 150);
  const std::string master =
      "  node_id: 127\n  heartbeat_producer_ms: 20\n  heartbeat_timeout_ms: 150";
  // The bulk drive's node id; a timeout one period long (one lost heartbeat would stop the
  // line); a period shorter than the 10 ms scan that sends it.
  const std::string text =
      replaced(reference_text(), master,
               "  node_id: 1\n  heartbeat_producer_ms: 5\n  heartbeat_timeout_ms: 5");
  const std::string problems = problems_of(text, test::reference_line_config());
  EXPECT_NE(problems.find("drives.bulk.node_id"), std::string::npos) << problems;
  EXPECT_NE(problems.find("also used by master"), std::string::npos) << problems;
  EXPECT_NE(problems.find("master.heartbeat_timeout_ms"), std::string::npos) << problems;
  EXPECT_NE(problems.find("master.heartbeat_producer_ms"), std::string::npos) << problems;
  // Without the block the devices could not be told to watch the controller: refused.
  const std::string without = replaced(reference_text(), "master:\n" + master + "\n", "");
  EXPECT_NE(problems_of(without, test::reference_line_config()).find("master"), std::string::npos);
}

TEST(CanConfig, BusLoadOverTheLimitIsRefused) {
  // At 500 kbit/s the same traffic needs about 106 %.
  const std::string text =
      replaced(reference_text(), "bitrate_bps: 1000000", "bitrate_bps: 500000");
  const std::string problems = problems_of(text, test::reference_line_config());
  EXPECT_NE(problems.find("bus.bitrate_bps: inconsistent"), std::string::npos) << problems;
}

bool same_mapping(const canopen::PdoMapping& a, const canopen::PdoMapping& b) {
  if (a.count != b.count) return false;
  for (std::uint8_t i = 0; i < a.count; ++i) {
    if (!(a.entries[i].mapping_value() == b.entries[i].mapping_value())) return false;
  }
  return true;
}

TEST(CanConfig, ThePdoMappingsOfTheReferenceAreTheMastersDefaults) {
  // can.yaml spells out what the master uses without the block, so the two cannot drift.
  const CanConfig config = test::reference_can_config();
  EXPECT_TRUE(same_mapping(config.drive_pdos.rpdo1, canopen::layout::kDriveRpdo1));
  EXPECT_TRUE(same_mapping(config.drive_pdos.rpdo2, canopen::layout::kDriveRpdo2));
  EXPECT_TRUE(same_mapping(config.drive_pdos.tpdo1, canopen::layout::kDriveTpdo1));
  EXPECT_TRUE(same_mapping(config.drive_pdos.tpdo2, canopen::layout::kDriveTpdo2));
  EXPECT_TRUE(same_mapping(config.io_pdos.rpdo1, canopen::layout::kIoRpdo1));
  EXPECT_TRUE(same_mapping(config.io_pdos.tpdo1, canopen::layout::kIoTpdo1));
  const auto block = reference_text().find("pdo_mapping:");
  ASSERT_NE(block, std::string::npos);
  const CanConfig without = parse_can_config(reference_text().substr(0, block), "can.yaml",
                                             test::reference_line_config());
  EXPECT_TRUE(same_mapping(without.drive_pdos.tpdo1, config.drive_pdos.tpdo1));
  EXPECT_TRUE(same_mapping(without.io_pdos.rpdo1, config.io_pdos.rpdo1));
}

TEST(CanConfig, ARegroupedPdoMappingLoads) {
  std::string text = reference_text();
  text = replaced(text, R"(rpdo1: ["0x60400010", "0x60FF0020"])",
                  R"(rpdo1: ["0x60FF0020", "0x60400010"])");
  text = replaced(text, R"(tpdo1: ["0x60410010", "0x60640020"])",
                  R"(tpdo1: ["0x60640020", "0x60410010"])");
  text = replaced(text, R"(tpdo1: ["0x60000108", "0x64010110", "0x64010210", "0x64010310"])",
                  R"(tpdo1: ["0x64010310", "0x60000108", "0x64010110", "0x64010210"])");
  const CanConfig config = parse_can_config(text, "can.yaml", test::reference_line_config());
  EXPECT_EQ(config.drive_pdos.rpdo1.entries[0].index, 0x60FF);
  EXPECT_EQ(config.drive_pdos.tpdo1.entries[1].index, 0x6041);
  EXPECT_EQ(config.io_pdos.tpdo1.entries[0].mapping_value(), 0x64010310U);
  EXPECT_EQ(config.io_pdos.tpdo1.count, 4);
  EXPECT_TRUE(config.write_pdo_mappings);  // written by default
  const CanConfig built_in = parse_can_config(
      replaced(text, "pdo_mapping:\n", "pdo_mapping:\n  write_to_devices: false\n"), "can.yaml",
      test::reference_line_config());
  EXPECT_FALSE(built_in.write_pdo_mappings);
}

TEST(CanConfig, BadPdoMappingsAreNamedWithTheirKeyAndReason) {
  const std::string drive_rpdo1 = R"(rpdo1: ["0x60400010", "0x60FF0020"])";
  const std::string drive_tpdo2 = R"(tpdo2: ["0x606C0020"])";
  const std::string nine_entries =
      R"(tpdo2: ["0x606C0020", "0x606C0020", "0x606C0020", "0x606C0020", "0x606C0020",)"
      R"( "0x606C0020", "0x606C0020", "0x606C0020", "0x606C0020"])";
  struct Case {
    const char* what;
    std::string from;
    std::string to;
    std::vector<std::string> expected;  // each in the problems, which name file and line
  };
  const std::vector<Case> cases{
      {"not a mapping value",
       drive_rpdo1,
       R"(rpdo1: ["0x60400010", "target"])",
       {"can.yaml:", "pdo_mapping.drive.rpdo1", "expected a mapping value such as 0x60400010"}},
      // CiA 402's vl target velocity (0x6042, 16 bits) is not what this master commands: the
      // problem lists what the PDO can carry.
      {"another object",
       drive_rpdo1,
       R"(rpdo1: ["0x60400010", "0x60420010"])",
       {"not an object this master exchanges with a drive", "0x60FF0020 (target velocity)"}},
      {"the right object, the wrong length",
       drive_rpdo1,
       R"(rpdo1: ["0x60400020", "0x60FF0020"])",
       {"not an object this master exchanges"}},
      // The statusword comes from the drive; and then the controlword is missing.
      {"the wrong direction",
       drive_rpdo1,
       R"(rpdo1: ["0x60410010", "0x60FF0020"])",
       {"statusword is sent by the device: it belongs in a TPDO",
        "no PDO carries 0x60400010 (controlword)"}},
      {"mapped nowhere",
       drive_tpdo2,
       R"(tpdo2: [])",
       {"no PDO carries 0x606C0020 (velocity actual)"}},
      // 2 + 4 + 4 bytes.
      {"mapped twice, and too long",
       R"(rpdo2: ["0x60830020", "0x60840020"])",
       R"(rpdo2: ["0x60400010", "0x60830020", "0x60840020"])",
       {"0x60400010 (controlword) is also mapped in rpdo1",
        "carries 10 bytes, more than a CAN frame's 8"}},
      {"an I/O module's object",
       drive_tpdo2,
       R"(tpdo2: ["0x606C0020", "0x60000108"])",
       {"not an object this master exchanges with a drive"}},
      {"nine entries", drive_tpdo2, nine_entries, {"maps 9 objects, a PDO holds at most 8"}},
  };
  const LineConfig line = test::reference_line_config();
  for (const Case& bad : cases) {
    SCOPED_TRACE(bad.what);
    const std::string problems = problems_of(replaced(reference_text(), bad.from, bad.to), line);
    for (const std::string& expected : bad.expected) {
      EXPECT_NE(problems.find(expected), std::string::npos) << expected << " in\n" << problems;
    }
  }
}

TEST(CanConfig, MissingFileIsAProblemNotACrash) {
  EXPECT_THROW(load_can_config("/nonexistent/can.yaml", test::reference_line_config()),
               ConfigError);
}

}  // namespace
}  // namespace fl::drivers
