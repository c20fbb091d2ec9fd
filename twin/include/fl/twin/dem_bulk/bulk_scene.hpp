// The bulk end of the line as a DEM scene (issue 3 item 2; thesis 5.3 and 6.1): the mailbox
// hopper with its adjustable slit opening over the bulk belt, the belt, the universal leveller
// with its rotating blades downstream, and a discharge edge where fillets leave and are counted.
//
// Frame: x along the travel (the gate's plane at x = gate.x_mm), y across (0 on the belt
// centre), z up (0 on the belt surface). Every wall is a triangle mesh built from
// config/bulk_dem.yaml; the gate is moved by translating its wall (z = the opening), the belt
// is a surface velocity, the leveller's rotor turns about its own axis (a wall rotation).
//
// Fillets are the thesis' bonded meta-particles (six variants, fillet_generator.hpp) with the
// appendix-B laws of config/dem.yaml; they are dropped into the hopper in random poses from a
// seeded generator, as an initial fill and/or at a rate, and taken out of the engine once their
// centroid is past the discharge edge. As the DEM plant's infeed (BulkBeltConfig::
// hold_at_discharge) the belt that reaches the discharge edge stops while a fillet waits at the
// edge, as an accumulating transfer does at a photo-eye, and a stop plate backs it up: the
// fillet leaves only when the takt belt downstream takes it (hand_over_front()).
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "fl/twin/dem/fillet_template.hpp"
#include "fl/twin/dem/simulation.hpp"
#include "fl/twin/dem/sphere_group.hpp"

