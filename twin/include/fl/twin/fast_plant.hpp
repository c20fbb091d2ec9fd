// The fast plant: a seeded 2D rigid-pose model of the whole line of thesis section 5.3
// (mailbox hopper, bulk belt, leveller, takt conveyor, speed transitions, guide rails, flip
// plates, reject belt, centring, two multilane units, squeeze roller, final air knife) with
// its sensors. It integrates at a fixed internal step (2 ms) and runs a minute of line time in
// a fraction of a second, for closed-loop tests and lock-step runs. The drives and cameras are
// the emulators both plants share (fl/twin/sensors): this plant moves the bodies and hands
// them their ground truth.
//
// Coordinates are the line's (line_config.hpp): s_mm along the product path, 0 at the takt
// barrier; y_mm lateral, positive to the left looking downstream; angle_rad the direction from
// the thick end to the tip, counter-clockwise from the travel direction seen from above, in
// (-pi, pi] (the convention of FilletEstimate).
//
// Determinism: one seed gives a bit-identical sequence of input images. All randomness comes
// from TwinRng (xoshiro256**, portable uniform and polar-method normal draws), in separate
// streams per subsystem so that e.g. a camera fault does not change the fillets fed. step()
// does not allocate: bodies and exits live in pools sized at construction.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <optional>
#include <span>
#include <vector>

#include "fl/controller/line_config.hpp"
#include "fl/controller/plant.hpp"
#include "fl/controller/process_image.hpp"
#include "fl/twin/fast_plant_config.hpp"
#include "fl/twin/sensors/camera_emulator.hpp"
#include "fl/twin/sensors/drive_emulator.hpp"
#include "fl/twin/sensors/twin_rng.hpp"

namespace fl {

// The plants' generator; the name stays for the fast plant's tests and tools.
using FastRng = TwinRng;

// ---------------------------------------------------------------- bodies

// One fillet of a body.
struct FilletMember {
  std::uint32_t plant_id = 0;
  Hand hand = Hand::kUnknown;
  SideUp side = SideUp::kUnknown;  // true side up now
  std::uint8_t variant = 0;        // index into FastFilletConfig::variants (table 3.1)
  float length_mm = 0.0F;
  float width_mm = 0.0F;
  float thickness_mm = 0.0F;  // thickest section
};

// Where a body's centre is, for its belt and its stations.
enum class BodyZone : std::uint8_t {
  kNone,        // no belt under the centre (keeps its velocity)
  kBelt,        // a plain belt section
  kGuide,       // guide belt with rails
  kPlates,      // the flip plates between guide and reject belt (guide speed)
  kMultilane1,  // orienting unit 1
  kMultilane2,
};

// One rigid body on the line: a single fillet or two touching fillets moving as one.
struct FilletBody {
  std::uint32_t group_id = 0;
  std::uint8_t member_count = 1;
  std::array<FilletMember, 2> members{};

  // Rigid-body geometry; a touching pair lies side by side (widths add).
  float length_mm = 0.0F;
  float width_mm = 0.0F;
  float thickness_mm = 0.0F;
  float thickest_from_thick_end = 0.3F;  // share of the length
  float thick_end_ratio = 0.75F;         // thickness profile, see fillet_thickness_mm()
  float tip_ratio = 0.15F;

  // Pose and motion.
  double s_mm = 0.0;
  double y_mm = 0.0;
  double angle_rad = 0.0;
  double v_mps = 0.0;        // along the line
  double omega_radps = 0.0;  // counter-clockwise
  // Cached from angle_rad: half extents of the rotated body along and across the line.
  double cos_angle = 1.0;
  double sin_angle = 0.0;
  double half_extent_s_mm = 0.0;
  double half_extent_y_mm = 0.0;

  BodyZone zone = BodyZone::kNone;
  DriveId drive = DriveId::kTakt;  // belt under the centre (left drive on a multilane unit)
  float rail_residual_rad = 0.0F;  // heading the guide rails leave

