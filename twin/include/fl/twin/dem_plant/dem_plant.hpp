// The DEM plant: the line of thesis section 5.3 as a DEM digital twin behind the controller's
// plant interface, so that `linectl run --plant dem` runs the controller unchanged.
//
// Fillets are bonded sphere meta-particles (fl/twin/dem/fillet_generator.hpp, six thesis
// variants); the machinery is walls of the DEM engine, built from LineConfig. Engine frame
// (metres): x = the line's s, y lateral (left > 0), z up. The reject belt and everything
// downstream lie at z = 0; the guide belt rises to its end (thesis 5.3: "this segment also
// exhibits an upward motion"), 150 mm over the reject belt, and the belts upstream of it lie
// at its start's level (DemMachineryConfig: guide_rise_mm, plate1_drop_mm).
//
// - Belts: one rectangle (two triangles) per product-path belt with the drive's actual speed
//   as surface velocity; multilane units two side-by-side belts (left y > 0, right y < 0);
//   small gaps between belts (see DemMachineryConfig). The drives are the shared
//   DriveEmulator (fl/twin/sensors): 5 ms command delay, ramps, encoders, as the fast plant.
// - Side walls along the whole line, guide rails funnelling over the guide belt.
// - Flip plate 1 (thesis 5.2, figure 5.13: a slide, or out of the way to leave a drop): a
//   plate from the guide's raised end down over the plates section to 50 mm above the reject
//   belt, conveying at the guide's speed, hinged along the belt's right edge. The command
//   swings it up by 90 degrees in the actuation time; the fillet then falls over the guide's
//   end onto the landing under it (at the reject belt's level) and turns over end over end by
//   contact and gravity alone. A plate caught mid-swing does whatever its pose does to the
//   fillet (counted as a misflip). Its lower edge stands over the thickest fillet so that the
//   reject reversal carries a fillet back under it into the crate.
// - Flip plate 2 (simplification): a fillet whose centroid crosses plate 2's position while
//   the plate is retracted turns sideways in one go, a rigid rotation of its spheres by 180
//   degrees about the travel direction through its centroid; a plate in mid-travel flips by
//   chance and throws the heading, as in the fast plant. A physical sideways flip needs a
//   lateral drop, which the 200 mm plates section has no room for beside plate 1.
// - Reject belt: reverses on command; the crate is a removal zone under its upstream edge.
// - Centring pusher: a vertical plate; a stroke starts at the edge of the fillet at the unit
//   (the real unit's light grid) and travels the commanded shift, pushing by contact, on a
//   trapezoidal profile whose braking stays under the friction that stops the fillet on the
//   belt (else the plate stops and the fillet slides on). Its face runs with the centring
//   belt (a belt-faced pusher), so it shifts without braking one side and turning the fillet.
//   Or, with machinery.centring_unit: jaws, two such plates closing on the centre line from
//   the fillet's outer side until both press it with the grip force; the unit then reports
//   the commanded shift as done.
// - Squeeze roller: a cylinder mesh lowered onto the squeeze belt, rolling with it.
// - Air knife: a removal zone around its position while it blows.
// - Feeder, one of two (DemFeederConfig::source):
//   - levelled_layer (simplification of hopper, bulk belt and leveller): the hopper outflow
//     fills a backlog counted in fillets (the level sensor reads it as heap height), and the
//     running leveller places the next fillet (or touching pair) on the takt belt's upstream
//     end when there is room, as the fast plant's levelled layer.
//   - dem_bulk_end: the mailbox hopper, bulk belt and leveller as a DEM scene of their own
//     (BulkScene, config/bulk_line.yaml), stepped with the line. The controller's commands
//     drive it: the bulk drive's actual speed moves its belt, the hopper opening its gate
//     cylinder, the leveller command its rotor (through the same motor lag). The level sensor
//     reads the highest fillet sphere in a window in front of the leveller. At the scene's
//     discharge edge the leveller's belt stops while a fillet waits there (the transfer's
//     photo-eye); that fillet moves onto the takt belt's upstream end, with its variant, side
//     up, heading and place across, once there is room for it (beside fillets clear of it
//     across, as a levelled layer lies). Simplification: it arrives as its template, rigid and
//     at the takt belt's speed, not with the bend it had (two engines, joined at the transfer).
// - Cameras: the shared CameraEmulator (fl/twin/sensors: period, jitter, latency, noise,
//   misses, misclassification, faults), the same as the fast plant's, on each fillet's
//   ground-truth rigid pose (a least-squares fit of its spheres to its template); a fillet
//   whose spheres touch another fillet's is one blob (not singulated).
//
// Determinism: one seed and one thread count give bit-identical input images.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "fl/controller/line_config.hpp"
#include "fl/controller/plant.hpp"
#include "fl/twin/dem/fillet_template.hpp"
#include "fl/twin/dem/simulation.hpp"
#include "fl/twin/dem/sphere_group.hpp"
#include "fl/twin/dem_plant/dem_plant_config.hpp"
#include "fl/twin/fast_plant_config.hpp"
#include "fl/twin/sensors/camera_emulator.hpp"
#include "fl/twin/sensors/drive_emulator.hpp"
#include "fl/twin/sensors/twin_rng.hpp"