namespace fl {

struct BulkSimulationConfig {
  double sub_particle_radius_mm = 7.0;  // thesis 3..7 mm; 7 mm for speed
  double rayleigh_fraction = 0.15;      // timestep share of the Rayleigh time (appendix B)
  double neighbor_skin_mm = 4.0;
  int thread_count = 1;
  double control_step_s = 0.002;  // commands, counting and the feeder run at this step
  std::uint64_t seed = 1;         // poses and variants of the fed fillets
};

struct BulkBeltConfig {
  double half_width_mm = 200.0;  // 400 mm belt, as the DEM plant's
  double start_mm = -550.0;      // upstream end (behind the hopper's back wall)
  double discharge_mm = 900.0;   // downstream end: fillets past it are counted and removed
  double speed_mps = 0.2;        // initial command
  double max_speed_mps = 1.0;    // line.yaml drives.bulk.max_speed_mps
  double side_wall_height_mm = 100.0;
  // Set by the DEM plant, not read from the file: the transfer onto the takt belt. The belt
  // that reaches the discharge edge stops while a fillet is at the edge (a photo-eye
  // interlock: the fillet waits still, and the ones behind it queue on the stopped belt), and
  // a plate across the edge stops whatever slides on. Fillets leave only through
  // hand_over_front(). A plate alone, with the belt slipping under the waiting fillets, turned
  // them crosswise (70 to 90 degrees off the travel for most of them).
  bool hold_at_discharge = false;
};

struct BulkHopperConfig {
  double back_mm = -400.0;       // lower edge of the back wall (the gate is the front)
  double height_mm = 400.0;      // walls from the belt up to this
  double back_slope_deg = 15.0;  // back wall leans outwards by this from the vertical
  double wall_gap_mm = 3.0;      // back wall's lower edge over the belt (belt runs under it)
};

struct BulkGateConfig {
  double x_mm = 0.0;                  // the gate's plane
  double opening_mm = 60.0;           // line.yaml bulk.hopper_opening_mm
  double min_opening_mm = 0.0;        // cylinder end stops
  double max_opening_mm = 150.0;      // plant_fast.yaml hopper_max_opening_mm
  double cylinder_speed_mmps = 50.0;  // plant_fast.yaml hopper_cylinder_speed_mmps
};

struct BulkLevellerConfig {
  double x_mm = 500.0;           // rotor axis along the travel
  int blades = 8;                // thesis 5.3: eight blades
  double tip_radius_mm = 150.0;  // blade tip circle
  double hub_radius_mm = 50.0;
  double tip_clearance_mm = 55.0;  // lowest blade tip over the belt
  double speed_rpm = 120.0;        // line.yaml leveller.speed_rpm; > 0 sweeps back at the belt
  int hub_segments = 16;
};

// The universal leveller's own conveyor (optional; thesis 5.3: "the fillets descend onto a
// secondary conveyor, traversing beneath the universal leveller"): the belt from from_mm to the
// discharge edge is a second belt, turning with the rotor (one drive: speed_mps when the rotor
// turns at rotor_rpm, in proportion otherwise). The level sensor then regulates only the bulk
// belt under the hopper, and the levelled layer keeps leaving while the heap is held. Without
// it one belt runs from start to discharge at the bulk belt's speed.
struct BulkLevellerBeltConfig {
  bool present = false;
  double from_mm = 150.0;    // the bulk belt's end: between the gate and the rotor's tip circle
  double speed_mps = 0.15;   // at rotor_rpm
  double rotor_rpm = 120.0;  // line.yaml leveller.speed_rpm
};

struct BulkFeederConfig {
  std::uint32_t initial_fill = 12;  // fillets placed in the hopper at construction
  double rate_per_s = 0.0;          // further fillets dropped per second (0: none)
  double drop_height_mm = 450.0;    // rate feeder drops from this height over the belt
  double max_tilt_deg = 20.0;       // random tilt of a dropped fillet's plane
  std::uint32_t max_fillets = 600;  // in the scene at once (the thesis ran 450)
};

struct BulkDemConfig {
  dem::ModelSpec engine;  // config/dem.yaml (appendix B), walls and solver set by the scene
  BulkSimulationConfig simulation;
  BulkBeltConfig belt;
  BulkHopperConfig hopper;
  BulkGateConfig gate;
  BulkLevellerConfig leveller;
  BulkLevellerBeltConfig leveller_belt;
  BulkFeederConfig feeder;
};

// Defaults above with the appendix-B engine.
BulkDemConfig default_bulk_dem_config();
// Reads config/bulk_dem.yaml strictly (fl::YamlReader; every problem with file:line and key
// path) and the engine file it names; throws fl::ConfigError.
BulkDemConfig load_bulk_dem_config(const std::filesystem::path& file);

struct BulkFilletView {
  std::uint32_t id = 0;  // feed number, from 1
  std::uint8_t variant = 0;
  dem::Vec3 centroid_m = dem::Vec3::Zero();
  dem::Vec3 velocity_m_per_s = dem::Vec3::Zero();
  dem::Vec3 lower_m = dem::Vec3::Zero();  // bounding box of its spheres
  dem::Vec3 upper_m = dem::Vec3::Zero();
  double mass_kg = 0.0;
  bool passed_gate = false;
};

// A fillet leaving the scene through the stop plate at the discharge edge (hand_over_front()).
struct BulkHandover {
  std::uint32_t id = 0;
  std::uint8_t variant = 0;  // thesis_fillet_variants() order
  double time_s = 0.0;
  dem::Vec3 centroid_m = dem::Vec3::Zero();
  dem::Vec3 velocity_m_per_s = dem::Vec3::Zero();
  dem::Vec3 lower_m = dem::Vec3::Zero();  // bounding box of its spheres
  dem::Vec3 upper_m = dem::Vec3::Zero();
  // Template to world: the rigid fit of its template to its spheres (dem::TemplateRotationFit);
  // column 0 is its heading (thick end to tip), entry (2, 2) > 0 means skin side up.
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
};

struct BulkCounters {
  std::uint64_t fed = 0;
  std::uint64_t passed_gate = 0;  // centroid crossed the gate's plane downstream
  double passed_gate_mass_kg = 0.0;
  std::uint64_t discharged = 0;  // centroid past the discharge edge, or handed over (removed)
  double discharged_mass_kg = 0.0;
  std::uint64_t lost = 0;  // fell off the scene (centroid under the belt plane; removed)
  // Broken bonds that left with removed fillets: with the engine's broken bonds now, the
  // damage done since the start.
  std::uint64_t broken_bonds_removed = 0;
  // Spheres torn off a fillet that fell under the belt plane while their fillet stays on the
  // belt: held still there (see BulkScene::stop_fallen_spheres), counted once each.
  std::uint64_t fallen_spheres = 0;
  std::uint64_t rebuilds = 0;  // engine rebuilt to take fillets out
};

// Rotor load from the contacts on the blades and hub (see leveller_load()).
struct LevellerLoad {
  double force_sum_n = 0.0;  // sum of the contacts' elastic normal force magnitudes
  // The engine's reaction on the rotor wall about its axis (every law of the chain: elastic,
  // damping, friction, adhesion), as EDEM's geometry torque; > 0 opposes the commanded rotation.
  double torque_nm = 0.0;
  std::size_t contacts = 0;  // spheres touching the rotor
};

class BulkScene {
 public:
  explicit BulkScene(const BulkDemConfig& config);
  ~BulkScene();
  BulkScene(const BulkScene&) = delete;
  BulkScene& operator=(const BulkScene&) = delete;

