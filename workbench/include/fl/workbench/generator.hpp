// Synthetic measured datasets with a hidden effect, to prove the workbench: a truth model
// (the DEM twin plus one effect from the effect library, chosen at random with random
// parameters in a physical range, or none) run under a dataset's conditions, plus sensor
// noise. The truth goes to a separate file, so that whatever analyses the dataset cannot see
// it.
//
//   GeneratorOptions options;  options.seed = 7;  options.effect = "random";
//   const GeneratedDataset made = generate_dataset(options);
//   write_dataset(made.dataset, "data/hidden_7");
//   write_truth(made.truth, "data/hidden_7.truth.yaml");
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "fl/controller/line_config.hpp"
#include "fl/twin/dem/laws.hpp"
#include "fl/twin/dem_plant/dem_plant_config.hpp"
#include "fl/twin/model_tests/fixtures.hpp"
#include "fl/workbench/dataset.hpp"

namespace fl::workbench {

struct HiddenEffect {
  std::string law;  // a bond or contact law of the effect library; empty: no hidden effect
  dem::LawParameters parameters;
};

// The effects a compression test can reveal (bond laws), with their physical ranges.
std::vector<std::string> compress_effect_candidates();
// The effects a slide test can reveal (fillet-equipment contact laws): static_kinetic_friction
// (resting friction above the sliding one) and wet_film (a lubricating film on wet plates).
std::vector<std::string> slide_effect_candidates();
// The effects a drop test can reveal (bond laws, as compression), with ranges for a drop.
std::vector<std::string> drop_effect_candidates();
// The effects a bend test can reveal: stiffness graded with thickness.
std::vector<std::string> bend_effect_candidates();

struct GeneratorOptions {
  // Any type but settle (nothing a camera sees hides in it) and bulk_flow.
  ExperimentType experiment = ExperimentType::kCompress;
  std::uint64_t seed = 1;
  // "random": one of the experiment's candidates; "none"; or a law name from the candidates.
  std::string effect = "random";
  double force_noise_n = 0.01;  // compress: 1 sigma, Gaussian; written into the manifest
  // Compress: 1 sigma on the logged displacement (the crosshead's encoder; the truth's plate
  // follows the true path) and the logger's row interval.
  double displacement_noise_um = 0.0;
  double compress_row_s = 0.005;
  double angle_noise_deg = 0.3;       // slide: 1 sigma on each onset angle (an inclinometer's)
  double height_noise_mm = 0.5;       // drop: 1 sigma on each tracked height (a 200 fps camera's)
  double bend_angle_noise_deg = 1.0;  // bend: 1 sigma on each angle (read off a side photo)
  // Line tracks: 1 sigma on each camera position (x, y) and angle; fillets per trial.
  double position_noise_mm = 1.0;
  double track_angle_noise_deg = 1.0;
  int fillets_per_trial = 5;
  // Line tracks: where the truth starts. false: at each fillet's first row, noise and all, so a
  // twin started there can match the truth to the noise. true: at the fillet's true first pose,
  // which the camera saw with noise like every other row, as on a real line: then no twin
  // knows where the fillet really was (docs/measurements.md, the ensemble).
  bool truth_starts_at_true_pose = false;
  // Compress: loading rates 1x, 2x, 4x, ... Slide: fillet variants in turn (144x72x40,
  // 172x72x32, 176x72x40), each dry then wet, so the last of an even count is wet. 0: the
  // experiment's default (compress 3, slide 4 per tilt rate). Drop: heights 50, 100, 200 mm, ...
  // (doubling) with rows every 5 ms to 0.4 s after the impact; default 3. Line tracks: takt
  // accelerations 4 then 7 m/s^2 to 1.5 m/s, each dry then wet (default 4 trials, 20 fillets).
  // Bend: the variants in turn over the edge by 60, 80, 100 mm (+10 mm each round); default 3.
  int trials = 0;
  int repetitions = 10;  // slide, bend: angles (rows) per trial
  // Slide: each trial repeated at each of these tilt rates (written as its tilt_rate condition);
  // empty: the twin's 5 deg/s, no condition written. A rate-dependent friction shows itself
  // against a rate-independent one only across rates (docs/measurements.md).
  std::vector<double> slide_tilt_rates_deg_per_s;
  // Slide: each repetition re-lays the fillet, turned uniformly within SlideSettings' placement
  // tolerance, as a lab puts the fillet back after each slide: the rows then scatter by the
  // placement as well as the noise. false: laid once, straight; the rows differ by the noise.
  bool slide_relaid = false;
  // Line tracks: on the line (machine: line) instead of one lab belt. Each trial's fillets
  // appear one by one on the centring belt, as camera 2 would see them, and are tracked over
  // both multilane units to the squeeze belt, whose differentials turn them; each trial's log
  // names every belt (line_config's nominal speeds) and flips the units' differentials halfway;
  // dry then wet. The plant is `line_tracks_plant` on `line_tracks_line` (null: the defaults).
  bool line_tracks_on_line = false;
  std::shared_ptr<const LineConfig> line_tracks_line;
  std::shared_ptr<const DemPlantConfig> line_tracks_plant;
  model_tests::CommonParams common;  // the base model (appendix B, 7 mm) the effect joins
};

struct GeneratedDataset {
  Dataset dataset;
  HiddenEffect truth;
};

// Throws std::invalid_argument for an experiment or effect it cannot generate.
GeneratedDataset generate_dataset(const GeneratorOptions& options);

// The base model's spec with an effect's bond law in place of bpm (parameters kept, the
// effect's added). Shared by the generator and by what fits effects. Throws
// std::invalid_argument when the law is not a bond law of the registry.
dem::ModelSpec with_bond_effect(const dem::ModelSpec& base, const HiddenEffect& effect,
                                const dem::LawRegistry& registry = dem::LawRegistry::builtin());

// The base model's spec with a contact-law effect in every fillet-equipment chain, placed by
// its chain stage (docs/twin.md): after the chain's laws of its own and earlier stages, except
// that a friction law replaces the chain's friction law (one limit on the tangential force);
// replacing coulomb, a parameter kinetic_friction_coefficient the effect does not give is
// coulomb's coefficient (the base model's friction is the sliding one), capped at a static one.
// A law already in the chain gets the effect's parameters. Throws std::invalid_argument when
// the law is not a contact law of the registry.
dem::ModelSpec with_contact_effect(const dem::ModelSpec& base, const HiddenEffect& effect,
                                   const dem::LawRegistry& registry = dem::LawRegistry::builtin());
// Whether the experiment's twin is judged on how fillets touch the machine (slide, line
// tracks: contact-law effects) rather than on how they deform (the others: bond-law effects).
[[nodiscard]] bool loads_contacts(ExperimentType experiment);
// The effect where the experiment's candidates go: the fillet-equipment contact chain where
// loads_contacts, else the bond law.
dem::ModelSpec with_experiment_effect(
    const dem::ModelSpec& base, ExperimentType experiment, const HiddenEffect& effect,
    const dem::LawRegistry& registry = dem::LawRegistry::builtin());

// What to paste into the DEM config (config/dem.yaml's layout) to add an effect as
// with_experiment_effect does: for a contact effect the items of the resulting fillet-equipment
// `contact_laws:` list, to replace the items under the config's own key (the replaced or
// inherited parameters written out, so the text loads as it is; one list per pair, each after
// a `# type_a - type_b` line, when the pairs' chains differ); for a bond effect the whole
// `bond_law:` block. Empty for no effect; throws std::invalid_argument when the model has no
// such interaction.
[[nodiscard]] std::string effect_config_snippet(const dem::ModelSpec& base,
                                                ExperimentType experiment,
                                                const HiddenEffect& effect);

// Writes the dataset in the measurement format (manifest.yaml and one CSV per trial).
void write_dataset(const Dataset& dataset, const std::filesystem::path& folder);
void write_truth(const HiddenEffect& truth, const std::filesystem::path& file);

}  // namespace fl::workbench