namespace fl {

// Places a fillet directly on the line (tests, scenarios). s >= 0 counts as fed.
struct DemFilletSpawn {
  double s_mm = 0.0;
  double y_mm = 0.0;
  double angle_rad = 0.0;    // thick end to tip, CCW from travel
  double v_mps = 0.0;        // along the line
  std::uint8_t variant = 2;  // thesis_fillet_variants() index 0..5 (even: left, odd: right)
  SideUp side = SideUp::kSkin;
  bool touching_pair = false;  // a second fillet side by side (to the left), in contact
};

// Ground-truth pose of one fillet now (line coordinates).
struct DemFilletView {
  std::uint32_t plant_id = 0;
  std::uint32_t group_id = 0;
  Hand hand = Hand::kUnknown;
  SideUp side = SideUp::kUnknown;
  // Table 3.1 row of its template, counted as the renderer's size_variant: 0 = 144x72x40,
  // 1 = 172x72x32, 2 = 176x72x40 mm.
  std::uint8_t size_variant = 1;
  double s_mm = 0.0;
  double y_mm = 0.0;
  double z_mm = 0.0;  // centroid height over the reject belt's plane (engine z)
  double angle_rad = 0.0;
  // Curvature of the long axis in the belt plane (dem::InPlaneBendFit): positive turns it
  // anticlockwise seen from above, thick end to tip. 0 for a fillet standing on end.
  double bend_per_mm = 0.0;
  double v_mps = 0.0;  // centroid speed along the line
  double min_s_mm = 0.0;
  double max_s_mm = 0.0;
  bool fed = false;
  bool touching = false;  // a sphere of it touches a sphere of another fillet
  std::size_t spheres = 0;
};

struct DemPlantFaults {
  std::array<bool, kDriveCount> drive_fault{};
  CameraFaultSet cameras{};
  bool estop_open = false;
};

struct DemPlantCounters {
  std::uint64_t fillets_spawned = 0;
  std::uint64_t fillets_fed = 0;
  std::array<std::uint64_t, 4> exits{};  // by TrueExit
  std::uint64_t exits_not_recorded = 0;
  std::uint64_t unfed_losses = 0;
  std::uint64_t flips = 0;
  std::uint64_t misflips = 0;
  std::uint64_t rebuilds = 0;      // engine rebuilt to take fillets out
  std::uint64_t engine_steps = 0;  // frame counters: cameras().counters()
  std::uint64_t handed_over = 0;   // dem_bulk_end: fillets moved from the bulk end to the takt
};

class DemPlant final : public Plant {
 public:
  DemPlant(const LineConfig& line, const DemPlantConfig& config);
  ~DemPlant() override;

  [[nodiscard]] const char* name() const override { return "dem"; }
  void reset(std::uint64_t seed, InputImage& in) override;
  void step(const OutputImage& out, std::int64_t dt_ns, InputImage& in) override;
  [[nodiscard]] std::span<const TrueFilletExit> drain_exits() override;
  [[nodiscard]] std::uint64_t fillets_fed() const override { return counters_.fillets_fed; }
  [[nodiscard]] std::uint64_t fillets_on_line() const override;

  [[nodiscard]] DemPlantFaults& faults() { return faults_; }
  std::optional<std::uint32_t> spawn_fillet(const DemFilletSpawn& spawn);