  // Advances by whole control steps (rounded to the nearest).
  void step(double seconds);

  // ---- commands (take effect from the next control step)
  void set_gate_opening_mm(double opening_mm);  // clamped to the end stops; cylinder speed
  void set_belt_speed_mps(double speed_mps);    // clamped to +-max
  void set_leveller_rpm(double rpm);
  // Places one fillet: variant 0..5 (thesis_fillet_variants order), centroid, orientation.
  std::uint32_t add_fillet(std::uint8_t variant, const dem::Vec3& centroid_m,
                           const Eigen::Quaterniond& orientation,
                           const dem::Vec3& velocity_m_per_s = dem::Vec3::Zero());
  // A loose sphere of fillet material (for checks of the walls); returns its creation id.
  std::uint32_t add_sphere(const dem::Vec3& position_m, double radius_m);

  // ---- state and geometry
  [[nodiscard]] double time_s() const;
  [[nodiscard]] double gate_opening_mm() const;                            // where the gate is now
  [[nodiscard]] double gate_target_mm() const { return gate_target_mm_; }  // commanded
  [[nodiscard]] double gate_lower_edge_z_m() const;      // from the placed gate mesh
  [[nodiscard]] double leveller_lowest_tip_z_m() const;  // lowest blade tip now
  [[nodiscard]] double leveller_angle_rad() const;
  [[nodiscard]] double belt_speed_mps() const {
    return wall_leveller_belt_ == wall_belt_ && transfer_waiting() ? 0.0 : belt_speed_mps_;
  }
  // The leveller unit's belt (BulkLevellerBeltConfig); the bulk belt's speed without one.
  // Either is 0 while the transfer holds a fillet at the discharge edge (hold_at_discharge).
  [[nodiscard]] double leveller_belt_speed_mps() const;
  // A fillet waits at the discharge edge (hold_at_discharge): the belt there is stopped.
  [[nodiscard]] bool transfer_waiting() const { return front_fillet() != nullptr; }
  [[nodiscard]] double leveller_rpm() const { return leveller_rpm_; }
  [[nodiscard]] const dem::Simulation& simulation() const { return *sim_; }
  [[nodiscard]] const std::vector<dem::FilletTemplate>& templates() const { return templates_; }
  [[nodiscard]] std::vector<BulkFilletView> fillets() const;
  [[nodiscard]] const BulkDemConfig& config() const { return config_; }

  // ---- measurements
  [[nodiscard]] const BulkCounters& counters() const { return counters_; }
  [[nodiscard]] std::size_t fillets_in_hopper() const;  // centroid upstream of the gate
  [[nodiscard]] std::size_t fillets_in_scene() const { return fillets_.size(); }
  // Events per second over the last `window_s` of scene time (or since the start).
  [[nodiscard]] double outflow_rate_per_s(double window_s) const;
  [[nodiscard]] double mass_flow_kg_per_s(double window_s) const;
  [[nodiscard]] double gate_pass_rate_per_s(double window_s) const;
  [[nodiscard]] double gate_mass_flow_kg_per_s(double window_s) const;  // the mailbox's outflow
  // Load on the leveller at the end of the last engine step: the torque is the engine's
  // reaction on the rotor wall (dem::State::wall_torque_nm); the contact count and force sum
  // are recounted from the spheres overlapping a rotor triangle (Hertz elastic part,
  // F = 4/3 E* sqrt(R) overlap^1.5), which the engine does not keep per wall.
  [[nodiscard]] LevellerLoad leveller_load() const;
  // Mean of leveller_load() over the control steps of the last step() call.
  [[nodiscard]] LevellerLoad leveller_load_mean() const { return load_mean_; }
  // A level sensor over the belt: the highest sphere top (centre z + radius) of any fillet
  // sphere whose centre lies in x_from_mm..x_to_mm, across the whole belt, as a laser line
  // across the belt sees the heap; 0 over a bare belt. Millimetres over the belt surface.
  [[nodiscard]] double heap_height_mm(double x_from_mm, double x_to_mm) const;

  // ---- the transfer at the discharge edge (hold_at_discharge)
  // The fillet that reached the stop plate first (its leading edge within kAtStopMm of it) of
  // those there now; none while no fillet is. Always none without the stop plate.
  [[nodiscard]] std::optional<BulkHandover> front_at_discharge() const;
  // Takes that fillet out of the scene and counts it discharged; none if there is none.
  std::optional<BulkHandover> hand_over_front();
  // How close to the stop plate a fillet's leading edge must come to count as at it: soft
  // contact, JKR adhesion and the belt pushing leave it a fraction of a sphere from the plate.
  static constexpr double kAtStopMm = 5.0;