  bool fed = false;  // centre crossed s = 0
  // Station history (also for tests and the HMI).
  bool plate1_flipped = false;
  bool plate2_flipped = false;
  bool misflipped = false;
  std::uint8_t centring_phase = 0;  // 0 before, 1 in the window, 2 past
  double centring_entry_y_mm = 0.0;
  double centring_applied_mm = 0.0;
  bool thick_passed_roller = false;
  bool stuck_at_roller = false;
  bool was_stuck = false;
  bool squeezed_ok = false;
};

// Sets a body's heading (wrapped) and its cached trigonometry and extents.
inline void set_body_angle(FilletBody& body, double angle_rad) {
  body.angle_rad = wrap_angle_rad(angle_rad);
  body.cos_angle = std::cos(body.angle_rad);
  body.sin_angle = std::sin(body.angle_rad);
  const double c = std::abs(body.cos_angle);
  const double s = std::abs(body.sin_angle);
  body.half_extent_s_mm = 0.5 * (body.length_mm * c + body.width_mm * s);
  body.half_extent_y_mm = 0.5 * (body.length_mm * s + body.width_mm * c);
}

// Thickness of a body at u in [0, 1] along its length from the thick end: piecewise linear
// from thick_end_ratio x T at u = 0 to T at the thickest section, down to tip_ratio x T at 1.
float fillet_thickness_mm(const FilletBody& body, float u_from_thick_end);
// Line position of the thickest section.
inline double thickest_section_s_mm(const FilletBody& body) {
  return body.s_mm - (0.5 - static_cast<double>(body.thickest_from_thick_end)) *
                         static_cast<double>(body.length_mm) * body.cos_angle;
}

// Places a body directly on the line (tests, scenario setup). s >= 0 counts as fed.
struct BodySpawn {
  double s_mm = 0.0;
  double y_mm = 0.0;
  double angle_rad = 0.0;
  double v_mps = 0.0;
  Hand hand = Hand::kRight;
  SideUp side = SideUp::kSkin;
  std::uint8_t variant = 1;  // table 3.1 row (0..2)
  float scale = 1.0F;
  bool touching_pair = false;  // two fillets stuck together, side by side
};

// ---------------------------------------------------------------- faults

// The camera faults are the shared emulator's; the name stays for the closed-loop scenarios.
using FastCameraFaults = CameraFaults;

// Settable at run time through FastPlant::faults(); reset() clears it.
struct FastPlantFaults {
  std::array<bool, kDriveCount> drive_fault{};  // drive trips: not ready, fault, stops
  CameraFaultSet cameras{};
  bool estop_open = false;         // safety chain open: drives and leveller stop
  bool leveller_overload = false;  // overload switch forced on (the rotor stops)
  bool hopper_blocked = false;     // mailbox outflow stuck regardless of the opening
};

// ---------------------------------------------------------------- state

struct FastInfeedState {
  std::uint32_t hopper_fillets = 0;  // left in the mailbox hopper
  double hopper_opening_mm = 0.0;
  bool hopper_blocked = false;
  double blocked_at_opening_mm = 0.0;
  double outflow_fillets = 0.0;  // fractional outflow not yet whole fillets
  double layer_fillets = 0.0;    // waiting in front of the leveller
  double layer_mm = 0.0;         // true heap height
  double level_reading_mm = 0.0;
  double leveller_rpm = 0.0;
  bool leveller_overload = false;
};

struct FastStationState {
  double plate1_travel = 0.0;  // 0 extended (no flip) .. 1 retracted (flip)
  double plate2_travel = 0.0;
  double pusher_mm = 0.0;      // centring pusher position
  double roller_travel = 0.0;  // 0 up .. 1 down
  bool roller_pressing = false;
  bool final_reject_blowing = false;
};

struct FastPlantCounters {
  std::uint64_t fillets_spawned = 0;  // put on the takt conveyor by the leveller (or spawn_body)
  std::uint64_t groups_spawned = 0;   // touching pairs among them
  std::uint64_t fillets_fed = 0;
  std::array<std::uint64_t, 4> exits{};  // by TrueExit
  std::uint64_t exits_not_recorded = 0;  // exit buffer full (never drained)
  std::uint64_t unfed_losses = 0;        // left before crossing the barrier (not in the balance)
  std::uint64_t pool_full_refusals = 0;  // leveller wanted to feed but the pool was full
  std::uint64_t hopper_blockages = 0;
  std::uint64_t misflips = 0;
  std::uint64_t roller_stuck = 0;  // frame counters: cameras().counters()
};

struct FastPlantState {
  std::int64_t time_ns = 0;  // belt drives: FastPlant::drives()
  FastInfeedState infeed;
  FastStationState stations;
};

// ---------------------------------------------------------------- plant

class FastPlant final : public Plant {
 public:
  FastPlant(const LineConfig& line, const FastPlantConfig& plant);
  ~FastPlant() override;

