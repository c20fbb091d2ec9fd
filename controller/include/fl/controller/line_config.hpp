// Line configuration: geometry, speeds, station parameters, drive limits and tolerances.
// Plain data, filled by the config loader (config_loader.hpp) from config/line.yaml and
// validated there; the logic takes it as const and never changes it while running.
//
// Line coordinate s_mm: distance along the product path, 0 at the takt laser barrier,
// increasing downstream. Lateral coordinate y_mm: 0 on the belt centre line, positive to the
// left looking downstream.
#pragma once

#include <array>
#include <cstdint>

#include "fl/controller/process_image.hpp"

namespace fl {

struct DriveLimits {
  float max_speed_mps = 1.0F;
  float max_accel_mps2 = 5.0F;
  float counts_per_mm = 10.0F;  // encoder resolution at the belt surface
};

// One belt of the product path between takt barrier and outfeed.
struct BeltSection {
  float start_mm = 0.0F;
  float end_mm = 0.0F;
  float nominal_speed_mps = 0.0F;
};

// Whether a drive moves a section of the product path: the bulk belt is upstream of s = 0,
// and a multilane unit's section belongs to its left drive, so these three have none.
constexpr bool has_section(DriveId id) {
  return id != DriveId::kBulk && id != DriveId::kMultilane1Right && id != DriveId::kMultilane2Right;
}

struct CameraMount {
  float s_mm = 0.0F;              // line position of the optical axis
  float field_of_view_mm = 0.0F;  // length of belt seen along travel
  float period_s = 0.04F;         // nominal frame period, for staleness checks
  float max_age_s = 0.1F;         // an estimate older than this is stale
};

struct BulkConfig {
  float level_setpoint_mm = 60.0F;  // layer height wanted in front of the leveller
  float level_kp_mps_per_mm = 0.004F;
  float level_ki_mps_per_mm_s = 0.002F;
  float min_speed_mps = 0.0F;
  float max_speed_mps = 0.15F;
  float hopper_opening_mm = 60.0F;          // thesis 6.1: about two fillets high flows stably
  float hopper_unblock_opening_mm = 90.0F;  // opened to this when starved
  float starved_after_s = 6.0F;  // level under half setpoint at full bulk speed this long
  float unblock_duration_s = 2.0F;
};

struct LevellerConfig {
  float speed_rpm = 120.0F;
  float min_running_rpm = 60.0F;  // below this while commanded: blade jam
  float spin_up_s = 2.0F;         // grace after start before the speed check applies
};

struct TaktConfig {
  float standard_speed_mps = 0.12F;
  float takt_speed_mps = 0.6F;
  float takt_accel_mps2 = 6.0F;
  float pull_distance_mm = 110.0F;  // belt travel of one stroke: the front row's centre across
  float min_period_s = 0.9F;        // caps the rate: 60 / 0.9 = about 67 per minute
  float min_gap_mm = 200.0F;        // previous item must be this far past the barrier first
  float beam_debounce_s = 0.02F;
  // Takt belt travel since a stroke began after which the pulled fillet has left the beam
  // whatever its length (the longest, 176 mm, plus slip): a beam still broken then is the
  // next row, touching the pulled fillet or behind a gap shorter than the debounce.
  // 0 switches it off (only a clear beam re-arms).
  float rearm_travel_mm = 190.0F;
};

struct FlipConfig {
  float plate1_s_mm = 0.0F;     // end-over-end plate
  float plate2_s_mm = 0.0F;     // sideways plate
  float actuation_s = 0.15F;    // plate travel time
  float clearance_mm = 100.0F;  // the plate is committed while an item is this close
  SideUp target_side = SideUp::kBone;
};

struct RejectConfig {
  float reverse_speed_mps = 0.5F;
  float drop_margin_mm = 60.0F;  // travel beyond the belt's upstream edge to fall in the crate
  float min_confidence = 0.6F;   // camera 1 classification below this is rejected
};

struct CentringConfig {
  float s_mm = 0.0F;
  float max_shift_mm = 60.0F;
  float deadband_mm = 5.0F;
  float stroke_time_s = 0.12F;
};

struct MultilaneConfig {
  float common_speed_mps = 0.6F;      // faster than the centring belt: stretches the spacing
  float max_differential_mps = 0.5F;  // |right - left|, within both drives' limits
  float belt_track_mm = 80.0F;        // effective lateral lever between the two belts
  float angle_gain_per_s = 12.0F;     // proportional gain of the angle loop
  float angle_done_rad = 0.02F;       // settled when within this
};

struct SqueezeConfig {
  float roller_s_mm = 0.0F;
  float thickest_from_rear = 0.3F;  // thickest section, share of length from the thick end
  float actuation_s = 0.08F;
};

struct ToleranceConfig {
  float target_angle_rad = 0.6108652F;  // 35 degrees, the placement of thesis figure 1.3a
  bool mirror_for_left = true;          // left fillets placed at -target
  float angle_tol_rad = 0.0872665F;     // 5 degrees
  float lateral_tol_mm = 20.0F;
  float final_reject_s_mm = 0.0F;  // air knife position
  float final_reject_pulse_s = 0.1F;
};

struct TrackingConfig {
  float match_gate_mm = 80.0F;  // a detection matches a fillet predicted within this
  // The same for camera 2, the first after the flip plates: an item's time over the plates
  // is not the guide belt's (a slide gains on it, a fall loses), so its gate is wider.
  float plates_gate_mm = 170.0F;
  float nominal_length_mm = 170.0F;  // used before camera 1 measures an item
};

struct WatchdogConfig {
  float cycle_period_s = 0.01F;
  std::int32_t overrun_fault_cycles = 3;  // consecutive overruns that fault the line
  // Periods without a scan starting before the watchdog faults the line (scan stalled).
  std::int32_t stall_fault_cycles = 10;
};

struct LineConfig {
  // Product path: the belts from takt barrier to outfeed, indexed by DriveId. Bulk and
  // multilane right belts have no section of their own (bulk is upstream of s = 0; a
  // multilane unit's section is registered on its left drive).
  std::array<BeltSection, kDriveCount> sections{};
  std::array<DriveLimits, kDriveCount> limits{};
  std::array<CameraMount, kCameraCount> cameras{};
  float takt_belt_length_mm = 600.0F;
  float placed_at_s_mm = 0.0F;  // end of the outfeed: hand-off to the portion cutter

