// The line configuration loader: config/line.yaml equals default_line_config(), and every kind
// of broken file is refused with a message that names file, key path and reason.
#include "fl/controller/config_loader.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <numbers>
#include <string>
#include <vector>

namespace fl {
namespace {

using ::testing::HasSubstr;
using ::testing::IsEmpty;

const std::filesystem::path kReferenceFile =
    std::filesystem::path(FL_SOURCE_DIR) / "config" / "line.yaml";

std::string reference_text() {
  std::ifstream stream(kReferenceFile);
  return std::string(std::istreambuf_iterator<char>(stream), {});
}

// `text` with its only occurrence of `from` replaced; fails the test when `from` is not
// exactly once in it, so that an edit of line.yaml cannot make a test silently vacuous.
std::string replaced(const std::string& text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << "not in line.yaml: " << from;
  if (at == std::string::npos) {
    return text;
  }
  EXPECT_EQ(text.find(from, at + 1), std::string::npos) << "more than once in line.yaml: " << from;
  std::string result = text;
  result.replace(at, from.size(), to);
  return result;
}

// 1-based line of the first occurrence of `needle`, as the messages count lines.
int line_of(const std::string& text, const std::string& needle) {
  const std::size_t at = text.find(needle);
  EXPECT_NE(at, std::string::npos) << needle;
  return 1 + static_cast<int>(
                 std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
}

// The ConfigError that parsing `text` throws; fails the test when it does not throw.
ConfigError parse_error(const std::string& text) {
  try {
    (void)parse_line_config(text, "line.yaml");
  } catch (const ConfigError& error) {
    return error;
  }
  ADD_FAILURE() << "no ConfigError";
  return ConfigError(std::vector<ConfigProblem>{});
}

// ---------------------------------------------------------------- field-by-field comparison

class FieldComparison {
 public:
  void exact(const std::string& field, float loaded, float expected) {
    // Both sides come from the same decimal literals, rounded once to float: bit-equal.
    if (loaded != expected) {
      add(field, loaded, expected);
    }
  }
  void angle(const std::string& field, float loaded_rad, float expected_rad) {
    // The file holds degrees; degrees * pi / 180 rounded to float need not be the float that
    // the C++ literal in radians (itself rounded to 7 digits) gives. 1e-6 rad is far below
    // anything the line can tell apart (camera angle resolution is about 1e-2 rad).
    if (std::abs(loaded_rad - expected_rad) > 1e-6F) {
      add(field, loaded_rad, expected_rad);
    }
  }
  template <typename Value>
  void same(const std::string& field, Value loaded, Value expected) {
    if (loaded != expected) {
      differences_.push_back(field + ": loaded " + std::to_string(static_cast<long>(loaded)) +
                             ", expected " + std::to_string(static_cast<long>(expected)));
    }
  }
  [[nodiscard]] const std::vector<std::string>& differences() const { return differences_; }

 private:
  void add(const std::string& field, float loaded, float expected) {
    differences_.push_back(field + ": loaded " + format_number(loaded) + ", expected " +
                           format_number(expected));
  }
  std::vector<std::string> differences_;
};

std::vector<std::string> compare(const LineConfig& loaded, const LineConfig& expected) {
  FieldComparison c;
  for (std::size_t i = 0; i < kDriveCount; ++i) {
    const std::string name = "drives." + std::string(config_name(static_cast<DriveId>(i))) + ".";
    c.exact(name + "max_speed_mps", loaded.limits[i].max_speed_mps,
            expected.limits[i].max_speed_mps);
    c.exact(name + "max_accel_mps2", loaded.limits[i].max_accel_mps2,
            expected.limits[i].max_accel_mps2);
    c.exact(name + "counts_per_mm", loaded.limits[i].counts_per_mm,
            expected.limits[i].counts_per_mm);
    c.exact(name + "section.start_mm", loaded.sections[i].start_mm, expected.sections[i].start_mm);
    c.exact(name + "section.end_mm", loaded.sections[i].end_mm, expected.sections[i].end_mm);
    c.exact(name + "section.nominal_speed_mps", loaded.sections[i].nominal_speed_mps,
            expected.sections[i].nominal_speed_mps);
  }
  for (std::size_t i = 0; i < kCameraCount; ++i) {
    const std::string name = "cameras." + std::string(config_name(static_cast<CameraId>(i))) + ".";
    c.exact(name + "s_mm", loaded.cameras[i].s_mm, expected.cameras[i].s_mm);
    c.exact(name + "field_of_view_mm", loaded.cameras[i].field_of_view_mm,
            expected.cameras[i].field_of_view_mm);
    c.exact(name + "period_s", loaded.cameras[i].period_s, expected.cameras[i].period_s);
    c.exact(name + "max_age_s", loaded.cameras[i].max_age_s, expected.cameras[i].max_age_s);
  }
  c.exact("line.takt_belt_length_mm", loaded.takt_belt_length_mm, expected.takt_belt_length_mm);
  c.exact("line.placed_at_s_mm", loaded.placed_at_s_mm, expected.placed_at_s_mm);

  const BulkConfig& b = loaded.bulk;
  const BulkConfig& eb = expected.bulk;
  c.exact("bulk.level_setpoint_mm", b.level_setpoint_mm, eb.level_setpoint_mm);
  c.exact("bulk.level_kp_mps_per_mm", b.level_kp_mps_per_mm, eb.level_kp_mps_per_mm);
  c.exact("bulk.level_ki_mps_per_mm_s", b.level_ki_mps_per_mm_s, eb.level_ki_mps_per_mm_s);
  c.exact("bulk.min_speed_mps", b.min_speed_mps, eb.min_speed_mps);
  c.exact("bulk.max_speed_mps", b.max_speed_mps, eb.max_speed_mps);
  c.exact("bulk.hopper_opening_mm", b.hopper_opening_mm, eb.hopper_opening_mm);
  c.exact("bulk.hopper_unblock_opening_mm", b.hopper_unblock_opening_mm,
          eb.hopper_unblock_opening_mm);
  c.exact("bulk.starved_after_s", b.starved_after_s, eb.starved_after_s);
  c.exact("bulk.unblock_duration_s", b.unblock_duration_s, eb.unblock_duration_s);

  c.exact("leveller.speed_rpm", loaded.leveller.speed_rpm, expected.leveller.speed_rpm);
  c.exact("leveller.min_running_rpm", loaded.leveller.min_running_rpm,
          expected.leveller.min_running_rpm);
  c.exact("leveller.spin_up_s", loaded.leveller.spin_up_s, expected.leveller.spin_up_s);

  const TaktConfig& t = loaded.takt;
  const TaktConfig& et = expected.takt;
  c.exact("takt.standard_speed_mps", t.standard_speed_mps, et.standard_speed_mps);
  c.exact("takt.takt_speed_mps", t.takt_speed_mps, et.takt_speed_mps);
  c.exact("takt.takt_accel_mps2", t.takt_accel_mps2, et.takt_accel_mps2);
  c.exact("takt.pull_distance_mm", t.pull_distance_mm, et.pull_distance_mm);
  c.exact("takt.min_period_s", t.min_period_s, et.min_period_s);
  c.exact("takt.min_gap_mm", t.min_gap_mm, et.min_gap_mm);
  c.exact("takt.beam_debounce_s", t.beam_debounce_s, et.beam_debounce_s);
  c.exact("takt.rearm_travel_mm", t.rearm_travel_mm, et.rearm_travel_mm);

  c.exact("flip.plate1_s_mm", loaded.flip.plate1_s_mm, expected.flip.plate1_s_mm);
  c.exact("flip.plate2_s_mm", loaded.flip.plate2_s_mm, expected.flip.plate2_s_mm);
  c.exact("flip.actuation_s", loaded.flip.actuation_s, expected.flip.actuation_s);
  c.exact("flip.clearance_mm", loaded.flip.clearance_mm, expected.flip.clearance_mm);
  c.same("flip.target_side", loaded.flip.target_side, expected.flip.target_side);

  c.exact("reject.reverse_speed_mps", loaded.reject.reverse_speed_mps,
          expected.reject.reverse_speed_mps);
  c.exact("reject.drop_margin_mm", loaded.reject.drop_margin_mm, expected.reject.drop_margin_mm);
  c.exact("reject.min_confidence", loaded.reject.min_confidence, expected.reject.min_confidence);

  c.exact("centring.s_mm", loaded.centring.s_mm, expected.centring.s_mm);
  c.exact("centring.max_shift_mm", loaded.centring.max_shift_mm, expected.centring.max_shift_mm);
  c.exact("centring.deadband_mm", loaded.centring.deadband_mm, expected.centring.deadband_mm);
  c.exact("centring.stroke_time_s", loaded.centring.stroke_time_s, expected.centring.stroke_time_s);

  const MultilaneConfig& m = loaded.multilane;
  const MultilaneConfig& em = expected.multilane;
  c.exact("multilane.common_speed_mps", m.common_speed_mps, em.common_speed_mps);
  c.exact("multilane.max_differential_mps", m.max_differential_mps, em.max_differential_mps);
  c.exact("multilane.belt_track_mm", m.belt_track_mm, em.belt_track_mm);
  c.exact("multilane.angle_gain_per_s", m.angle_gain_per_s, em.angle_gain_per_s);
  c.angle("multilane.angle_done_rad", m.angle_done_rad, em.angle_done_rad);

  c.exact("squeeze.roller_s_mm", loaded.squeeze.roller_s_mm, expected.squeeze.roller_s_mm);
  c.exact("squeeze.thickest_from_rear", loaded.squeeze.thickest_from_rear,
          expected.squeeze.thickest_from_rear);
  c.exact("squeeze.actuation_s", loaded.squeeze.actuation_s, expected.squeeze.actuation_s);

  const ToleranceConfig& tol = loaded.tolerance;
  const ToleranceConfig& etol = expected.tolerance;
  c.angle("tolerance.target_angle_rad", tol.target_angle_rad, etol.target_angle_rad);
  c.same("tolerance.mirror_for_left", tol.mirror_for_left, etol.mirror_for_left);
  c.angle("tolerance.angle_tol_rad", tol.angle_tol_rad, etol.angle_tol_rad);
  c.exact("tolerance.lateral_tol_mm", tol.lateral_tol_mm, etol.lateral_tol_mm);
  c.exact("tolerance.final_reject_s_mm", tol.final_reject_s_mm, etol.final_reject_s_mm);
  c.exact("tolerance.final_reject_pulse_s", tol.final_reject_pulse_s, etol.final_reject_pulse_s);

  c.exact("tracking.match_gate_mm", loaded.tracking.match_gate_mm, expected.tracking.match_gate_mm);
  c.exact("tracking.plates_gate_mm", loaded.tracking.plates_gate_mm,
          expected.tracking.plates_gate_mm);
  c.exact("tracking.nominal_length_mm", loaded.tracking.nominal_length_mm,
          expected.tracking.nominal_length_mm);

  c.exact("watchdog.cycle_period_s", loaded.watchdog.cycle_period_s,
          expected.watchdog.cycle_period_s);
  c.same("watchdog.overrun_fault_cycles", loaded.watchdog.overrun_fault_cycles,
         expected.watchdog.overrun_fault_cycles);
  c.same("watchdog.stall_fault_cycles", loaded.watchdog.stall_fault_cycles,
         expected.watchdog.stall_fault_cycles);
  return c.differences();
}

// ---------------------------------------------------------------- the reference file

TEST(LineConfigFile, ReferenceFileEqualsDefaultConfig) {
  const LineConfig loaded = load_line_config(kReferenceFile);
  EXPECT_THAT(compare(loaded, default_line_config()), IsEmpty());
}

TEST(LineConfigFile, ComparisonCoversEveryField) {
  // 608 bytes is LineConfig on this ABI as compare() knows it (152 four-byte fields and
  // paddings). A new field changes the size: add it to compare(), the loader and line.yaml.
  EXPECT_EQ(sizeof(LineConfig), 608U);
  // The comparison must see a change in the last field of the last block.
  LineConfig changed = default_line_config();
  changed.watchdog.stall_fault_cycles += 1;  // any change will do
  EXPECT_EQ(compare(changed, default_line_config()).size(), 1U);
}

TEST(LineConfigFile, TextAndFileLoadTheSame) {
  const LineConfig from_text = parse_line_config(reference_text(), "line.yaml");
  EXPECT_THAT(compare(from_text, load_line_config(kReferenceFile)), IsEmpty());
}

TEST(LineConfigFile, AnglesAreConvertedFromDegrees) {
  const LineConfig loaded = load_line_config(kReferenceFile);
  // 35 degrees in the file: the placement angle of thesis figure 1.3a.
  EXPECT_NEAR(loaded.tolerance.target_angle_rad, 35.0 * std::numbers::pi / 180.0, 1e-7);
}

// ---------------------------------------------------------------- malformed files

TEST(LineConfigErrors, TypoIsUnknownKeyAndTheRealKeyIsMissing) {
  const std::string text = replaced(reference_text(), "  min_period_s: 0.9", "  min_perod_s: 0.9");
  const ConfigError error = parse_error(text);
  const std::string message = error.what();
  const int line = line_of(text, "min_perod_s");
  EXPECT_THAT(message, HasSubstr("line.yaml:" + std::to_string(line) +
                                 ":3: takt.min_perod_s: unknown key"));  // column 3: indent 2
  EXPECT_THAT(message, HasSubstr("did you mean \"min_period_s\"?"));
  EXPECT_THAT(message, HasSubstr("takt.min_period_s: missing key"));
  EXPECT_EQ(error.problems().size(), 2U);  // the typo and the key it replaced, nothing else
}

TEST(LineConfigErrors, MissingKey) {
  const ConfigError error = parse_error(replaced(reference_text(), "  lateral_tol_mm: 20.0\n", ""));
  EXPECT_THAT(error.what(), HasSubstr("line.yaml:"));
  EXPECT_THAT(error.what(), HasSubstr("tolerance.lateral_tol_mm: missing key"));
  EXPECT_EQ(error.problems().size(), 1U);  // a missing key is no reason for further noise
}

TEST(LineConfigErrors, MissingBlockIsOneProblem) {
  // Without the tracking block its three keys are not reported again one by one.
  const std::string text = replaced(reference_text(), "tracking:\n  match_gate_mm: 80.0",
                                    "tracking_:\n  match_gate_mm: 80.0");
  const ConfigError error = parse_error(text);
  EXPECT_THAT(error.what(), HasSubstr("tracking: missing key"));
  EXPECT_THAT(error.what(), HasSubstr("tracking_: unknown key"));
  EXPECT_EQ(error.problems().size(), 2U);  // the renamed block: missing and unknown
}

TEST(LineConfigErrors, StringWhereANumberIs) {
  const std::string text =
      replaced(reference_text(), "  takt_speed_mps: 0.6", "  takt_speed_mps: fast");
  const std::string message = parse_error(text).what();
  // Column 19: the value after "  takt_speed_mps: " (2 + 14 + 2 characters).
  EXPECT_THAT(message,
              HasSubstr("line.yaml:" + std::to_string(line_of(text, "takt_speed_mps: fast")) +
                        ":19: takt.takt_speed_mps: wrong type: expected a number, "
                        "found \"fast\""));
}

TEST(LineConfigErrors, QuotedNumberIsAString) {
  const std::string text =
      replaced(reference_text(), "  takt_speed_mps: 0.6", "  takt_speed_mps: \"0.6\"");
  EXPECT_THAT(parse_error(text).what(),
              HasSubstr("takt.takt_speed_mps: wrong type: expected a number, found the quoted "
                        "string \"0.6\""));
}

TEST(LineConfigErrors, NegativeSpeedIsOutOfRange) {
  const std::string text =
      replaced(reference_text(), "  reverse_speed_mps: 0.5", "  reverse_speed_mps: -0.5");
  const ConfigError error = parse_error(text);
  EXPECT_THAT(error.what(), HasSubstr("line.yaml:" + std::to_string(line_of(text, "-0.5")) +
                                      ":22: reject.reverse_speed_mps: out of range: got -0.5, "
                                      "must be > 0"));  // column 22: after "  reverse_speed_mps: "
  EXPECT_EQ(error.problems().size(), 1U);  // the drive limit check stays quiet about it
}

TEST(LineConfigErrors, SpeedAboveDriveLimit) {
  // 1.5 m/s is above the guide drive's max_speed_mps of 1.0.
  const std::string text =
      replaced(reference_text(), "{start_mm: 1000.0, end_mm: 2000.0, nominal_speed_mps: 0.50}",
               "{start_mm: 1000.0, end_mm: 2000.0, nominal_speed_mps: 1.5}");
  const ConfigError error = parse_error(text);
  EXPECT_THAT(error.what(),
              HasSubstr("drives.guide.section.nominal_speed_mps: inconsistent values: "
                        "drives.guide.section.nominal_speed_mps = 1.5 exceeds the drive's limit "
                        "drives.guide.max_speed_mps = 1"));
  EXPECT_EQ(error.problems().size(), 1U);
}

TEST(LineConfigErrors, BadIndentationIsSyntaxError) {
  // One space more than its siblings: yaml-cpp reads it as a value that cannot be a map.
  const std::string text =
      replaced(reference_text(), "  min_gap_mm: 200.0", "   min_gap_mm: 200.0");
  const ConfigError error = parse_error(text);
  EXPECT_THAT(error.what(),
              HasSubstr("line.yaml:" + std::to_string(line_of(text, "min_gap_mm")) + ":"));
  EXPECT_THAT(error.what(), HasSubstr("invalid YAML syntax"));
  EXPECT_EQ(error.problems().size(), 1U);  // nothing is read from a broken document
}

TEST(LineConfigErrors, EmptyFile) {
  EXPECT_THAT(parse_error("").what(), HasSubstr("line.yaml: empty file"));
  EXPECT_THAT(parse_error("# only a comment\n").what(), HasSubstr("line.yaml: empty file"));
}

TEST(LineConfigErrors, NonExistentFile) {
  const std::filesystem::path missing = kReferenceFile.parent_path() / "no_such_line.yaml";
  try {
    (void)load_line_config(missing);
    FAIL() << "no ConfigError";
  } catch (const ConfigError& error) {
    EXPECT_THAT(error.what(), HasSubstr(missing.string() + ": cannot read file: no such file"));
  }
}

TEST(LineConfigErrors, FileNameIsInMessagesOfAFile) {
  const std::filesystem::path file =
      std::filesystem::path(::testing::TempDir()) / "fl_config_loader_test_line.yaml";
  {
    std::ofstream stream(file);
    stream << replaced(reference_text(), "  target_side: bone", "  target_side: bones");
  }
  try {
    (void)load_line_config(file);
    ADD_FAILURE() << "no ConfigError";
  } catch (const ConfigError& error) {
    EXPECT_THAT(error.what(), HasSubstr(file.string() + ":"));
    EXPECT_THAT(error.what(), HasSubstr("flip.target_side"));
  }
  std::filesystem::remove(file);
}

TEST(LineConfigErrors, SectionGap) {
  // The guide belt starting 10 mm after transition 2 ends leaves a gap fillets fall into.
  const std::string text = replaced(reference_text(), "{start_mm: 1000.0, end_mm: 2000.0",
                                    "{start_mm: 1010.0, end_mm: 2000.0");
  const ConfigError error = parse_error(text);
  EXPECT_THAT(error.what(),
              HasSubstr("line.yaml:" + std::to_string(line_of(text, "{start_mm: 1010.0")) + ":"));
  EXPECT_THAT(error.what(), HasSubstr("drives.guide.section.start_mm: inconsistent values: "
                                      "drives.guide.section.start_mm = 1010 must equal "
                                      "drives.transition2.section.end_mm = 1000"));
  EXPECT_EQ(error.problems().size(), 1U);
}

TEST(LineConfigErrors, CameraOutsideItsBelt) {
  // Camera 2 at 2900 with 300 mm field of view sees [2750, 3050]: its first 50 mm are on the
  // reject belt, which ends at 2800.
  const std::string text =
      replaced(reference_text(), "position: {s_mm: 2950.0", "position: {s_mm: 2900.0");
  const ConfigError error = parse_error(text);
  EXPECT_THAT(error.what(),
              HasSubstr("cameras.position.s_mm: inconsistent values: field of view [2750, 3050]"));
  EXPECT_THAT(error.what(), HasSubstr("must lie on the centring belt [2800, 3400]"));
  EXPECT_EQ(error.problems().size(), 1U);
}

TEST(LineConfigErrors, FinalCameraMustSeeBeforeTheAirKnife) {
  // 4750 + 300 / 2 = 4900 is past the air knife at 4850, though still on the squeeze belt.
  const std::string text =
      replaced(reference_text(), "final: {s_mm: 4650.0", "final: {s_mm: 4750.0");
  const ConfigError error = parse_error(text);
  EXPECT_THAT(error.what(), HasSubstr("cameras.final.s_mm: inconsistent values"));
  EXPECT_THAT(error.what(), HasSubstr("after the air knife"));
  EXPECT_EQ(error.problems().size(), 1U);
}

// A recording carries the line.yaml it was made with; one made before tracking.plates_gate_mm
// existed still loads, with camera 2 matching within match_gate_mm as it did then.
TEST(LineConfigFile, PlatesGateMissingMeansTheBeltsGate) {
  std::string text = reference_text();
  const std::string key = "  plates_gate_mm: 170.0\n";
  ASSERT_NE(text.find(key), std::string::npos);
  text.erase(text.find(key), key.size());
  const LineConfig loaded = parse_line_config(text, "line.yaml");
  EXPECT_FLOAT_EQ(loaded.tracking.plates_gate_mm, loaded.tracking.match_gate_mm);
}

// Likewise a line.yaml from before watchdog.stall_fault_cycles: the runtime's fixed 10 periods.
TEST(LineConfigFile, StallLimitMissingMeansTenPeriods) {
  std::string text = reference_text();
  const std::string key = "  stall_fault_cycles: 10";
  ASSERT_NE(text.find(key), std::string::npos);
  text.erase(text.find(key), text.find('\n', text.find(key)) + 1 - text.find(key));
  EXPECT_EQ(parse_line_config(text, "line.yaml").watchdog.stall_fault_cycles, 10);
}

TEST(LineConfigErrors, StallLimitOfOnePeriodIsRefused) {
  // One period without a scan is the scheduler's jitter alone: it would fault a healthy line.
  const std::string text =
      replaced(reference_text(), "  stall_fault_cycles: 10", "  stall_fault_cycles: 1");
  EXPECT_THAT(parse_error(text).what(), HasSubstr("watchdog.stall_fault_cycles"));
}

// And one from before takt.rearm_travel_mm: only a clear beam re-arms the takt, as then.
TEST(LineConfigFile, RearmTravelMissingMeansOff) {
  std::string text = reference_text();
  const std::string key = "  rearm_travel_mm: 190.0\n";
  ASSERT_NE(text.find(key), std::string::npos);
  text.erase(text.find(key), key.size());
  EXPECT_EQ(parse_line_config(text, "line.yaml").takt.rearm_travel_mm, 0.0F);
}

TEST(LineConfigErrors, RearmTravelShorterThanAFilletIsRefused) {
  // 120 mm is past the 110 mm pull but short of the 170 mm nominal fillet: the pulled
  // fillet's tail could still break the beam and be struck as the next row.
  const std::string text =
      replaced(reference_text(), "  rearm_travel_mm: 190.0", "  rearm_travel_mm: 120.0");
  const ConfigError error = parse_error(text);
  EXPECT_THAT(error.what(), HasSubstr("takt.rearm_travel_mm = 120 must be 0 (off) or at least "
                                      "tracking.nominal_length_mm = 170"));
  EXPECT_EQ(error.problems().size(), 1U);
}

TEST(LineConfigErrors, PlatesGateNarrowerThanTheBeltsGate) {
  const std::string text =
      replaced(reference_text(), "  plates_gate_mm: 170.0", "  plates_gate_mm: 60.0");
  EXPECT_THAT(parse_error(text).what(), HasSubstr("tracking.plates_gate_mm"));
}

TEST(LineConfigErrors, FlipPlatesOutOfOrder) {
  // Plate 1 at 2160 is downstream of plate 2 at 2150, though still in the 2000..2200 gap.
  const std::string text =
      replaced(reference_text(), "  plate1_s_mm: 2050.0", "  plate1_s_mm: 2160.0");
  EXPECT_THAT(parse_error(text).what(),
              HasSubstr("flip.plate1_s_mm: inconsistent values: flip.plate1_s_mm = 2160 must be "
                        "upstream of flip.plate2_s_mm = 2150"));
}

TEST(LineConfigErrors, MultilaneDifferentialBeyondTheDrives) {
  // 2.5 m/s exceeds 1.0 + 1.0: one belt full forward, the other full reverse.
  const std::string text =
      replaced(reference_text(), "  max_differential_mps: 0.5", "  max_differential_mps: 2.5");
  const ConfigError error = parse_error(text);
  EXPECT_THAT(error.what(), HasSubstr("multilane.max_differential_mps = 2.5 exceeds 2"));
  EXPECT_EQ(error.problems().size(), 2U);  // once per multilane unit
}

TEST(LineConfigErrors, BadEnumValue) {
  const std::string text =
      replaced(reference_text(), "  target_side: bone", "  target_side: bones");
  EXPECT_THAT(parse_error(text).what(),
              HasSubstr("line.yaml:" + std::to_string(line_of(text, "bones")) +
                        ":16: flip.target_side: invalid value: got \"bones\", expected one of: "
                        "skin, bone"));  // column 16: after "  target_side: "
}

TEST(LineConfigErrors, MultipleProblemsAreAllReported) {
  std::string text = reference_text();
  text = replaced(text, "  min_period_s: 0.9", "  min_perod_s: 0.9");              // 2 problems
  text = replaced(text, "  reverse_speed_mps: 0.5", "  reverse_speed_mps: -0.5");  // 1
  text = replaced(text, "  target_side: bone", "  target_side: bones");            // 1
  text = replaced(text, "  lateral_tol_mm: 20.0\n", "");                           // 1
  const ConfigError error = parse_error(text);
  EXPECT_EQ(error.problems().size(), 5U);  // the sum of the counts above
  const std::string message = error.what();
  EXPECT_THAT(message, HasSubstr("5 configuration problems:\n"));
  EXPECT_THAT(message, HasSubstr("\nline.yaml:" + std::to_string(line_of(text, "min_perod_s"))));
  EXPECT_THAT(message, HasSubstr("takt.min_period_s: missing key"));
  EXPECT_THAT(message, HasSubstr("reject.reverse_speed_mps: out of range"));
  EXPECT_THAT(message, HasSubstr("flip.target_side: invalid value"));
  EXPECT_THAT(message, HasSubstr("tolerance.lateral_tol_mm: missing key"));
  // One problem per line after the header line.
  EXPECT_EQ(std::count(message.begin(), message.end(), '\n'), 5);
}

TEST(LineConfigErrors, SectionOnADriveWithoutOne) {
  // The right belt of unit 1 shares the unit's section, which is registered on the left drive.
  const std::string text =
      replaced(reference_text(), "  multilane1_right:\n",
               "  multilane1_right:\n    section: {start_mm: 3400.0, end_mm: 3800.0, "
               "nominal_speed_mps: 0.40}\n");
  EXPECT_THAT(parse_error(text).what(),
              HasSubstr("drives.multilane1_right.section: unknown key: a multilane unit's section "
                        "belongs to its left drive"));
}

}  // namespace
}  // namespace fl