  [[nodiscard]] const char* name() const override { return "fast"; }
  void reset(std::uint64_t seed, InputImage& in) override;
  void step(const OutputImage& out, std::int64_t dt_ns, InputImage& in) override;
  [[nodiscard]] std::span<const TrueFilletExit> drain_exits() override;
  [[nodiscard]] std::uint64_t fillets_fed() const override { return counters_.fillets_fed; }
  [[nodiscard]] std::uint64_t fillets_on_line() const override;

  // Fault injection, read and changed between steps.
  [[nodiscard]] FastPlantFaults& faults() { return faults_; }
  [[nodiscard]] const FastPlantFaults& faults() const { return faults_; }

  // Read-only views for tests and the HMI. bodies() lists the bodies on the line, downstream
  // first; the span is valid until the next step(), reset() or spawn_body().
  [[nodiscard]] std::span<const FilletBody> bodies() const;
  [[nodiscard]] const FastPlantState& state() const { return state_; }
  [[nodiscard]] const DriveEmulator& drives() const { return drives_; }
  [[nodiscard]] const CameraEmulator& cameras() const { return cameras_; }
  [[nodiscard]] const FastPlantCounters& counters() const { return counters_; }
  [[nodiscard]] const LineConfig& line_config() const { return line_; }
  [[nodiscard]] const FastPlantConfig& plant_config() const { return config_; }

  // Places a body (tests, scenarios); returns its group id, or nothing when the pool is
  // full. Ids continue the plant's own numbering.
  std::optional<std::uint32_t> spawn_body(const BodySpawn& spawn);

 private:
  // A product-path segment: a belt section (or the flip plates) with what acts there.
  struct Segment {
    double start_mm = 0.0;
    double end_mm = 0.0;
    BodyZone zone = BodyZone::kNone;
    DriveId drive = DriveId::kTakt;        // the belt (left belt on a multilane unit)
    DriveId right_drive = DriveId::kTakt;  // multilane units only
  };

  // The next fillet (or pair) the leveller will release, drawn ahead so its length is known
  // when checking for space on the takt conveyor.
  struct NextFeed {
    FilletBody body;
    double gap_mm = 0.0;
  };

  // fast_plant.cpp
  void substep(std::int64_t h_ns, const OutputImage& out);
  void write_image(InputImage& in);
  void record_exit(const FilletBody& body, TrueExit exit);
  void insert_body(const FilletBody& body);
  void remove_body(std::size_t index);
  std::uint32_t next_plant_id() { return ++last_plant_id_; }
  std::uint32_t next_group_id() { return ++last_group_id_; }

  // fast_actuators.cpp
  void step_stations(double h_s, const OutputImage& out);

  // fast_infeed.cpp
  void step_infeed(double h_s, const OutputImage& out);
  void draw_next_feed();
  FilletBody make_body(std::uint8_t members, FastRng& rng);

  // fast_bodies.cpp
  void build_segments();
  void locate(FilletBody& body) const;
  void step_bodies(double h_s, const OutputImage& out);
  void resolve_contacts();
  void sort_bodies();
  [[nodiscard]] bool beam_broken() const;

  LineConfig line_;
  FastPlantConfig config_;
  FastPlantFaults faults_{};
  FastPlantState state_{};
  FastPlantCounters counters_{};

  std::int64_t step_ns_ = 2000000;
  DriveEmulator drives_;
  CameraEmulator cameras_;
  bool roller_went_down_ = false;   // the roller reached the fillets in this sub-step
  std::vector<FilletBody> bodies_;  // capacity max_bodies, downstream first
  std::vector<TrueFilletExit> exits_;
  std::size_t exit_count_ = 0;
  std::size_t exits_drained_ = 0;  // handed out by drain_exits(), dropped at the next step()

  std::array<Segment, kDriveCount + 1> segments_{};
  std::size_t segment_count_ = 0;

  NextFeed next_feed_{};
  bool pool_was_full_ = false;

  FastRng feed_rng_;
  FastRng body_rng_;
  FastRng sensor_rng_;  // level sensor

  std::uint32_t last_plant_id_ = 0;
  std::uint32_t last_group_id_ = 0;

  InputImage image_{};  // zeroed including padding: images are compared byte for byte
};

}  // namespace fl