  BulkConfig bulk;
  LevellerConfig leveller;
  TaktConfig takt;
  FlipConfig flip;
  RejectConfig reject;
  CentringConfig centring;
  MultilaneConfig multilane;
  SqueezeConfig squeeze;
  ToleranceConfig tolerance;
  TrackingConfig tracking;
  WatchdogConfig watchdog;
};

// The drive whose belt carries a point of the product path: the section holding s_mm; in the
// gap of the flip plates, the guide belt that feeds them (the section before a gap); upstream of
// the first section the takt belt, downstream of the last the outfeed (the sections follow each
// other in flow order, as the loader checks). A multilane unit answers its left drive.
[[nodiscard]] DriveId drive_under(const LineConfig& line, double s_mm);

// The belt that carries a fillet together with `drive`: a multilane unit's right belt beside
// its left one; any other belt carries it alone (itself).
constexpr DriveId carrying_partner(DriveId drive) {
  if (drive == DriveId::kMultilane1Left) return DriveId::kMultilane1Right;
  if (drive == DriveId::kMultilane2Left) return DriveId::kMultilane2Right;
  return drive;
}

// The speed that carries a fillet forward at s_mm, from each drive's speed (`speed_of(DriveId)`:
// commanded, measured, or an encoder's travel): a multilane unit's mean of its two belts, any
// other belt's own (the mean of it with itself, exactly).
template <typename SpeedOf>
auto carrying_speed(const LineConfig& line, double s_mm, const SpeedOf& speed_of) {
  const DriveId drive = drive_under(line, s_mm);
  return (speed_of(drive) + speed_of(carrying_partner(drive))) / 2;
}

// The reference line of thesis section 5.3 with the project's chosen numbers (the figure
// with the thesis' belt speeds is not legible in the text, docs/line.md gives the reasons).
// config/line.yaml holds the same values; a test keeps the two equal.
LineConfig default_line_config();

}  // namespace fl
