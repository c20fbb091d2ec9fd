#include "fl/workbench/twin_models.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <memory>
#include <numbers>
#include <optional>
#include <random>
#include <sstream>
#include <stdexcept>
#include <utility>
#include <variant>

#include "displacement_path.hpp"
#include "fl/controller/process_image.hpp"
#include "fl/twin/dem/config.hpp"
#include "fl/twin/dem_plant/line_tracks.hpp"
#include "fl/twin/model_tests/model_tests.hpp"

namespace fl::workbench {
namespace {

// Sub-particles along a sample edge: at least 2, so that bonds cross the section.
int spheres_along(const Conditions& conditions, std::string_view name, double radius_m,
                  int fallback) {
  const auto found = conditions.find(name);
  if (found == conditions.end()) return fallback;
  const double length_m = std::get<double>(found->second);
  return std::max(2, static_cast<int>(std::lround(length_m / (2.0 * radius_m))));
}

std::string label_condition(const Conditions& conditions, std::string_view name,
                            const std::string& fallback) {
  const auto found = conditions.find(name);
  return found == conditions.end() ? fallback : std::get<std::string>(found->second);
}

// model_tests' variant index (thesis_fillet_variants order: each size left, then mirrored)
// from the trial's variant label and mirrored flag; the absent ones keep the base model's.
std::size_t fillet_variant(const Conditions& conditions, std::size_t base_variant) {
  static constexpr std::string_view kSizes[] = {"144x72x40", "172x72x32", "176x72x40"};
  std::size_t size = base_variant / 2;
  bool mirrored = base_variant % 2 == 1;
  const auto variant = conditions.find("variant");
  if (variant != conditions.end()) {
    const auto& label = std::get<std::string>(variant->second);
    const auto* found = std::find(std::begin(kSizes), std::end(kSizes), label);
    if (found == std::end(kSizes)) throw std::runtime_error("unknown fillet variant " + label);
    size = static_cast<std::size_t>(found - std::begin(kSizes));
    mirrored = false;
  }
  const auto flag = conditions.find("mirrored");
  if (flag != conditions.end()) mirrored = std::get<bool>(flag->second);
  return 2 * size + (mirrored ? 1 : 0);
}

std::string law_text(const dem::LawSpec& law) {
  std::ostringstream text;
  text << law.name;
  if (law.parameters.empty()) return text.str();
  text << " (";
  bool first = true;
  for (const auto& [key, value] : law.parameters) {
    text << (first ? "" : ", ") << key << " " << value;
    first = false;
  }
  text << ")";
  return text.str();
}

// The spec describes the dry plate; a wet_film law in it is the film a wet plate carries, so it
// is taken out for trials that are not wet (no surface condition: dry).
void keep_wet_film_for_wet_trials(dem::ModelSpec& spec, const Conditions& conditions) {
  if (label_condition(conditions, "surface", "dry") == "wet") return;
  const std::uint32_t equipment = model_tests::equipment_type(spec);
  for (dem::InteractionSpec& interaction : spec.interactions) {
    if (!model_tests::is_fillet_with(interaction, equipment)) continue;
    std::erase_if(interaction.contact_laws,
                  [](const dem::LawSpec& law) { return law.name == "wet_film"; });
  }
}

// The fillet-equipment contact laws with their parameters, for describe().
std::string equipment_chain_text(const dem::ModelSpec& spec) {
  std::string text;
  const std::uint32_t equipment = model_tests::equipment_type(spec);
  for (const dem::InteractionSpec& interaction : spec.interactions) {
    if (!model_tests::is_fillet_with(interaction, equipment)) continue;
    for (const dem::LawSpec& law : interaction.contact_laws) text += " " + law_text(law);
    break;  // fillet types A and B share the chain
  }
  return text;
}

// The bond law of the spec with its parameters, for describe().
std::string bond_law_text(const dem::ModelSpec& spec) {
  for (const dem::InteractionSpec& interaction : spec.interactions) {
    if (interaction.bond_law) return law_text(*interaction.bond_law);
  }
  return "none";
}

// Refuses a dataset of another experiment type, naming the model and both types.
void require_experiment(const Dataset& dataset, ExperimentType type, std::string_view model) {
  if (dataset.experiment != type) {
    throw std::runtime_error("the " + std::string(model) + " model runs " +
                             std::string(to_string(type)) + " datasets, not " +
                             std::string(to_string(dataset.experiment)));
  }
}

// The model's answer: one channel in the unit of the trial's channel of that name, the trial's
// source lines kept for the report.
Table single_channel_answer(const Trial& trial, std::string_view name,
                            std::vector<double> values_si) {
  Table table;
  table.channels.push_back({std::string(name), trial.data.at(name).unit, std::move(values_si)});
  table.lines = trial.data.lines;
  return table;
}

// An ensemble's spread, 1 sigma of where one more member would land from the members' mean:
// their sample standard deviation times sqrt(1 + 1/runs), from the sums of the members' values
// and squares (a few runs of positions within metres lose nothing to this over Welford's).
double ensemble_spread(double sum, double sum_sq, double runs) {
  const double mean = sum / runs;
  const double variance = std::max(0.0, (sum_sq - runs * mean * mean) / (runs - 1.0));
  return std::sqrt(variance * (1.0 + 1.0 / runs));
}

}  // namespace

TwinCompressModel::TwinCompressModel(model_tests::CommonParams common)
    : common_(std::move(common)) {}

std::string TwinCompressModel::describe() const {
  std::ostringstream text;
  text << "DEM twin, bonded block of " << common_.sub_particle_radius_m * 1e3
       << " mm sub-particles; bond law " << bond_law_text(model_tests::make_spec(common_));
  return text.str();
}

Table TwinCompressModel::run(const Dataset& dataset, const Trial& trial) {
  require_experiment(dataset, ExperimentType::kCompress, "compress");
  const std::vector<double>& time_s = trial.data.at("time").values_si;
  const std::vector<double>& displacement_m = trial.data.at("displacement").values_si;
  model_tests::CompressParams params;
  params.common = common_;
  const double r = common_.sub_particle_radius_m;
  params.block_nx = spheres_along(trial.conditions, "sample_side", r, params.block_nx);
  params.block_ny = params.block_nx;
  params.block_nz = spheres_along(trial.conditions, "sample_height", r, params.block_nz);
  params.profile_time_s = time_s;
  // The plate follows the crosshead's path, not the logger's noise on it: row by row, a fast
  // logger's noise became plate speeds as large as the loading rate, and the stiff plate
  // contact answered them (a correct model scored 8.4 noise sigmas on a generated 10 kHz log).
  const std::vector<double> path_m = detail::smoothed_displacement_m(
      time_s, displacement_m, detail::stated_displacement_noise_m(dataset));
  for (const double d : path_m) params.profile_travel_m.push_back(d - path_m[0]);
  const model_tests::CompressResult result = model_tests::run_compress(params);
  if (result.series.size() != time_s.size()) {
    throw std::runtime_error("the compress model returned " + std::to_string(result.series.size()) +
                             " samples for " + std::to_string(time_s.size()) + " rows");
  }
  std::vector<double> force_n;
  for (const auto& sample : result.series) force_n.push_back(sample.plate_force_n);
  return single_channel_answer(trial, "force", std::move(force_n));
}

TwinSlideModel::TwinSlideModel(model_tests::CommonParams common, SlideSettings settings)
    : common_(std::move(common)), settings_(settings) {
  if (common_.base_spec.materials.empty()) common_.base_spec = dem::appendix_b_model_spec();
  if (settings_.ensemble_runs < 1) {
    throw std::invalid_argument("the slide ensemble needs one run or more, not " +
                                std::to_string(settings_.ensemble_runs));
  }
  // Beyond 45 deg the fillet would lie across the tilt: another test, not a placement error.
  // An ensemble at 0 would slide the same run N times and call its spread 0.
  const bool runs_vary = settings_.ensemble_runs == 1 || settings_.placement_tolerance_deg > 0.0;
  if (!(settings_.placement_tolerance_deg >= 0.0 && settings_.placement_tolerance_deg <= 45.0) ||
      !runs_vary) {
    throw std::invalid_argument(
        "the slide ensemble's placement tolerance must be above 0 and at most 45 deg, not " +
        std::to_string(settings_.placement_tolerance_deg));
  }
  if (!(std::abs(settings_.placement_yaw_deg) + settings_.placement_tolerance_deg <= 45.0)) {
    throw std::invalid_argument(
        "the slide's placement turn and tolerance must stay within 45 deg, not " +
        std::to_string(settings_.placement_yaw_deg) + " +- " +
        std::to_string(settings_.placement_tolerance_deg));
  }
}

std::string TwinSlideModel::describe() const {
  std::ostringstream text;
  text << "DEM twin, slide of a flexible fillet of " << common_.sub_particle_radius_m * 1e3
       << " mm sub-particles; fillet-equipment laws:";
  text << equipment_chain_text(common_.base_spec);
  if (settings_.ensemble_runs > 1) {
    text << "; mean of " << settings_.ensemble_runs << " placements within +-"
         << settings_.placement_tolerance_deg << " deg";
  }
  return text.str();
}

Table TwinSlideModel::run(const Dataset& dataset, const Trial& trial) {
  require_experiment(dataset, ExperimentType::kSlide, "slide");
  (void)trial.data.at("onset_angle");  // refuses a trial without the channel before running
  model_tests::SlideParams params;
  params.common = common_;
  params.common.variant = fillet_variant(trial.conditions, common_.variant);
  params.tilt_rate_deg_per_s = settings_.tilt_rate_deg_per_s;
  if (const auto rate = trial.conditions.find("tilt_rate"); rate != trial.conditions.end()) {
    const double* rate_rad_per_s = std::get_if<double>(&rate->second);
    if (rate_rad_per_s == nullptr) {
      throw std::runtime_error("trial '" + trial.id + "': tilt_rate is not a number");
    }
    params.tilt_rate_deg_per_s = *rate_rad_per_s * 180.0 / std::numbers::pi;
  }
  params.max_angle_deg = settings_.max_angle_deg;
  dem::ModelSpec& spec = params.common.base_spec;
  const std::uint32_t equipment = model_tests::equipment_type(spec);
  // run_slide sets the fillet-equipment friction (coulomb's, or static_kinetic_friction's static
  // coefficient) and jkr energy itself: hand it the spec's own, so the spec is the one source of
  // the model.
  keep_wet_film_for_wet_trials(spec, trial.conditions);
  std::optional<double> friction, surface_energy;
  for (dem::InteractionSpec& interaction : spec.interactions) {
    if (!model_tests::is_fillet_with(interaction, equipment)) continue;
    std::vector<dem::LawSpec>& laws = interaction.contact_laws;
    const auto coulomb = std::find_if(
        laws.begin(), laws.end(), [](const dem::LawSpec& law) { return law.name == "coulomb"; });
    const auto static_kinetic = std::find_if(laws.begin(), laws.end(), [](const dem::LawSpec& law) {
      return law.name == "static_kinetic_friction";
    });
    if (coulomb != laws.end()) {
      friction = coulomb->parameters.at("friction_coefficient");
    } else if (static_kinetic != laws.end()) {
      // static_kinetic_friction replaced coulomb: run_slide sets its static coefficient.
      friction = static_kinetic->parameters.at("static_friction_coefficient");
    }
    for (const dem::LawSpec& law : laws) {
      if (law.name == "jkr") surface_energy = law.parameters.at("surface_energy_j_per_m2");
    }
  }
  if (!friction) {
    throw std::runtime_error("the slide model needs a friction law between fillet and equipment");
  }
  params.friction_coefficient = *friction;
  params.surface_energy_j_per_m2 = surface_energy.value_or(0.0);  // no jkr: no adhesion
  constexpr double kRadPerDeg = std::numbers::pi / 180.0;
  const int runs = settings_.ensemble_runs;
  double sum_rad = 0.0;
  double sum_sq_rad = 0.0;
  for (int member = 0; member < runs; ++member) {
    // Evenly spaced over the tolerance about the placement (one run: at the placement).
    const double share = (member + 0.5) / runs;
    params.placement_yaw_rad =
        (settings_.placement_yaw_deg + settings_.placement_tolerance_deg * (2.0 * share - 1.0)) *
        kRadPerDeg;
    const model_tests::SlideResult result = model_tests::run_slide(params);
    if (!result.slide_angle_deg) {
      std::ostringstream reason;
      reason << "the fillet has not slid by " << settings_.max_angle_deg << " deg";
      if (runs > 1) reason << " (placement " << params.placement_yaw_rad / kRadPerDeg << " deg)";
      throw std::runtime_error(reason.str());
    }
    const double onset_rad = *result.slide_angle_deg * kRadPerDeg;
    sum_rad += onset_rad;
    sum_sq_rad += onset_rad * onset_rad;
  }
  const auto n = static_cast<double>(runs);
  const double mean_rad = sum_rad / n;
  Table table =
      single_channel_answer(trial, "onset_angle", std::vector<double>(trial.data.rows(), mean_rad));
  if (runs > 1) {
    table.channels.push_back(
        {"onset_angle_spread", trial.data.at("onset_angle").unit,
         std::vector<double>(trial.data.rows(), ensemble_spread(sum_rad, sum_sq_rad, n))});
  }
  return table;
}

TwinDropModel::TwinDropModel(model_tests::CommonParams common) : common_(std::move(common)) {
  if (common_.base_spec.materials.empty()) common_.base_spec = dem::appendix_b_model_spec();
}

std::string TwinDropModel::describe() const {
  std::ostringstream text;
  text << "DEM twin, flat drop of a flexible fillet of " << common_.sub_particle_radius_m * 1e3
       << " mm sub-particles; bond law " << bond_law_text(common_.base_spec);
  return text.str();
}

Table TwinDropModel::run(const Dataset& dataset, const Trial& trial) {
  const bool settle = dataset.experiment == ExperimentType::kSettle;
  if (dataset.experiment != ExperimentType::kDrop && !settle) {
    throw std::runtime_error("the drop model runs drop and settle datasets, not " +
                             std::string(to_string(dataset.experiment)));
  }
  const auto height = trial.conditions.find("drop_height");
  if (height == trial.conditions.end() && !settle) {
    throw std::runtime_error("the drop model needs the trial's drop_height condition");
  }
  model_tests::DropParams params;
  params.common = common_;
  params.common.variant = fillet_variant(trial.conditions, common_.variant);
  keep_wet_film_for_wet_trials(params.common.base_spec, trial.conditions);
  // Settle: no height, so run_drop releases the fillet 1 mm over the plate.
  params.drop_height_m = settle ? 0.0 : std::get<double>(height->second);
  params.speed_m_per_s = 0.0;  // released at rest, also from 0 height (1 mm up)
  params.orientation = Eigen::Quaterniond::Identity();  // flat, as the fillet lies on a belt
  params.height_times_s = trial.data.at("time").values_si;
  params.duration_s = 0.0;  // to the last measured time
  const model_tests::DropResult result = model_tests::run_drop(params);
  if (result.centre_height_m.size() != trial.data.rows()) {
    throw std::runtime_error("the drop model became unstable after " +
                             std::to_string(result.centre_height_m.size()) + " of " +
                             std::to_string(trial.data.rows()) + " rows");
  }
  return single_channel_answer(trial, "height", result.centre_height_m);
}

TwinBendModel::TwinBendModel(model_tests::CommonParams common, BendSettings settings)
    : common_(std::move(common)), settings_(settings) {
  if (common_.base_spec.materials.empty()) common_.base_spec = dem::appendix_b_model_spec();
}

std::string TwinBendModel::describe() const {
  std::ostringstream text;
  text << "DEM twin, flexible fillet of " << common_.sub_particle_radius_m * 1e3
       << " mm sub-particles over a table edge; bond law " << bond_law_text(common_.base_spec);
  return text.str();
}

Table TwinBendModel::run(const Dataset& dataset, const Trial& trial) {
  require_experiment(dataset, ExperimentType::kBend, "bend");
  const auto overhang = trial.conditions.find("overhang");
  if (overhang == trial.conditions.end()) {
    throw std::runtime_error("the bend model needs the trial's overhang condition");
  }
  model_tests::BendParams params;
  params.common = common_;
  params.common.variant = fillet_variant(trial.conditions, common_.variant);
  keep_wet_film_for_wet_trials(params.common.base_spec, trial.conditions);
  const double length_m = 2.0 * model_tests::make_fillet(params.common).half_extent_m.x();
  const double overhang_m = std::get<double>(overhang->second);
  if (!(overhang_m > 0.0 && overhang_m < length_m)) {
    std::ostringstream reason;
    reason << "the bend model needs an overhang inside the fillet's length: " << overhang_m * 1e3
           << " mm of a " << length_m * 1e3 << " mm fillet";
    throw std::runtime_error(reason.str());
  }
  params.overhang_share = overhang_m / length_m;
  params.duration_s = settings_.duration_s;
  params.clamp_behind_edge_m = settings_.clamp_behind_edge_m;
  params.rest_damping_per_s = settings_.rest_damping_per_s;
  const model_tests::BendResult result = model_tests::run_bend(params);
  if (result.slid_off || !std::isfinite(result.angle_deg)) {
    throw std::runtime_error("the bend model's fillet slid off the table");
  }
  constexpr double kRadPerDeg = std::numbers::pi / 180.0;
  return single_channel_answer(
      trial, "bend_angle", std::vector<double>(trial.data.rows(), result.angle_deg * kRadPerDeg));
}

TwinBulkFlowModel::TwinBulkFlowModel(model_tests::CommonParams common, BulkFlowSettings settings)
    : common_(std::move(common)), settings_(std::move(settings)) {
  if (common_.base_spec.materials.empty()) common_.base_spec = dem::appendix_b_model_spec();
}

std::string TwinBulkFlowModel::describe() const {
  std::ostringstream text;
  text << "DEM twin, mailbox hopper of " << settings_.scene.feeder.initial_fill
       << " bonded fillets (a trial's fill and feed_rate conditions change it) of "
       << common_.sub_particle_radius_m * 1e3
       << " mm sub-particles over the bulk belt; mass under the gate over " << settings_.measure_s
       << " s; fillet-equipment laws:" << equipment_chain_text(common_.base_spec);
  return text.str();
}

Table TwinBulkFlowModel::run(const Dataset& dataset, const Trial& trial) {
  require_experiment(dataset, ExperimentType::kBulkFlow, "bulk-flow");
  BulkDemConfig config = settings_.scene;
  config.engine = common_.base_spec;
  keep_wet_film_for_wet_trials(config.engine, trial.conditions);
  config.simulation.sub_particle_radius_mm = common_.sub_particle_radius_m * 1e3;
  config.simulation.thread_count = common_.thread_count;
  const auto speed = trial.conditions.find("belt_speed");
  if (speed != trial.conditions.end()) config.belt.speed_mps = std::get<double>(speed->second);
  const auto fill = trial.conditions.find("fill");
  if (fill != trial.conditions.end()) {
    const double fillets = std::get<double>(fill->second);
    if (fillets != std::floor(fillets)) {
      std::ostringstream reason;
      reason << "the bulk-flow model fills the hopper with whole fillets, not " << fillets;
      throw std::runtime_error(reason.str());
    }
    config.feeder.initial_fill = static_cast<std::uint32_t>(fillets);
  }
  const auto feed = trial.conditions.find("feed_rate");
  if (feed != trial.conditions.end()) config.feeder.rate_per_s = std::get<double>(feed->second);
  const std::vector<double>& opening_m = trial.data.at("opening").values_si;
  std::vector<double> openings_mm;
  openings_mm.reserve(opening_m.size());
  for (const double opening : opening_m) openings_mm.push_back(opening * 1e3);
  // The sweep refuses an opening beyond the gate's travel, naming it.
  const std::vector<GateSweepPoint> points = sweep_gate_opening(
      config, openings_mm, GateSweepOptions{settings_.settle_s, settings_.measure_s});
  std::vector<double> outflow_kg_per_s;
  outflow_kg_per_s.reserve(points.size());
  for (const GateSweepPoint& point : points) {
    outflow_kg_per_s.push_back(point.gate_mass_flow_kg_per_s);
  }
  return single_channel_answer(trial, "outflow", std::move(outflow_kg_per_s));
}

TwinLineTracksModel::TwinLineTracksModel(model_tests::CommonParams common,
                                         LineTracksSettings settings)
    : common_(std::move(common)), settings_(std::move(settings)) {
  if (common_.base_spec.materials.empty()) common_.base_spec = dem::appendix_b_model_spec();
  if (settings_.ensemble_runs < 1) {
    throw std::invalid_argument("the line-tracks model needs one run or more per trial, not " +
                                std::to_string(settings_.ensemble_runs));
  }
}

std::string TwinLineTracksModel::describe() const {
  std::ostringstream text;
  text << "DEM twin, flexible fillets of " << common_.sub_particle_radius_m * 1e3
       << " mm sub-particles on a commanded belt (tracks taken on the line: the line's DEM "
          "plant replaying its log)";
  if (settings_.ensemble_runs > 1) {
    text << ", mean of " << settings_.ensemble_runs << " runs from first poses within the noise";
  }
  text << "; fillet-equipment laws:" << equipment_chain_text(common_.base_spec);
  return text.str();
}

namespace {

// The jitter's seed for one trial: FNV-1a over its id, so that it does not hang on the trial's
// place in the dataset or on the standard library's hash.
std::uint64_t trial_seed(std::uint64_t seed, const std::string& id) {
  std::uint64_t hash = 1469598103934665603ULL ^ seed;
  for (const char c : id) {
    hash ^= static_cast<unsigned char>(c);
    hash *= 1099511628211ULL;
  }
  return hash;
}

}  // namespace

std::string_view line_tracks_channel_without_noise(const Dataset& dataset) {
  for (const std::string_view channel : {"x", "y", "angle"}) {
    const auto found = dataset.noise_si.find(channel);
    if (found == dataset.noise_si.end() || !(found->second > 0.0)) return channel;
  }
  return {};
}

namespace {

// The line's commands at a time from a line log (dataset.hpp, machine: line): belt speeds
// linear between rows as logged every scan, stations held from the row before.
OutputImage line_commands_at(const Table& log, double time_s) {
  const std::vector<double>& t = log.at("time").values_si;
  OutputImage out{};
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    if (const Channel* speed = log.find(kDriveNames[d]); speed != nullptr) {
      out.drives[d].speed_mps =
          static_cast<float>(model_tests::logged_value_at(t, speed->values_si, time_s, true));
    }
  }
  for (const LineLogFlag& flag : kLineLogFlags) {
    const Channel* channel = log.find(flag.column);
    out.*flag.field = channel != nullptr &&
                      model_tests::logged_value_at(t, channel->values_si, time_s, false) > 0.5;
  }
  if (const Channel* shift = log.find(kLineLogCentringShift); shift != nullptr) {
    out.centring_shift_mm =
        static_cast<float>(model_tests::logged_value_at(t, shift->values_si, time_s, false) * 1e3);
  }
  return out;
}

}  // namespace

