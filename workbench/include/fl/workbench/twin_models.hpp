// The DEM twin as a TrialModel: each experiment of the thesis' model tests reproduced from a
// trial's conditions and driving channels. The engine model (contact and bond laws, effects
// from the effect library) comes from CommonParams::base_spec, so adding an effect to the
// model is a change of that spec (config/dem.yaml), not of this code.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "fl/controller/line_config.hpp"
#include "fl/twin/dem_bulk/bulk_scene.hpp"
#include "fl/twin/dem_plant/dem_plant_config.hpp"
#include "fl/twin/model_tests/fixtures.hpp"
#include "fl/twin/model_tests/model_tests.hpp"
#include "fl/workbench/compare.hpp"

namespace fl::workbench {

// Compression of a bonded block between plates: the top plate follows the measured
// displacement over the measured times (load, hold, unload as measured), the plate force is
// the model's answer. Sample size from the trial's sample_side and sample_height conditions
// (default 5 x 5 x 4 sub-particles).
class TwinCompressModel final : public TrialModel {
 public:
  explicit TwinCompressModel(model_tests::CommonParams common);
  [[nodiscard]] std::string describe() const override;
  Table run(const Dataset& dataset, const Trial& trial) override;

 private:
  model_tests::CommonParams common_;
};

// How the slide twin tilts its plate. 5 deg/s is the thesis' rate, taken when a trial has no
// `tilt_rate` condition; a fillet that has not slid by max_angle_deg is reported as failed
// (atan 5.7 = 80 deg: no fillet friction is that high).
// With ensemble_runs > 1 each trial is slid that many times, the fillet laid turned about the
// vertical at evenly spaced angles within +-placement_tolerance_deg (a hand placement's) about
// placement_yaw_deg (0: straight; the turn plus the tolerance at most 45 deg), and
// the answer is the members' mean with their spread as the channel onset_angle_spread (the
// sample standard deviation times sqrt(1 + 1/runs), as the line-tracks ensemble), which compare
// adds to the noise. Why: one run a trial is one draw where the onset turns on how the fillet
// lies. Where contacts stick and slip (static_kinetic_friction) it turns chaotically: by 0.5
// deg RMS for +-4 deg of turn on the 144 mm fillet, and by 0.3 to 0.9 deg between stick
// speeds 0.3 to 1 % apart. Under coulomb the 144 mm fillet's onset moves by under 0.05 deg,
// but the 172 mm one starts to slide in one of two ways, 0.45 deg apart, as it lies turned
// one way or the other (docs/measurements.md).
struct SlideSettings {
  double tilt_rate_deg_per_s = 5.0;
  double max_angle_deg = 80.0;
  int ensemble_runs = 1;
  double placement_tolerance_deg = 5.0;
  // The fillet's turn about the vertical, counter-clockwise seen from above: one run's, or the
  // centre of an ensemble's placements. What a generator re-laying the fillet varies.
  double placement_yaw_deg = 0.0;
};

// Slide test (thesis 3.4.1): a flexible fillet of the trial's `variant` (default 172x72x32) and
// `mirrored` flag on a plate tilted at the trial's `tilt_rate` until it slides; the onset angle is
// the answer, the same on every row (the rows are repetitions, the twin is deterministic; an
// ensemble, SlideSettings, answers its mean and spread). The
// fillet-equipment laws are the spec's: coulomb friction and jkr adhesion keep the spec's values
// (run_slide's own defaults are not used), and effects in that chain act. The `surface` condition:
// the spec describes the dry plate; a wet_film law in it is the film a wet plate carries, so it
// acts on surface=wet trials only and is taken out of the chain for dry ones (no surface: dry).
// Throws std::runtime_error when the fillet has not slid by max_angle_deg.
class TwinSlideModel final : public TrialModel {
 public:
  explicit TwinSlideModel(model_tests::CommonParams common, SlideSettings settings = {});
  [[nodiscard]] std::string describe() const override;
  Table run(const Dataset& dataset, const Trial& trial) override;

