#include "fl/controller/config_loader.hpp"

#include <spdlog/spdlog.h>

#include <array>
#include <numbers>
#include <string>

namespace fl {

namespace {

constexpr std::array<EnumName<SideUp>, 2> kSideNames{{
    {to_string(SideUp::kSkin), SideUp::kSkin},
    {to_string(SideUp::kBone), SideUp::kBone},
}};

// The product-path belts from takt barrier to outfeed, in flow order. Bulk is upstream of
// s = 0 and a multilane unit's section is registered on its left drive.
constexpr std::array kSectionDrives{
    DriveId::kTakt,    DriveId::kTransition1, DriveId::kTransition2,    DriveId::kGuide,
    DriveId::kReject,  DriveId::kCentring,    DriveId::kMultilane1Left, DriveId::kMultilane2Left,
    DriveId::kSqueeze, DriveId::kOutfeed};

constexpr std::array<DriveId, 4> kMultilaneDrives{
    DriveId::kMultilane1Left, DriveId::kMultilane1Right, DriveId::kMultilane2Left,
    DriveId::kMultilane2Right};

// Converted in double so that the float result is the nearest to the exact angle.
float radians_from_degrees(double degrees) {
  return static_cast<float>(degrees * std::numbers::pi / 180.0);
}

// Full key paths, for cross-checks and their messages.
std::string drive_key(DriveId id, std::string_view field) {
  return "drives." + std::string(to_string(id)) + "." + std::string(field);
}
std::string section_key(DriveId id, std::string_view field) {
  return "drives." + std::string(to_string(id)) + ".section." + std::string(field);
}
std::string camera_key(CameraId id, std::string_view field) {
  return "cameras." + std::string(to_string(id)) + "." + std::string(field);
}

// "drives.guide.section.start_mm = 900"
std::string named(std::string_view key, float value) {
  return std::string(key) + " = " + format_number(value);
}

// ---------------------------------------------------------------- reading

void read_drive(YamlMapReader& drives, DriveId id, LineConfig& config) {
  YamlMapReader drive = drives.map(to_string(id));
  DriveLimits& limits = config.limits[index(id)];
  // Zero would stop the belt, forbid any ramp, or make positions unmeasurable.
  limits.max_speed_mps = drive.read_float("max_speed_mps", Range::positive());
  limits.max_accel_mps2 = drive.read_float("max_accel_mps2", Range::positive());
  limits.counts_per_mm = drive.read_float("counts_per_mm", Range::positive());
  if (has_section(id)) {
    YamlMapReader section = drive.map("section");
    BeltSection& belt = config.sections[index(id)];
    belt.start_mm = section.read_float("start_mm", Range::any());  // cross-checked below
    belt.end_mm = section.read_float("end_mm", Range::any());
    // Product-path belts carry fillets downstream while running.
    belt.nominal_speed_mps = section.read_float("nominal_speed_mps", Range::positive());
    section.finish();
  } else if (drive.has("section")) {
    drive.report("section", ProblemKind::kUnknownKey,
                 id == DriveId::kBulk
                     ? "the bulk belt is upstream of s = 0 and has no section on the line"
                     : "a multilane unit's section belongs to its left drive");
  }
  drive.finish();
}

void read_camera(YamlMapReader& cameras, CameraId id, LineConfig& config) {
  YamlMapReader camera = cameras.map(to_string(id));
  CameraMount& mount = config.cameras[index(id)];
  mount.s_mm = camera.read_float("s_mm", Range::any());  // cross-checked against its belt
  mount.field_of_view_mm = camera.read_float("field_of_view_mm", Range::positive());
  mount.period_s = camera.read_float("period_s", Range::positive());
  mount.max_age_s = camera.read_float("max_age_s", Range::positive());
  camera.finish();
}

void read_stations(YamlMapReader& root, LineConfig& config) {
  {
    YamlMapReader bulk = root.map("bulk");
    BulkConfig& c = config.bulk;
    c.level_setpoint_mm = bulk.read_float("level_setpoint_mm", Range::positive());
    c.level_kp_mps_per_mm = bulk.read_float("level_kp_mps_per_mm", Range::positive());
    // Zero is a plain P controller, which is legitimate.
    c.level_ki_mps_per_mm_s = bulk.read_float("level_ki_mps_per_mm_s", Range::non_negative());
    // The bulk belt only runs forward.
    c.min_speed_mps = bulk.read_float("min_speed_mps", Range::non_negative());
    c.max_speed_mps = bulk.read_float("max_speed_mps", Range::positive());
    c.hopper_opening_mm = bulk.read_float("hopper_opening_mm", Range::positive());
    c.hopper_unblock_opening_mm = bulk.read_float("hopper_unblock_opening_mm", Range::positive());
    c.starved_after_s = bulk.read_float("starved_after_s", Range::positive());
    c.unblock_duration_s = bulk.read_float("unblock_duration_s", Range::positive());
  }
  {
    YamlMapReader leveller = root.map("leveller");
    LevellerConfig& c = config.leveller;
    c.speed_rpm = leveller.read_float("speed_rpm", Range::positive());
    // Zero would switch the jam detection off.
    c.min_running_rpm = leveller.read_float("min_running_rpm", Range::positive());
    c.spin_up_s = leveller.read_float("spin_up_s", Range::non_negative());
  }
  {
    YamlMapReader takt = root.map("takt");
    TaktConfig& c = config.takt;
    c.standard_speed_mps = takt.read_float("standard_speed_mps", Range::positive());
    c.takt_speed_mps = takt.read_float("takt_speed_mps", Range::positive());
    c.takt_accel_mps2 = takt.read_float("takt_accel_mps2", Range::positive());
    c.pull_distance_mm = takt.read_float("pull_distance_mm", Range::positive());
    c.min_period_s = takt.read_float("min_period_s", Range::positive());
    c.min_gap_mm = takt.read_float("min_gap_mm", Range::positive());
    c.beam_debounce_s = takt.read_float("beam_debounce_s", Range::non_negative());  // 0: none
    // Absent: off, the rule before the key existed, so that a recording made then replays
    // the controller it ran.
    c.rearm_travel_mm = takt.read_float_or("rearm_travel_mm", 0.0F, Range::non_negative());
  }
  {
    YamlMapReader flip = root.map("flip");
    FlipConfig& c = config.flip;
    c.plate1_s_mm = flip.read_float("plate1_s_mm", Range::any());  // cross-checked
    c.plate2_s_mm = flip.read_float("plate2_s_mm", Range::any());
    c.actuation_s = flip.read_float("actuation_s", Range::positive());
    // Zero would let a plate switch under a fillet.
    c.clearance_mm = flip.read_float("clearance_mm", Range::positive());
    c.target_side = flip.read_enum("target_side", kSideNames);
  }
  {
    YamlMapReader reject = root.map("reject");
    RejectConfig& c = config.reject;
    c.reverse_speed_mps = reject.read_float("reverse_speed_mps", Range::positive());  // magnitude
    c.drop_margin_mm = reject.read_float("drop_margin_mm", Range::positive());
    c.min_confidence = reject.read_float("min_confidence", Range::closed(0.0, 1.0));
  }
  {
    YamlMapReader centring = root.map("centring");
    CentringConfig& c = config.centring;
    c.s_mm = centring.read_float("s_mm", Range::any());  // cross-checked
    c.max_shift_mm = centring.read_float("max_shift_mm", Range::positive());
    c.deadband_mm = centring.read_float("deadband_mm", Range::non_negative());
    c.stroke_time_s = centring.read_float("stroke_time_s", Range::positive());
  }
  {
    YamlMapReader multilane = root.map("multilane");
    MultilaneConfig& c = config.multilane;
    c.common_speed_mps = multilane.read_float("common_speed_mps", Range::positive());
    c.max_differential_mps = multilane.read_float("max_differential_mps", Range::positive());
    c.belt_track_mm = multilane.read_float("belt_track_mm", Range::positive());
    c.angle_gain_per_s = multilane.read_float("angle_gain_per_s", Range::positive());
    // Beyond half a turn every angle would count as settled.
    c.angle_done_rad = radians_from_degrees(
        multilane.read_double("angle_done_deg", Range::above(0.0).and_at_most(180.0)));
  }
  {
    YamlMapReader squeeze = root.map("squeeze");
    SqueezeConfig& c = config.squeeze;
    c.roller_s_mm = squeeze.read_float("roller_s_mm", Range::any());  // cross-checked
    c.thickest_from_rear = squeeze.read_float("thickest_from_rear", Range::closed(0.0, 1.0));
    c.actuation_s = squeeze.read_float("actuation_s", Range::positive());
  }
  {
    YamlMapReader tolerance = root.map("tolerance");
    ToleranceConfig& c = config.tolerance;
    // Same convention as the camera estimates: (-180, 180] degrees.
    c.target_angle_rad = radians_from_degrees(
        tolerance.read_double("target_angle_deg", Range::above(-180.0).and_at_most(180.0)));
    c.mirror_for_left = tolerance.read_bool("mirror_for_left");
    // Beyond half a turn every angle would pass.
    c.angle_tol_rad = radians_from_degrees(
        tolerance.read_double("angle_tol_deg", Range::above(0.0).and_at_most(180.0)));
    c.lateral_tol_mm = tolerance.read_float("lateral_tol_mm", Range::positive());
    c.final_reject_s_mm = tolerance.read_float("final_reject_s_mm", Range::any());  // checked
    c.final_reject_pulse_s = tolerance.read_float("final_reject_pulse_s", Range::positive());
  }
  {
    YamlMapReader tracking = root.map("tracking");
    TrackingConfig& c = config.tracking;
    c.match_gate_mm = tracking.read_float("match_gate_mm", Range::positive());
    // Optional, unlike the other keys: recordings carry the line.yaml they were made with, and
    // before this key camera 2 matched within match_gate_mm, so that is what its absence means.
    c.plates_gate_mm = tracking.read_float_or("plates_gate_mm", c.match_gate_mm, Range::positive());
    c.nominal_length_mm = tracking.read_float("nominal_length_mm", Range::positive());
  }
  {
    YamlMapReader watchdog = root.map("watchdog");
    WatchdogConfig& c = config.watchdog;
    c.cycle_period_s = watchdog.read_float("cycle_period_s", Range::positive());
    // One overrun must be able to fault the line; zero would fault it without any.
    c.overrun_fault_cycles =
        watchdog.read_int<std::int32_t>("overrun_fault_cycles", Range::at_least(1.0));
    // Optional: before this key the stall limit was the runtime's fixed 10 periods. At least
    // 2, since one period without a scan is what the scheduler's wake-up jitter alone gives.
    c.stall_fault_cycles = watchdog.read_int_or<std::int32_t>(
        "stall_fault_cycles", WatchdogConfig{}.stall_fault_cycles, Range::closed(2.0, 1000.0));
  }
}

// ---------------------------------------------------------------- cross-checks

void check_sections(const LineConfig& config, YamlReader& reader) {
  const DriveId* previous = nullptr;
  for (const DriveId& id : kSectionDrives) {
    const BeltSection& belt = config.sections[index(id)];
    const std::string start = section_key(id, "start_mm");
    const std::string end = section_key(id, "end_mm");
    reader.require(belt.end_mm > belt.start_mm, {end, start},
                   named(end, belt.end_mm) + " must be greater than " +
                       named(start, belt.start_mm) + ": a belt has a length");
    const std::string speed = section_key(id, "nominal_speed_mps");
    const std::string max_speed = drive_key(id, "max_speed_mps");
    reader.require(belt.nominal_speed_mps <= config.limits[index(id)].max_speed_mps,
                   {speed, max_speed},
                   named(speed, belt.nominal_speed_mps) + " exceeds the drive's limit " +
                       named(max_speed, config.limits[index(id)].max_speed_mps));
    if (previous != nullptr) {
      const BeltSection& before = config.sections[index(*previous)];
      const std::string before_end = section_key(*previous, "end_mm");
      if (id == DriveId::kReject) {
        // The flip plates sit in the gap between guide and reject belt.
        reader.require(belt.start_mm >= before.end_mm, {start, before_end},
                       named(start, belt.start_mm) + " must not be upstream of " +
                           named(before_end, before.end_mm) +
                           ": sections follow each other in flow order");
      } else {
        // Belts hand over directly: a gap drops fillets, an overlap is two belts at once.
        reader.require(belt.start_mm == before.end_mm, {start, before_end},
                       named(start, belt.start_mm) + " must equal " +
                           named(before_end, before.end_mm) +
                           ": sections follow each other in flow order without gap or overlap");
      }
    }
    previous = &id;
  }
  const std::string takt_end = section_key(DriveId::kTakt, "end_mm");
  reader.require(config.sections[index(DriveId::kTakt)].end_mm == 0.0F, {takt_end},
                 named(takt_end, config.sections[index(DriveId::kTakt)].end_mm) +
                     " must be 0: s = 0 is the takt barrier at the end of the takt belt");
  const std::string outfeed_end = section_key(DriveId::kOutfeed, "end_mm");
  reader.require(config.sections[index(DriveId::kOutfeed)].end_mm == config.placed_at_s_mm,
                 {outfeed_end, "line.placed_at_s_mm"},
                 named(outfeed_end, config.sections[index(DriveId::kOutfeed)].end_mm) +
                     " must equal " + named("line.placed_at_s_mm", config.placed_at_s_mm) +
                     ": fillets are placed where the outfeed ends");
}

// `s_mm` must lie on `belt` (both ends included).
void check_on_belt(const LineConfig& config, YamlReader& reader, std::string_view key, float s_mm,
                   DriveId belt_id, std::string_view what) {
  const BeltSection& belt = config.sections[index(belt_id)];
  const std::string start = section_key(belt_id, "start_mm");
  const std::string end = section_key(belt_id, "end_mm");
  reader.require(s_mm >= belt.start_mm && s_mm <= belt.end_mm, {key, start, end},
                 named(key, s_mm) + " must lie on the " + std::string(to_string(belt_id)) +
                     " belt [" + format_number(belt.start_mm) + ", " + format_number(belt.end_mm) +
                     "] (" + start + ", " + end + "): " + std::string(what));
}

void check_cameras(const LineConfig& config, YamlReader& reader) {
  struct Placement {
    CameraId camera;
    DriveId belt;
  };
  constexpr std::array<Placement, kCameraCount> kPlacements{{
      {CameraId::kOrientation, DriveId::kGuide},
      {CameraId::kPosition, DriveId::kCentring},
      {CameraId::kMultilane1, DriveId::kMultilane1Left},
      {CameraId::kMultilane2, DriveId::kMultilane2Left},
      {CameraId::kFinal, DriveId::kSqueeze},
  }};
  for (const Placement& placement : kPlacements) {
    const CameraMount& mount = config.cameras[index(placement.camera)];
    const BeltSection& belt = config.sections[index(placement.belt)];
    const std::string s = camera_key(placement.camera, "s_mm");
    const std::string fov = camera_key(placement.camera, "field_of_view_mm");
    const std::string start = section_key(placement.belt, "start_mm");
    const std::string end = section_key(placement.belt, "end_mm");
    const float first_mm = mount.s_mm - mount.field_of_view_mm / 2.0F;
    const float last_mm = mount.s_mm + mount.field_of_view_mm / 2.0F;
    // The camera measures fillets on the belt it is meant for, which that belt's drive moves.
    reader.require(first_mm >= belt.start_mm && last_mm <= belt.end_mm, {s, fov, start, end},
                   "field of view [" + format_number(first_mm) + ", " + format_number(last_mm) +
                       "] (" + s + " +- " + fov + " / 2) must lie on the " +
                       std::string(to_string(placement.belt)) + " belt [" +
                       format_number(belt.start_mm) + ", " + format_number(belt.end_mm) + "] (" +
                       start + ", " + end + ")");
    // A staleness limit under one frame period would make every estimate stale between frames.
    const std::string period = camera_key(placement.camera, "period_s");
    const std::string max_age = camera_key(placement.camera, "max_age_s");
    reader.require(mount.max_age_s >= mount.period_s, {max_age, period},
                   named(max_age, mount.max_age_s) + " must be at least " +
                       named(period, mount.period_s) + ": estimates would go stale between frames");
  }

  const CameraMount& position = config.cameras[index(CameraId::kPosition)];
  const std::string position_s = camera_key(CameraId::kPosition, "s_mm");
  const std::string position_fov = camera_key(CameraId::kPosition, "field_of_view_mm");
  reader.require(position.s_mm + position.field_of_view_mm / 2.0F <= config.centring.s_mm,
                 {position_s, position_fov, "centring.s_mm"},
                 "field of view of camera 2 ends at " +
                     format_number(position.s_mm + position.field_of_view_mm / 2.0F) + " (" +
                     position_s + " + " + position_fov + " / 2), after the centring unit at " +
                     named("centring.s_mm", config.centring.s_mm) +
                     ": the lateral position must be measured before the unit acts");

  const CameraMount& final_camera = config.cameras[index(CameraId::kFinal)];
  const std::string final_s = camera_key(CameraId::kFinal, "s_mm");
  const std::string final_fov = camera_key(CameraId::kFinal, "field_of_view_mm");
  reader.require(config.squeeze.roller_s_mm < final_camera.s_mm, {"squeeze.roller_s_mm", final_s},
                 named("squeeze.roller_s_mm", config.squeeze.roller_s_mm) +
                     " must be upstream of " + named(final_s, final_camera.s_mm) +
                     ": the final camera inspects squeezed fillets");
  reader.require(final_camera.s_mm + final_camera.field_of_view_mm / 2.0F <=
                     config.tolerance.final_reject_s_mm,
                 {final_s, final_fov, "tolerance.final_reject_s_mm"},
                 "field of view of the final camera ends at " +
                     format_number(final_camera.s_mm + final_camera.field_of_view_mm / 2.0F) +
                     " (" + final_s + " + " + final_fov + " / 2), after the air knife at " +
                     named("tolerance.final_reject_s_mm", config.tolerance.final_reject_s_mm) +
                     ": a fillet must be inspected before it passes the reject");
}

void check_stations(const LineConfig& config, YamlReader& reader) {
  // Re-arming on travel while the pulled fillet may still break the beam would strike it
  // twice: the travel must cover a whole fillet, which the nominal length stands for.
  reader.require(config.takt.rearm_travel_mm == 0.0F ||
                     config.takt.rearm_travel_mm >= config.tracking.nominal_length_mm,
                 {"takt.rearm_travel_mm", "tracking.nominal_length_mm"},
                 named("takt.rearm_travel_mm", config.takt.rearm_travel_mm) +
                     " must be 0 (off) or at least " +
                     named("tracking.nominal_length_mm", config.tracking.nominal_length_mm) +
                     ": before that the pulled fillet may still break the beam");
  reader.require(config.tracking.plates_gate_mm >= config.tracking.match_gate_mm,
                 {"tracking.plates_gate_mm", "tracking.match_gate_mm"},
                 "the gate after the flip plates must be at least the belts' gate");
  // Flip plates: slides in the gap between guide and reject belt, plate 1 first.
  const std::string guide_end = section_key(DriveId::kGuide, "end_mm");
  const std::string reject_start = section_key(DriveId::kReject, "start_mm");
  reader.require(config.flip.plate1_s_mm < config.flip.plate2_s_mm,
                 {"flip.plate1_s_mm", "flip.plate2_s_mm"},
                 named("flip.plate1_s_mm", config.flip.plate1_s_mm) + " must be upstream of " +
                     named("flip.plate2_s_mm", config.flip.plate2_s_mm));
  reader.require(config.flip.plate1_s_mm >= config.sections[index(DriveId::kGuide)].end_mm,
                 {"flip.plate1_s_mm", guide_end},
                 named("flip.plate1_s_mm", config.flip.plate1_s_mm) + " must not be upstream of " +
                     named(guide_end, config.sections[index(DriveId::kGuide)].end_mm) +
                     ": the plates sit between guide and reject belt");
  reader.require(config.flip.plate2_s_mm <= config.sections[index(DriveId::kReject)].start_mm,
                 {"flip.plate2_s_mm", reject_start},
                 named("flip.plate2_s_mm", config.flip.plate2_s_mm) +
                     " must not be downstream of " +
                     named(reject_start, config.sections[index(DriveId::kReject)].start_mm) +
                     ": the plates sit between guide and reject belt");

  check_on_belt(config, reader, "centring.s_mm", config.centring.s_mm, DriveId::kCentring,
                "the centring unit pushes fillets on the centring belt");
  check_on_belt(config, reader, "squeeze.roller_s_mm", config.squeeze.roller_s_mm,
                DriveId::kSqueeze, "the roller presses fillets on the squeeze belt");
  check_on_belt(config, reader, "tolerance.final_reject_s_mm", config.tolerance.final_reject_s_mm,
                DriveId::kSqueeze, "the air knife acts on the squeeze belt after the final camera");

  // Drive limits bound what the stations may command.
  const DriveId takt = DriveId::kTakt;
  reader.require(
      config.takt.standard_speed_mps <= config.limits[index(takt)].max_speed_mps,
      {"takt.standard_speed_mps", drive_key(takt, "max_speed_mps")},
      named("takt.standard_speed_mps", config.takt.standard_speed_mps) +
          " exceeds the drive's limit " +
          named(drive_key(takt, "max_speed_mps"), config.limits[index(takt)].max_speed_mps));
  reader.require(
      config.takt.takt_speed_mps <= config.limits[index(takt)].max_speed_mps,
      {"takt.takt_speed_mps", drive_key(takt, "max_speed_mps")},
      named("takt.takt_speed_mps", config.takt.takt_speed_mps) + " exceeds the drive's limit " +
          named(drive_key(takt, "max_speed_mps"), config.limits[index(takt)].max_speed_mps));
  reader.require(
      config.takt.takt_accel_mps2 <= config.limits[index(takt)].max_accel_mps2,
      {"takt.takt_accel_mps2", drive_key(takt, "max_accel_mps2")},
      named("takt.takt_accel_mps2", config.takt.takt_accel_mps2) + " exceeds the drive's limit " +
          named(drive_key(takt, "max_accel_mps2"), config.limits[index(takt)].max_accel_mps2));
  // A takt stroke accelerates from standard speed to pull a row out.
  reader.require(config.takt.takt_speed_mps > config.takt.standard_speed_mps,
                 {"takt.takt_speed_mps", "takt.standard_speed_mps"},
                 named("takt.takt_speed_mps", config.takt.takt_speed_mps) +
                     " must be greater than " +
                     named("takt.standard_speed_mps", config.takt.standard_speed_mps) +
                     ": a takt stroke speeds up to pull a row out");

  const DriveId bulk = DriveId::kBulk;
  reader.require(
      config.bulk.max_speed_mps <= config.limits[index(bulk)].max_speed_mps,
      {"bulk.max_speed_mps", drive_key(bulk, "max_speed_mps")},
      named("bulk.max_speed_mps", config.bulk.max_speed_mps) + " exceeds the drive's limit " +
          named(drive_key(bulk, "max_speed_mps"), config.limits[index(bulk)].max_speed_mps));
  reader.require(config.bulk.min_speed_mps <= config.bulk.max_speed_mps,
                 {"bulk.min_speed_mps", "bulk.max_speed_mps"},
                 named("bulk.min_speed_mps", config.bulk.min_speed_mps) + " exceeds " +
                     named("bulk.max_speed_mps", config.bulk.max_speed_mps));
  reader.require(config.bulk.hopper_unblock_opening_mm > config.bulk.hopper_opening_mm,
                 {"bulk.hopper_unblock_opening_mm", "bulk.hopper_opening_mm"},
                 named("bulk.hopper_unblock_opening_mm", config.bulk.hopper_unblock_opening_mm) +
                     " must be greater than " +
                     named("bulk.hopper_opening_mm", config.bulk.hopper_opening_mm) +
                     ": unblocking opens the hopper wider");

  // Otherwise a blade at its commanded speed would read as jammed.
  reader.require(config.leveller.min_running_rpm < config.leveller.speed_rpm,
                 {"leveller.min_running_rpm", "leveller.speed_rpm"},
                 named("leveller.min_running_rpm", config.leveller.min_running_rpm) +
                     " must be below " + named("leveller.speed_rpm", config.leveller.speed_rpm) +
                     ": the blade at its commanded speed would read as jammed");

  const DriveId reject = DriveId::kReject;
  reader.require(
      config.reject.reverse_speed_mps <= config.limits[index(reject)].max_speed_mps,
      {"reject.reverse_speed_mps", drive_key(reject, "max_speed_mps")},
      named("reject.reverse_speed_mps", config.reject.reverse_speed_mps) +
          " exceeds the drive's limit " +
          named(drive_key(reject, "max_speed_mps"), config.limits[index(reject)].max_speed_mps));

  // A deadband as wide as the stroke would never move the pusher.
  reader.require(config.centring.deadband_mm < config.centring.max_shift_mm,
                 {"centring.deadband_mm", "centring.max_shift_mm"},
                 named("centring.deadband_mm", config.centring.deadband_mm) + " must be below " +
                     named("centring.max_shift_mm", config.centring.max_shift_mm) +
                     ": the unit would never shift a fillet");

  for (DriveId id : kMultilaneDrives) {
    const std::string max_speed = drive_key(id, "max_speed_mps");
    reader.require(config.multilane.common_speed_mps <= config.limits[index(id)].max_speed_mps,
                   {"multilane.common_speed_mps", max_speed},
                   named("multilane.common_speed_mps", config.multilane.common_speed_mps) +
                       " exceeds the drive's limit " +
                       named(max_speed, config.limits[index(id)].max_speed_mps));
  }
  // |right - left| is largest with one belt at full speed forward, the other full reverse.
  for (const auto& [left, right] :
       {std::pair{DriveId::kMultilane1Left, DriveId::kMultilane1Right},
        std::pair{DriveId::kMultilane2Left, DriveId::kMultilane2Right}}) {
    const std::string left_max = drive_key(left, "max_speed_mps");
    const std::string right_max = drive_key(right, "max_speed_mps");
    const float reachable_mps =
        config.limits[index(left)].max_speed_mps + config.limits[index(right)].max_speed_mps;
    reader.require(config.multilane.max_differential_mps <= reachable_mps,
                   {"multilane.max_differential_mps", left_max, right_max},
                   named("multilane.max_differential_mps", config.multilane.max_differential_mps) +
                       " exceeds " + format_number(reachable_mps) + " = " + left_max + " + " +
                       right_max + ": the most two belts can differ");
  }
}

LineConfig parse(YamlReader& reader) {
  LineConfig config;  // local: returned only when the whole file is valid
  {
    YamlMapReader root = reader.root();
    {
      YamlMapReader line = root.map("line");
      config.takt_belt_length_mm = line.read_float("takt_belt_length_mm", Range::positive());
      // Downstream of the takt barrier at s = 0.
      config.placed_at_s_mm = line.read_float("placed_at_s_mm", Range::positive());
    }
    {
      YamlMapReader drives = root.map("drives");
      for (std::size_t i = 0; i < kDriveCount; ++i) {
        read_drive(drives, static_cast<DriveId>(i), config);
      }
    }
    {
      YamlMapReader cameras = root.map("cameras");
      for (std::size_t i = 0; i < kCameraCount; ++i) {
        read_camera(cameras, static_cast<CameraId>(i), config);
      }
    }
    read_stations(root, config);
  }  // every mapping finished: unknown keys reported
  check_sections(config, reader);
  check_cameras(config, reader);
  check_stations(config, reader);
  reader.throw_if_problems();
  return config;
}

}  // namespace

LineConfig load_line_config(const std::filesystem::path& file) {
  YamlReader reader = YamlReader::from_file(file);
  LineConfig config = parse(reader);
  spdlog::info("line configuration loaded from {}", file.string());
  return config;
}

LineConfig parse_line_config(std::string_view yaml_text, std::string_view source_name) {
  YamlReader reader = YamlReader::from_text(yaml_text, source_name);
  return parse(reader);
}

}  // namespace fl