  // Views for tests and tools (allocate).
  [[nodiscard]] std::vector<DemFilletView> fillets() const;
  [[nodiscard]] const dem::Simulation& simulation() const { return *sim_; }
  [[nodiscard]] const DemPlantCounters& counters() const { return counters_; }
  [[nodiscard]] const DriveEmulator& drives() const { return drives_; }
  [[nodiscard]] const CameraEmulator& cameras() const { return cameras_; }
  [[nodiscard]] std::int64_t time_ns() const { return time_ns_; }
  [[nodiscard]] const std::vector<dem::FilletTemplate>& templates() const { return templates_; }
  [[nodiscard]] double engine_timestep_s() const;
  // The bulk end's DEM scene (DemInfeedSource::kDemBulkEnd), null with the levelled layer.
  [[nodiscard]] const BulkScene* bulk_end() const { return bulk_.get(); }
  // The last fillet moved from the bulk end onto the takt belt, as the scene gave it, and the
  // plant id it got there.
  struct Handover {
    BulkHandover from_bulk;
    std::uint32_t plant_id = 0;
  };
  [[nodiscard]] const std::optional<Handover>& last_handover() const { return last_handover_; }
  // Where the bulk end's frame lies in the line's (engine metres): its discharge edge at the
  // takt belt's upstream end, its belt surface at the takt belt's. For pictures of both.
  [[nodiscard]] dem::Vec3 bulk_end_offset_m() const;

 private:
  // The sphere group's fields are from the last particle pass.
  struct Fillet : dem::SphereGroup {
    std::uint32_t plant_id = 0;
    std::uint32_t group_id = 0;
    std::uint8_t variant = 0;
    std::uint32_t body = 0;      // engine body number
    std::uint32_t first_id = 0;  // engine id of template sphere 0
    bool fed = false;
    bool squeezed_ok = false;
    bool thick_passed_roller = false;
    bool remove = false;
    SideUp side_before_plates = SideUp::kUnknown;  // fitted as it left the guide
    double previous_s_m = 0.0;
    double progress_s_m = 0.0;
    std::int64_t progress_ns = 0;
  };
  struct Pose {
    double angle_rad = 0.0;
    SideUp side = SideUp::kUnknown;
    Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  };
  struct Stations {
    double plate1_travel = 0.0;
    double plate2_travel = 0.0;
    double plate1_angle_rad = 0.0;  // plate 1's swing about its hinge (0: slide pose)
    double pusher_mm = 0.0;
    double pusher_speed_mmps = 0.0;
    int pusher_side = 0;  // +1 pushes from the left (towards -y), -1 from the right, 0 parked
    double pusher_edge_m = 0.0;  // fillet edge where the stroke began
    // Jaws (DemCentringUnit::kJaws): each plate this far from the centre line while closed on
    // a fillet; parked outside the side walls otherwise.
    enum class Jaws : std::uint8_t { kParked, kClosing, kGripping };
    Jaws jaws = Jaws::kParked;
    double jaw_half_gap_m = 0.0;
    double jaw_speed_mps = 0.0;
    double roller_travel = 0.0;
    bool roller_pressing = false;
    bool roller_went_down = false;
    bool knife_blowing = false;
  };
  struct Infeed {
    double hopper_opening_mm = 0.0;
    double backlog_fillets = 0.0;
    double leveller_rpm = 0.0;
    double level_reading_mm = 0.0;
    bool leveller_overload = false;  // dem_bulk_end: the motor's trip (load torque)
  };
  struct NextFeed {
    std::uint8_t variant = 0;
    bool pair = false;
    SideUp side = SideUp::kSkin;
    double y_mm = 0.0;
    double angle_rad = 0.0;
    double gap_mm = 0.0;
  };
  // dem_plant.cpp
  void control_step(std::int64_t h_ns, const OutputImage& out);
  void write_image(InputImage& in);
  void record_exit(const Fillet& fillet, TrueExit exit);
  void take_out_removed();
  void scan_particles();
  [[nodiscard]] Pose fit_pose(const Fillet& fillet) const;
  [[nodiscard]] double in_plane_bend_per_mm(const Fillet& fillet, const Pose& pose) const;
  [[nodiscard]] bool touching(std::size_t f) const;
  [[nodiscard]] Hand hand_of(const Fillet& fillet) const;
  class FilletScene;  // the fillets as the camera emulator sees them
  [[nodiscard]] bool beam_broken() const;
  std::uint32_t add_fillet(std::uint8_t variant, SideUp side, const Eigen::Vector3d& centroid_m,
                           double angle_rad, double v_mps, std::uint32_t group_id);
  std::shared_ptr<const dem::Model> build_model() const;
  // Throws std::invalid_argument when the timestep is too large for the model's stiffnesses.
  void check_timestep() const;
  // The flip plates' section and the levels of the product path (engine metres).
  struct PlateLayout {
    double start_m = 0.0;       // the guide's raised end, top_z_m high: plate 1's top edge
    double end_m = 0.0;         // the reject belt's start, at z = 0
    double top_z_m = 0.0;       // plate 1's drop
    double end_z_m = 0.0;       // plate 1's lower edge, over the reject belt
    double upstream_z_m = 0.0;  // takt and transition belts, the guide's start
    // Plate 1's mesh runs from its top edge (the hinge's end at the belt's right edge) down
    // along slide_direction; it swings about that direction through the hinge point.
    Eigen::Vector3d hinge_m = Eigen::Vector3d::Zero();
    Eigen::Vector3d plate_end_m = Eigen::Vector3d::Zero();  // lower edge, the same side
    Eigen::Vector3d slide_direction = Eigen::Vector3d::UnitX();
  };
  [[nodiscard]] PlateLayout plate_layout() const;
  // Height of the product path's surface at s (plates in their slide pose).
  [[nodiscard]] double deck_z_m(double s_m) const;
  [[nodiscard]] double deck_slope(double s_m) const;  // dz/ds there