std::optional<std::vector<std::string>> TwinLineTracksModel::row_phases(const Dataset& /*dataset*/,
                                                                        const Trial& trial) const {
  if (!runs_on_line(trial.conditions)) return std::nullopt;
  const LineConfig line = settings_.line ? *settings_.line : default_line_config();
  const double guide_end_mm = line.sections[index(DriveId::kGuide)].end_mm;
  const double reject_start_mm = line.sections[index(DriveId::kReject)].start_mm;
  std::vector<std::string> phases;
  for (const double s_m : trial.data.at("x").values_si) {
    const double s_mm = s_m * 1e3;
    if (s_mm >= guide_end_mm && s_mm < reject_start_mm) {
      phases.emplace_back("on flip plates");
      continue;
    }
    std::string belt(kDriveNames[index(drive_under(line, s_mm))]);
    if (belt.ends_with("_left")) belt.resize(belt.size() - 5);  // the unit's two belts
    phases.push_back("on " + belt);
  }
  return phases;
}

std::vector<model_tests::BeltPose> TwinLineTracksModel::run_on_line(
    const Trial& trial, const std::vector<model_tests::BeltPose>& first,
    const std::vector<model_tests::BeltFilletSample>& samples) const {
  if (!trial.commands) {
    throw std::runtime_error("trial '" + trial.id +
                             "' ran on the line and has no command log to replay");
  }
  LineTracksRun run;
  run.line = settings_.line ? *settings_.line : default_line_config();
  run.plant = settings_.plant ? *settings_.plant : default_dem_plant_config();
  run.plant.engine = common_.base_spec;
  keep_wet_film_for_wet_trials(run.plant.engine, trial.conditions);
  run.plant.simulation.sub_particle_radius_mm =
      static_cast<float>(common_.sub_particle_radius_m * 1e3);
  run.plant.simulation.thread_count = common_.thread_count;
  run.variant = static_cast<std::uint8_t>(fillet_variant(trial.conditions, common_.variant));
  const Table& log = *trial.commands;
  run.commands = [&log](double time_s) { return line_commands_at(log, time_s); };
  // A fillet appears at the time of its first row.
  std::vector<double> first_time_s(first.size(), -1.0);
  for (const model_tests::BeltFilletSample& sample : samples) {
    if (first_time_s[sample.fillet] < 0.0) first_time_s[sample.fillet] = sample.time_s;
    run.samples.push_back({sample.fillet, sample.time_s});
  }
  for (std::size_t f = 0; f < first.size(); ++f) {
    run.first.push_back(
        {first_time_s[f], first[f].x_m * 1e3, first[f].y_m * 1e3, first[f].yaw_rad});
  }
  const LineTracksResult result = run_line_tracks(run);
  if (result.rows_after_leaving > 0) {
    spdlog::warn(
        "trial '{}': {} rows after their fillet left the twin's line (placed, crate, air knife or "
        "fell off) are answered with its last pose",
        trial.id, result.rows_after_leaving);
  }
  std::vector<model_tests::BeltPose> poses;
  poses.reserve(result.poses.size());
  for (const LineTrackPose& pose : result.poses) {
    poses.push_back({pose.s_mm * 1e-3, pose.y_mm * 1e-3, pose.angle_rad});
  }
  return poses;
}