 private:
  model_tests::CommonParams common_;
  SlideSettings settings_;
};

// Drop test (thesis 3.4.1's settle test, tracked by a camera): a fillet of the trial's `variant`
// and `mirrored` flag released at rest lying flat, its lowest point `drop_height` above a plate
// of the equipment material; the answer is the height of the fillet's centre (the mean of its
// sphere centres) above the plate at every measured time. The time column counts from the
// release. Bond laws (and effects among them) and the fillet-equipment laws are the spec's; a
// wet_film law acts on surface=wet trials only, as in the slide model.
// It also runs settle datasets: the same fillet released at rest with its lowest point 1 mm
// over the plate (a settle trial has no drop_height), sagging and ringing into its rest.
class TwinDropModel final : public TrialModel {
 public:
  explicit TwinDropModel(model_tests::CommonParams common);
  [[nodiscard]] std::string describe() const override;
  Table run(const Dataset& dataset, const Trial& trial) override;

 private:
  model_tests::CommonParams common_;
};

// How the bend twin holds its fillet: bend test (thesis 3.4.1, figure 3.11). 2 s is the thesis'
// run; the answer is the mean angle over its last quarter. A measured fillet is read at rest,
// and the thesis' bonds have no damping, so the twin damps the motion (model_tests::BendParams::
// rest_damping_per_s) until it rests where its forces balance: undamped, the appendix-B fillet
// still swings from 58 to 80 deg in the last quarter, and the swing's mean is 2 deg off the rest
// angle. At 20/s the 7 mm fillet's angle moves under 0.1 deg in the last quarter.
struct BendSettings {
  double duration_s = 2.0;
  double clamp_behind_edge_m = 0.03;  // spheres further behind the edge are held (a hand)
  double rest_damping_per_s = 20.0;   // 0: the thesis' undamped swing, answered by its mean
};

// Bend test: a fillet of the trial's `variant` and `mirrored` flag lying flat on a table of the
// equipment material with `overhang` of its length beyond the edge bends down under its own
// weight. The answer, the same on every row (repetitions), is the angle through which the chord
// from the edge section to the tip turned down from the horizontal (0 rigid, 90 hanging
// straight down, above 90 curling back under the table). Throws std::runtime_error when the
// overhang is not inside the fillet's length or the fillet slid off the table.
class TwinBendModel final : public TrialModel {
 public:
  explicit TwinBendModel(model_tests::CommonParams common, BendSettings settings = {});
  [[nodiscard]] std::string describe() const override;
  Table run(const Dataset& dataset, const Trial& trial) override;

 private:
  model_tests::CommonParams common_;
  BendSettings settings_;
};

// The bulk twin's scene and counting window (thesis 6.1, the mailbox outflow): the scene's
// geometry, feed and seed from `scene` (config/bulk_dem.yaml's defaults), its engine laws and
// sub-particle radius from the model's CommonParams. After `settle_s` with the gate standing at
// the opening, the mass of the fillets whose centre passed under the gate over `measure_s` is the
// outflow (the discharge edge is 0.9 m on: 4.5 s away at 0.2 m/s).
struct BulkFlowSettings {
  BulkDemConfig scene = default_bulk_dem_config();
  double settle_s = 0.5;  // the initial fill falls 0.3 m and comes to rest
  double measure_s = 2.0;
};

// Bulk flow: one row per gate opening; each row is a fresh bulk scene with the gate at that
// opening, the belt at the trial's `belt_speed`, the hopper filled with the trial's `fill`
// fillets (absent: the scene's) and fed `feed_rate` more a second while it runs (absent: the
// scene's feeder, none by default); the answer is the mass flow out of the mailbox, under its
// gate.
// The fed fillets are the six variants drawn by the scene's seed (a variant condition does not
// narrow them: a bulk is mixed). A wet_film law acts on surface=wet trials only, as in the slide
// model.
class TwinBulkFlowModel final : public TrialModel {
 public:
  explicit TwinBulkFlowModel(model_tests::CommonParams common, BulkFlowSettings settings = {});
  [[nodiscard]] std::string describe() const override;
  Table run(const Dataset& dataset, const Trial& trial) override;

