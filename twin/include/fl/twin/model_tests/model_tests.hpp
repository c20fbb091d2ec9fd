// The model tests of the thesis "From Bulk to Belt" (sections 3.4-3.5, results chapter 4) on
// this project's DEM engine. Each test is a function of a parameter struct (CommonParams for
// sub-particle radius, fillet variant, threads; the test's setup; the swept parameter) that
// returns a result struct of time series and scalar outcomes. Geometry is built of planes and
// boxes as in the thesis. demlab (apps/demlab) writes the results as CSV and SVG.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "fl/twin/model_tests/fixtures.hpp"

namespace fl::model_tests {

using Progress = std::function<void(std::size_t done, std::size_t total)>;

// ---------------------------------------------------------------- settle (damping), 3.4.1

struct EnergySample {
  double time_s = 0.0;
  double kinetic_j = 0.0;  // translational + rotational
  double gravitational_j = 0.0;
  double bond_elastic_j = 0.0;
  double contact_elastic_j = 0.0;
  double total_j = 0.0;
  double intact_bond_share = 1.0;
};

enum class SettleBody {
  kFillet,     // a fillet meta-particle, random orientation (figure 3.13)
  kBasicCube,  // the 2x2x2 meta-particle of figure 3.10
};

struct SettleParams {
  CommonParams common;
  SettleBody body = SettleBody::kFillet;
  double drop_height_m = 0.5;  // lowest sphere bottom above the floor (thesis: 500 mm)
  double duration_s = 2.0;
  double sample_interval_s = 0.005;
  std::optional<double> restitution;  // overrides hertz_mindlin restitution of every pair
};

struct SettleResult {
  std::vector<EnergySample> series;
  double timestep_s = 0.0;
  double bond_critical_step_s = 0.0;
  std::size_t particles = 0;
  std::size_t bonds = 0;
  double impact_time_s = 0.0;     // first floor contact
  double impact_kinetic_j = 0.0;  // kinetic energy then
  // Time after impact until the kinetic energy stays below 10%, 5%, 1% of impact_kinetic_j
  // ("time to dampen 90, 95, 99% of the energy", figure 4.3); empty: not within the run.
  std::optional<double> settle_90_s, settle_95_s, settle_99_s;
  double intact_bond_share = 1.0;  // at the end
  // Largest total energy after impact minus the total at impact (> 0: energy was created,
  // the "spiralling" total energy of figure 4.2).
  double energy_gain_j = 0.0;
};

SettleResult run_settle(const SettleParams& params);

// ---------------------------------------------------------------- bend, 3.4.1 figure 3.11

struct BendParams {
  CommonParams common;
  double table_length_m = 0.4;
  double table_width_m = 0.3;
  double table_thickness_m = 0.02;
  double overhang_share = 0.5;  // share of the fillet's length beyond the table edge
  // Spheres further than this behind the edge are held in place (0: free, the fillet may
  // slide off the table).
  double clamp_behind_edge_m = 0.03;
  double duration_s = 2.0;
  double sample_interval_s = 0.01;
  // Mass-proportional damping of every sphere's velocity and spin (1/s), as LAMMPS' fix
  // viscous: it takes energy out of the swing and leaves the static equilibrium where it is,
  // so the run ends at the angle a fillet comes to rest at on a lab table. 0: the thesis' run,
  // whose bonds have no damping, so the hanging part swings for seconds.
  double rest_damping_per_s = 0.0;
};

struct BendSample {
  double time_s = 0.0;
  double angle_deg = 0.0;
  double tip_x_m = 0.0;
  double tip_z_m = 0.0;
};

struct BendResult {
  std::vector<BendSample> series;
  // Angle through which the chord from the edge section to the tip turned down from its
  // start (0: rigid; 90: hanging straight down; > 90: curled back under the edge), averaged
  // over the last quarter of the run, and its range there: the swing without rest damping,
  // the residual motion with it.
  double angle_deg = 0.0;
  double angle_min_deg = 0.0;
  double angle_max_deg = 0.0;
  bool slid_off = false;  // no sphere left on the table: the angle means nothing
  double intact_bond_share = 1.0;
  double timestep_s = 0.0;
};

BendResult run_bend(const BendParams& params);

// ---------------------------------------------------------------- slide, 3.4.1 figure 3.12

struct SlideParams {
  CommonParams common;
  double plate_length_m = 1.0;  // thesis: a one-metre plate
  double plate_width_m = 0.3;
  double plate_thickness_m = 0.01;
  double tilt_rate_deg_per_s = 5.0;
  double max_angle_deg = 70.0;
  double settle_s = 0.3;           // flat plate before tilting
  double slide_distance_m = 0.01;  // centroid travel along the plate that counts as sliding
  // The fillet's turn about the vertical (+z, counter-clockwise seen from above) as it is laid
  // on the plate (0: its long axis along the tilt). A hand placement varies it by a few degrees;
  // where the contacts stick and slip, the onset turns on it (an ensemble over it:
  // workbench::SlideSettings).
  double placement_yaw_rad = 0.0;
  // Fillet-equipment friction (appendix B: 0.5): coulomb's mu or, where the chain has
  // static_kinetic_friction instead, its static mu_s (the onset: atan(mu_s) on an incline) with
  // mu_k kept at the configured mu_k / mu_s (set_friction_coefficient).
  double friction_coefficient = 0.5;
  double surface_energy_j_per_m2 = 0.055;  // fillet-equipment JKR (appendix B: 0.055)
  // Solid fillet: sphere rotation locked and these stiff bonds (thesis figure 4.6 "solid").
  bool rigid = false;
  Stiffness rigid_stiffness{1e8, 1e8};
};

struct SlideSample {
  double time_s = 0.0;
  double plate_angle_deg = 0.0;
  double travel_m = 0.0;  // centroid travel along the plate since the tilt began
};

struct SlideResult {
  std::vector<SlideSample> series;
  std::optional<double> slide_angle_deg;  // plate angle when travel reached slide_distance_m
  double intact_bond_share = 1.0;
  double timestep_s = 0.0;
};

SlideResult run_slide(const SlideParams& params);

// ---------------------------------------------------------------- compression, 3.5

struct CompressParams {
  CommonParams common;
  int block_nx = 5;  // spheres per side of the bonded block
  int block_ny = 5;
  int block_nz = 4;
  double speed_m_per_s = 0.01;  // plate speed after a smooth start
  double max_strain = 0.05;
  int samples = 100;
  // A measured test instead (load, hold, unload): the plate's travel at these times,
  // linearly interpolated, starting at 0 with the plate touching; one sample per entry.
  // Replaces speed, max_strain and samples when not empty.
  std::vector<double> profile_time_s;
  std::vector<double> profile_travel_m;
};

struct CompressSample {
  double time_s = 0.0;
  double plate_travel_m = 0.0;
  double block_shortening_m = 0.0;  // top minus bottom sphere layer, change since start
  double section_force_n = 0.0;     // compressive force through the block's mid-height bonds
  double plate_force_n = 0.0;       // the block's push on the top plate (State::wall_force_n)
};

struct CompressResult {
  std::vector<CompressSample> series;
  double gauge_length_m = 0.0;  // L: centre distance of the top and bottom sphere layers
  double area_m2 = 0.0;         // A: nx ny (2r)^2
  // E = F L / (A dL) (eq. 3.7) from a least-squares slope over the loading part.
  double youngs_modulus_pa = 0.0;        // section force against block shortening
  double plate_youngs_modulus_pa = 0.0;  // plate force against plate travel, block height
  // The lattice's analytic value: a column of bonds k = S_n pi (s r)^2 of length 2r per
  // (2r)^2 of cross-section: E = pi S_n s^2 r / 2.
  double analytic_youngs_modulus_pa = 0.0;
  double timestep_s = 0.0;
};

CompressResult run_compress(const CompressParams& params);

// ---------------------------------------------------------------- fillets tracked on a belt

// Fillets carried by one flat belt (a plane of the equipment material whose surface moves
// along +x at the commanded speed), as the line's cameras track them: each fillet appears
// lying flat at its first sample's pose, moving with the belt, and is tracked from then on.
// What a takt acceleration does to them (slip, a lag, a turn) is the answer.
struct BeltFilletSample {
  std::size_t fillet = 0;  // index into BeltTracksParams::first_poses
  double time_s = 0.0;
};

struct BeltPose {
  double x_m = 0.0;  // the fillet's centre (mean of its sphere centres)
  double y_m = 0.0;
  double yaw_rad = 0.0;  // of the fillet's long axis (its body x axis), unwrapped from the start
};

// A logged value at a time, as a command log drives a machine: linear between the samples
// (`linear` false: held from the sample at or before), held before the first and after the
// last. `time_s` ascending, as long as `value`, not empty.
double logged_value_at(const std::vector<double>& time_s, const std::vector<double>& value,
                       double at_s, bool linear = true);

struct BeltTracksParams {
  CommonParams common;
  // Belt speed, piecewise linear between the points, held before the first and after the last.
  std::vector<double> command_time_s;
  std::vector<double> belt_speed_m_per_s;
  std::vector<BeltPose> first_poses;      // one per fillet: where it appears
  std::vector<BeltFilletSample> samples;  // ascending in time; a fillet's first is its spawn
  double command_interval_s = 0.001;      // the belt speed is updated this often
};

struct BeltTracksResult {
  std::vector<BeltPose> poses;  // one per sample (fewer: the run became unstable)
  double timestep_s = 0.0;
  std::size_t particles = 0;
};

BeltTracksResult run_belt_tracks(const BeltTracksParams& params);

// ---------------------------------------------------------------- drops: impact, angle, scale

// One fillet dropped on a floor plane: with a speed from just above it, or from a height.
struct DropParams {
  CommonParams common;
  double speed_m_per_s = 2.0;  // initial downward speed, released 1 mm above the floor
  double drop_height_m = 0.0;  // > 0: released at rest from this height instead
  std::optional<Eigen::Quaterniond> orientation;  // empty: random from common.seed
  double duration_s = 0.5;
  double scale = 1.0;  // fillet scale (scaling test)
  // Timestep as a multiple of the bond critical step (overrides the common choice).
  std::optional<double> timestep_factor_of_bond_critical;
  double sample_interval_s = 0.005;
  // Times after release (ascending) at which the height of the fillet's centre (the mean of
  // its sphere centres, as a camera tracks it) above the floor is recorded
  // (DropResult::centre_height_m).
  // The run lasts to the later of duration_s and the last of them.
  std::vector<double> height_times_s;
};

struct DropResult {
  double intact_bond_share = 1.0;  // at the end
  double min_intact_bond_share = 1.0;
  std::optional<double> settle_95_s;  // kinetic energy stays below 5% of its impact value
  double timestep_s = 0.0;
  double bond_critical_step_s = 0.0;
  std::size_t particles = 0;
  std::vector<double> centre_height_m;  // at DropParams::height_times_s
};

DropResult run_drop(const DropParams& params);

// Impact speed stability (4.2.1): every stiffness set at every speed, `orientations` random
// orientations each.
struct ImpactParams {
  DropParams drop;
  std::vector<double> speeds_m_per_s;
  std::vector<Stiffness> stiffness_sets;
  int orientations = 3;
  int threads = 1;
  Progress progress;
};
struct ImpactRow {
  Stiffness stiffness;
  double speed_m_per_s = 0.0;
  int orientation = 0;
  double intact_bond_share = 1.0;
};
std::vector<ImpactRow> run_impact(const ImpactParams& params);

// Angle stability (4.2.2): Hammersley-sampled yaw, pitch, roll in [0, 2 pi).
struct AngleParams {
  DropParams drop;
  int samples = 200;
  int threads = 1;
  Progress progress;
};
struct AngleRow {
  double yaw_rad = 0.0, pitch_rad = 0.0, roll_rad = 0.0;
  double intact_bond_share = 1.0;
};
std::vector<AngleRow> run_angle_drop(const AngleParams& params);

// Scaling stability (4.2.3): the fillet scaled by each factor, dropped from a height.
struct ScalingParams {
  DropParams drop;  // drop_height_m > 0 for the thesis' 500 mm drop
  std::vector<double> scales;
  int threads = 1;
  Progress progress;
};
struct ScalingRow {
  double scale = 1.0;
  DropResult result;
};
std::vector<ScalingRow> run_scaling(const ScalingParams& params);

// ---------------------------------------------------------------- DOE, appendix C

struct DoeParams {
  SettleParams settle;             // one settle run per grid point
  std::optional<BendParams> bend;  // and a bend run when set
  std::vector<double> normal_levels_n_per_m3;
  std::vector<double> shear_levels_n_per_m3;
  int threads = 1;
  Progress progress;
};
struct DoeRow {
  Stiffness stiffness;
  SettleResult settle;  // series cleared to save memory
  std::optional<BendResult> bend;
};
std::vector<DoeRow> run_doe(const DoeParams& params);

}  // namespace fl::model_tests
