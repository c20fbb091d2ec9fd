// config/can.yaml: the reference file loads and agrees with line.yaml; every kind of
// mistake is named with file, key and line.
#include "fl/drivers/can_config.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <string>

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

TEST(CanConfig, BusLoadOverTheLimitIsRefused) {
  // At 500 kbit/s the same traffic needs about 106 %.
  const std::string text =
      replaced(reference_text(), "bitrate_bps: 1000000", "bitrate_bps: 500000");
  const std::string problems = problems_of(text, test::reference_line_config());
  EXPECT_NE(problems.find("bus.bitrate_bps: inconsistent"), std::string::npos) << problems;
}

TEST(CanConfig, MissingFileIsAProblemNotACrash) {
  EXPECT_THROW(load_can_config("/nonexistent/can.yaml", test::reference_line_config()),
               ConfigError);
}

}  // namespace
}  // namespace fl::drivers