 private:
  model_tests::CommonParams common_;
  BulkFlowSettings settings_;
};

// How the line-tracks twin answers. Whether a fillet's contacts stick or slip on a hard takt can
// turn on less than the camera's error on where the fillet first appeared (a resting friction
// near the takt's mu g: docs/measurements.md), and then one run from the measured first poses
// says little. With ensemble_runs > 1 the twin runs that many times, each from the first poses
// jittered by the dataset's noise on x, y and angle (the camera's error on them), and answers
// the members' mean, with their spread per row as the channels x_spread, y_spread and
// angle_spread: how far one more run would lie from that mean, 1 sigma (the members' sample
// standard deviation times sqrt(1 + 1/runs)), which compare adds to the noise. The jitter is drawn
// from `seed` and the trial's id, so the same dataset gets the same answer.
// Tracks taken on the line (machine: line) run on the DEM plant of `line` and `plant` (null:
// default_line_config() and default_dem_plant_config()); its engine model and sphere size are
// replaced by the workbench's (CommonParams), so an effect added there acts on the line too.
struct LineTracksSettings {
  int ensemble_runs = 1;
  std::uint64_t seed = 1;
  std::shared_ptr<const LineConfig> line;
  std::shared_ptr<const DemPlantConfig> plant;
};

// Line tracks (the line's cameras following fillets on a belt): every fillet of the trial
// appears at its first row's pose (x, y, angle: the yaw of its long axis), lying flat and moving
// with the belt, on one belt of the equipment material driven by the trial's command log (the
// first speed column, linear between rows; no log: the belt_speed condition); the answer is each
// fillet's centre and yaw at each of its rows. A trial with machine: line runs on the DEM plant
// instead (fl::run_line_tracks): x is the line coordinate s, the angle runs from the thick end to
// the tip, the log's belt speeds are linear between rows and its stations held from each row;
// a row after the fillet left the twin's line (placed, crate, air knife) is answered with its
// last pose, and the run logs how many. The angle is the nearest turn to the measured
// one (a camera's angle is wrapped, the twin's is not). Variant, mirrored and surface as the
// slide model (a wet_film acts on surface=wet trials only). An ensemble (LineTracksSettings)
// needs the dataset's noise on x, y and angle; without it the run is refused.
class TwinLineTracksModel final : public TrialModel {
 public:
  explicit TwinLineTracksModel(model_tests::CommonParams common, LineTracksSettings settings = {});
  [[nodiscard]] std::string describe() const override;
  Table run(const Dataset& dataset, const Trial& trial) override;
  // On the line, the belt under each row's measured s ("on centring", "on multilane1" for a
  // unit's two belts, "on flip plates" between the guide and the reject belt): where on the
  // line the model fails. Tracks on one belt: compare's own phases.
  [[nodiscard]] std::optional<std::vector<std::string>> row_phases(
      const Dataset& dataset, const Trial& trial) const override;

 private:
  // One run of a machine: line trial from the given first poses (line coordinates, metres).
  std::vector<model_tests::BeltPose> run_on_line(
      const Trial& trial, const std::vector<model_tests::BeltPose>& first,
      const std::vector<model_tests::BeltFilletSample>& samples) const;

  model_tests::CommonParams common_;
  LineTracksSettings settings_;
};

// The first of x, y and angle for which the dataset gives no noise (or none above 0): an
// ensemble cannot jitter the first poses by it. Empty when all three have one.
std::string_view line_tracks_channel_without_noise(const Dataset& dataset);

// The effects in a model (laws of the effect library, dem::LawInfo::is_effect) with their
// parameters, "; "-joined in the order the spec lists them, each once; "none" without any:
// what the run history records beside each run's error.
std::string model_effects(const dem::ModelSpec& spec);

// What make_twin_model's twins take besides the engine model.
struct TwinSettings {
  LineTracksSettings line_tracks;
  SlideSettings slide;
};

// The twin of an experiment type (every type of the measurement format): what compare, diagnose
// and the generator run.
std::unique_ptr<TrialModel> make_twin_model(ExperimentType experiment,
                                            const model_tests::CommonParams& common,
                                            const TwinSettings& settings = {});

}  // namespace fl::workbench