Table TwinLineTracksModel::run(const Dataset& dataset, const Trial& trial) {
  require_experiment(dataset, ExperimentType::kLineTracks, "line-tracks");
  const bool on_line = runs_on_line(trial.conditions);
  model_tests::BeltTracksParams params;
  params.common = common_;
  params.common.variant = fillet_variant(trial.conditions, common_.variant);
  keep_wet_film_for_wet_trials(params.common.base_spec, trial.conditions);
  if (on_line) {
    // The line's log is replayed by run_on_line.
  } else if (const Channel* logged = trial.commands ? belt_log_speed(*trial.commands) : nullptr) {
    params.command_time_s = trial.commands->at("time").values_si;
    params.belt_speed_m_per_s = logged->values_si;
  } else {
    const auto speed = trial.conditions.find("belt_speed");
    if (speed == trial.conditions.end()) {
      throw std::runtime_error(
          "the line-tracks model needs the trial's belt command log or its belt_speed condition");
    }
    params.command_time_s = {0.0};
    params.belt_speed_m_per_s = {std::get<double>(speed->second)};
  }
  const std::vector<double>& time = trial.data.at("time").values_si;
  const std::vector<double>& fillet = trial.data.at("fillet").values_si;
  const std::vector<double>& x = trial.data.at("x").values_si;
  const std::vector<double>& y = trial.data.at("y").values_si;
  const std::vector<double>& angle = trial.data.at("angle").values_si;
  // Rows in time order (stable: a file may list them per fillet); each fillet's first row is
  // where it appears.
  std::vector<std::size_t> order(trial.data.rows());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::stable_sort(order.begin(), order.end(),
                   [&time](std::size_t a, std::size_t b) { return time[a] < time[b]; });
  std::map<long long, std::size_t> index_of_fillet;
  for (const std::size_t row : order) {
    const long long number = std::llround(fillet[row]);
    auto [found, added] = index_of_fillet.try_emplace(number, params.first_poses.size());
    if (added) params.first_poses.push_back({x[row], y[row], angle[row]});
    params.samples.push_back({found->second, time[row]});
  }
  const int runs = settings_.ensemble_runs;
  const std::vector<model_tests::BeltPose> measured_first = params.first_poses;
  std::array<double, 3> jitter_sigma{0.0, 0.0, 0.0};
  if (runs > 1) {
    const std::string_view unknown = line_tracks_channel_without_noise(dataset);
    if (!unknown.empty()) {
      throw std::runtime_error(
          "the line-tracks ensemble jitters the first poses by the noise, and the dataset gives "
          "none for '" +
          std::string(unknown) + "'");
    }
    jitter_sigma = {dataset.noise_si.find("x")->second, dataset.noise_si.find("y")->second,
                    dataset.noise_si.find("angle")->second};
  }
  std::mt19937_64 random(trial_seed(settings_.seed, trial.id));
  std::normal_distribution<double> standard_normal(0.0, 1.0);
  // Sums over the members of each channel's value and square, per row (ensemble_spread).
  std::array<std::vector<double>, 3> sum, sum_sq;
  for (auto& s : sum) s.assign(order.size(), 0.0);
  for (auto& s : sum_sq) s.assign(order.size(), 0.0);
  constexpr double kTurn = 2.0 * std::numbers::pi;
  for (int member = 0; member < runs; ++member) {
    if (runs > 1) {
      for (std::size_t f = 0; f < measured_first.size(); ++f) {
        params.first_poses[f].x_m =
            measured_first[f].x_m + jitter_sigma[0] * standard_normal(random);
        params.first_poses[f].y_m =
            measured_first[f].y_m + jitter_sigma[1] * standard_normal(random);
        params.first_poses[f].yaw_rad =
            measured_first[f].yaw_rad + jitter_sigma[2] * standard_normal(random);
      }
    }
    const std::vector<model_tests::BeltPose> poses =
        on_line ? run_on_line(trial, params.first_poses, params.samples)
                : model_tests::run_belt_tracks(params).poses;
    if (poses.size() != order.size()) {
      throw std::runtime_error("the line-tracks model became unstable after " +
                               std::to_string(poses.size()) + " of " +
                               std::to_string(order.size()) + " rows");
    }
    for (std::size_t k = 0; k < order.size(); ++k) {
      const std::size_t row = order[k];
      const model_tests::BeltPose& pose = poses[k];
      const std::array<double, 3> value{
          pose.x_m, pose.y_m,
          pose.yaw_rad + kTurn * std::round((angle[row] - pose.yaw_rad) / kTurn)};
      for (std::size_t c = 0; c < 3; ++c) {
        sum[c][row] += value[c];
        sum_sq[c][row] += value[c] * value[c];
      }
    }
  }
  static constexpr std::array<std::string_view, 3> kChannels{"x", "y", "angle"};
  Table table;
  const auto n = static_cast<double>(runs);
  for (std::size_t c = 0; c < 3; ++c) {
    const Unit unit = trial.data.at(kChannels[c]).unit;
    std::vector<double> mean(order.size());
    for (std::size_t row = 0; row < order.size(); ++row) mean[row] = sum[c][row] / n;
    table.channels.push_back({std::string(kChannels[c]), unit, mean});
  }
  if (runs > 1) {
    for (std::size_t c = 0; c < 3; ++c) {
      std::vector<double> spread(order.size());
      for (std::size_t row = 0; row < order.size(); ++row) {
        spread[row] = ensemble_spread(sum[c][row], sum_sq[c][row], n);
      }
      table.channels.push_back(
          {std::string(kChannels[c]) + "_spread", trial.data.at(kChannels[c]).unit, spread});
    }
  }
  table.lines = trial.data.lines;
  return table;
}