  // dem_machinery.cpp
  void step_stations(double h_s, const OutputImage& out);
  void step_pusher(double h_s, const OutputImage& out);
  void step_jaws(double h_s, const OutputImage& out);
  // The fillet a centring stroke acts on: the nearest within the window around the unit.
  [[nodiscard]] const Fillet* fillet_at_centring() const;
  void command_walls(double h_s);
  void apply_events(const OutputImage& out);
  void flip_sideways(Fillet& fillet);

  // dem_feeder.cpp
  void step_infeed(double h_s, const OutputImage& out);
  void step_layer_infeed(double h_s, const OutputImage& out);
  void step_bulk_end(const OutputImage& out);
  void start_bulk_end(std::uint64_t seed);
  [[nodiscard]] double level_mm();
  void draw_next_feed();
  static double pair_partner_offset_m(const dem::FilletTemplate& t, SideUp side);
  [[nodiscard]] double pair_offset_m(std::uint8_t variant, SideUp side) const;
  // The takt belt's upstream end has room for a fillet of this template and heading, with
  // `gap_m` behind the last one (or, with its place across `y_mm` given, beside those clear
  // of it across by `gap_m`): where its centroid goes along the line, else none.
  [[nodiscard]] std::optional<double> entry_room_m(const dem::FilletTemplate& t, double angle_rad,
                                                   double gap_m,
                                                   std::optional<double> y_mm = {}) const;
  // A fillet's lateral place on the takt belt at its heading: y clear of the side walls, and so
  // is a pair's partner, which lies partner_dy_mm across from it (0: no partner).
  [[nodiscard]] double entry_y_mm(const dem::FilletTemplate& t, double angle_rad, double y_mm,
                                  double partner_dy_mm) const;

  LineConfig line_;
  DemPlantConfig config_;
  std::vector<dem::FilletTemplate> templates_;
  // A touching pair's partner lies this far to the first fillet's left (per variant; skin up,
  // bone up): computed once, as the feeder asks for it at every step while it waits for room.
  std::vector<std::array<double, 2>> pair_offset_m_;
  std::vector<std::vector<dem::BodyBond>> template_bonds_;
  std::shared_ptr<const dem::Model> model_;
  std::unique_ptr<dem::Simulation> sim_;
  std::vector<std::size_t> wall_belt_;  // per drive: engine wall index of its belt, or npos
  std::size_t wall_plate1_ = 0, wall_landing_ = 0, wall_pusher_ = 0, wall_jaw_ = 0,
              wall_roller_ = 0, wall_right_ml1_ = 0, wall_right_ml2_ = 0;

  DemPlantFaults faults_{};
  DemPlantCounters counters_{};
  std::int64_t time_ns_ = 0;
  std::int64_t step_ns_ = 1000000;
  DriveEmulator drives_;
  CameraEmulator cameras_;
  Stations stations_{};
  Infeed infeed_{};
  NextFeed next_feed_{};
  std::vector<Fillet> fillets_;
  std::vector<std::int32_t> fillet_of_body_;
  std::vector<TrueFilletExit> exits_;
  std::size_t exit_count_ = 0;
  std::size_t exits_drained_ = 0;
  bool beam_ = false;

  std::unique_ptr<BulkScene> bulk_;  // dem_bulk_end
  std::int64_t bulk_due_ns_ = 0;     // plant time of the scene's next control step
  std::optional<Handover> last_handover_;

  TwinRng feed_rng_;
  TwinRng body_rng_;
  TwinRng sensor_rng_;  // level sensor
  std::uint32_t last_plant_id_ = 0;
  std::uint32_t last_group_id_ = 0;
  InputImage image_{};
};

}  // namespace fl