 private:
  struct Fillet : dem::SphereGroup {
    std::uint32_t id = 0;
    std::uint8_t variant = 0;
    std::uint32_t body = 0;
    std::uint32_t first_id = 0;     // engine id of template sphere 0
    double at_stop_since_s = -1.0;  // when it first reached the stop plate; < 0: not yet
    bool passed_gate = false;
    bool remove = false;
  };
  struct Event {
    double time_s = 0.0;
    double mass_kg = 0.0;
  };

  std::shared_ptr<const dem::Model> build_model();
  void place_walls();
  void control_step(double h_s);
  void scan();
  void count_and_remove();
  void stop_fallen_spheres();
  void take_out_removed();
  void feed(double h_s);
  bool drop_random_fillet(const dem::Vec3& centre_m);
  void note_arrivals_at_stop();
  [[nodiscard]] bool at_stop(const Fillet& fillet) const;
  [[nodiscard]] const Fillet* front_fillet() const;
  [[nodiscard]] BulkHandover handover_of(const Fillet& fillet) const;
  void initial_fill();
  double uniform();  // [0, 1), portable (own bits, no std distribution)
  [[nodiscard]] double rate(const std::vector<Event>& events, double window_s, bool mass) const;

  BulkDemConfig config_;
  std::vector<dem::FilletTemplate> templates_;
  std::vector<std::vector<dem::BodyBond>> template_bonds_;
  std::vector<double> template_mass_kg_;
  std::shared_ptr<const dem::Model> model_;
  std::unique_ptr<dem::Simulation> sim_;
  std::vector<Fillet> fillets_;
  std::vector<std::int32_t> fillet_of_body_;
  std::vector<dem::Triangle> rotor_reference_;  // blades and hub, unmoved
  std::size_t wall_belt_ = 0, wall_gate_ = 0, wall_rotor_ = 0;
  std::size_t wall_leveller_belt_ = 0;  // == wall_belt_ without a leveller belt
  std::uint64_t rng_state_ = 0;
  std::uint32_t last_id_ = 0;
  double gate_target_mm_ = 0.0;
  double belt_speed_mps_ = 0.0;
  double leveller_rpm_ = 0.0;
  double feed_credit_ = 0.0;
  double nominal_time_s_ = 0.0;  // sum of control steps; the engine's clock follows it
  std::uint32_t pending_ = 0;    // initial fill that did not fit: dropped by the feeder
  double pair_e_star_pa_ = 0.0;  // fillet-steel effective modulus for the torque proxy
  BulkCounters counters_;
  std::vector<Event> gate_events_;
  std::vector<Event> discharge_events_;
  LevellerLoad load_mean_;
};

// Whether `seconds` is a whole number of control steps (within rounding): the scene runs whole
// steps, so a time between them would be run as another time than asked.
[[nodiscard]] bool is_whole_control_steps(double seconds, double control_step_s);

// Outflow of the mailbox against its opening (the thesis' 6.1 experiment in the model): for each
// opening a fresh scene with the same seed and fill, `settle_s` with the gate at the opening,
// then `measure_s` counted.
struct GateSweepOptions {
  double settle_s = 0.5;
  double measure_s = 2.0;
};
struct GateSweepPoint {
  double opening_mm = 0.0;
  double gate_passes_per_s = 0.0;        // fillets under the gate per second over measure_s
  double outflow_per_s = 0.0;            // past the discharge edge per second over measure_s
  double mass_flow_kg_per_s = 0.0;       // past the discharge edge
  double gate_mass_flow_kg_per_s = 0.0;  // under the gate: the mailbox's outflow
  std::uint64_t gate_passes = 0;
  std::uint64_t discharged = 0;
  double leveller_torque_nm = 0.0;  // mean over measure_s
  double wall_s = 0.0;              // computer time of this opening
};
// Throws std::runtime_error, naming the value, for an opening outside the gate's travel or a
// time that is not whole control steps (the measuring time at least one).
std::vector<GateSweepPoint> sweep_gate_opening(const BulkDemConfig& config,
                                               std::span<const double> openings_mm,
                                               const GateSweepOptions& options = {});
// Columns opening_mm, gate_passes_per_s, outflow_per_s, mass_flow_kg_per_s, gate_passes,
// discharged, leveller_torque_nm, wall_s (fl_report CSV); creates parent folders.
void write_gate_sweep_csv(std::span<const GateSweepPoint> points,
                          const std::filesystem::path& file);

}  // namespace fl