std::string model_effects(const dem::ModelSpec& spec) {
  const dem::LawRegistry& registry = dem::LawRegistry::builtin();
  std::vector<std::string> effects;
  const auto add = [&effects](const dem::LawSpec& law, bool is_effect) {
    if (!is_effect) return;
    std::string text = law_text(law);
    if (std::find(effects.begin(), effects.end(), text) == effects.end()) {
      effects.push_back(std::move(text));
    }
  };
  for (const dem::InteractionSpec& interaction : spec.interactions) {
    for (const dem::LawSpec& law : interaction.contact_laws) {
      const auto* info = registry.find_contact_law(law.name);
      add(law, info != nullptr && info->is_effect());
    }
    if (interaction.bond_law) {
      const auto* info = registry.find_bond_law(interaction.bond_law->name);
      add(*interaction.bond_law, info != nullptr && info->is_effect());
    }
  }
  if (effects.empty()) return "none";
  std::string joined;
  for (const std::string& effect : effects) joined += (joined.empty() ? "" : "; ") + effect;
  return joined;
}

std::unique_ptr<TrialModel> make_twin_model(ExperimentType experiment,
                                            const model_tests::CommonParams& common,
                                            const TwinSettings& settings) {
  switch (experiment) {
    case ExperimentType::kCompress:
      return std::make_unique<TwinCompressModel>(common);
    case ExperimentType::kSlide:
      return std::make_unique<TwinSlideModel>(common, settings.slide);
    case ExperimentType::kDrop:
    case ExperimentType::kSettle:
      return std::make_unique<TwinDropModel>(common);
    case ExperimentType::kBend:
      return std::make_unique<TwinBendModel>(common);
    case ExperimentType::kLineTracks:
      return std::make_unique<TwinLineTracksModel>(common, settings.line_tracks);
    case ExperimentType::kBulkFlow:
      return std::make_unique<TwinBulkFlowModel>(common);
  }
  throw std::invalid_argument("the twin has no model of experiment type " +
                              std::to_string(static_cast<int>(experiment)));
}

}  // namespace fl::workbench
