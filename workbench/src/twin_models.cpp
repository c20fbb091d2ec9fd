#include "fl/workbench/twin_models.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "fl/twin/dem/config.hpp"
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
                            std::string fallback) {
  const auto found = conditions.find(name);
  return found == conditions.end() ? fallback : std::get<std::string>(found->second);
}

// model_tests' variant index (thesis_fillet_variants order: each size left, then mirrored)
// from the trial's variant label and mirrored flag; the absent ones keep the base model's.
std::size_t slide_variant(const Conditions& conditions, std::size_t base_variant) {
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

}  // namespace

TwinCompressModel::TwinCompressModel(model_tests::CommonParams common)
    : common_(std::move(common)) {}

std::string TwinCompressModel::describe() const {
  const dem::ModelSpec spec = model_tests::make_spec(common_);
  std::ostringstream text;
  text << "DEM twin, bonded block of " << common_.sub_particle_radius_m * 1e3
       << " mm sub-particles; bond law";
  for (const dem::InteractionSpec& interaction : spec.interactions) {
    if (!interaction.bond_law) continue;
    text << " " << interaction.bond_law->name << " (";
    bool first = true;
    for (const auto& [key, value] : interaction.bond_law->parameters) {
      text << (first ? "" : ", ") << key << " " << value;
      first = false;
    }
    text << ")";
    break;
  }
  return text.str();
}

Table TwinCompressModel::run(const Dataset& dataset, const Trial& trial) {
  if (dataset.experiment != ExperimentType::kCompress) {
    throw std::runtime_error("the compress model runs compress datasets, not " +
                             std::string(to_string(dataset.experiment)));
  }
  const std::vector<double>& time_s = trial.data.at("time").values_si;
  const std::vector<double>& displacement_m = trial.data.at("displacement").values_si;
  model_tests::CompressParams params;
  params.common = common_;
  const double r = common_.sub_particle_radius_m;
  params.block_nx = spheres_along(trial.conditions, "sample_side", r, params.block_nx);
  params.block_ny = params.block_nx;
  params.block_nz = spheres_along(trial.conditions, "sample_height", r, params.block_nz);
  params.profile_time_s = time_s;
  for (const double d : displacement_m) params.profile_travel_m.push_back(d - displacement_m[0]);
  const model_tests::CompressResult result = model_tests::run_compress(params);
  if (result.series.size() != time_s.size()) {
    throw std::runtime_error("the compress model returned " + std::to_string(result.series.size()) +
                             " samples for " + std::to_string(time_s.size()) + " rows");
  }
  Table table;
  Channel force{"force", trial.data.at("force").unit, {}};
  for (const auto& sample : result.series) force.values_si.push_back(sample.plate_force_n);
  table.channels.push_back(std::move(force));
  table.lines = trial.data.lines;
  return table;
}

TwinSlideModel::TwinSlideModel(model_tests::CommonParams common, SlideSettings settings)
    : common_(std::move(common)), settings_(settings) {
  if (common_.base_spec.materials.empty()) common_.base_spec = dem::appendix_b_model_spec();
}

std::string TwinSlideModel::describe() const {
  std::ostringstream text;
  text << "DEM twin, slide of a flexible fillet of " << common_.sub_particle_radius_m * 1e3
       << " mm sub-particles; fillet-equipment laws:";
  const std::uint32_t equipment = model_tests::equipment_type(common_.base_spec);
  for (const dem::InteractionSpec& interaction : common_.base_spec.interactions) {
    if (!model_tests::is_fillet_with(interaction, equipment)) continue;
    for (const dem::LawSpec& law : interaction.contact_laws) text << " " << law_text(law);
    break;  // fillet types A and B share the chain
  }
  return text.str();
}

Table TwinSlideModel::run(const Dataset& dataset, const Trial& trial) {
  if (dataset.experiment != ExperimentType::kSlide) {
    throw std::runtime_error("the slide model runs slide datasets, not " +
                             std::string(to_string(dataset.experiment)));
  }
  const Channel& measured = trial.data.at("onset_angle");
  model_tests::SlideParams params;
  params.common = common_;
  params.common.variant = slide_variant(trial.conditions, common_.variant);
  params.tilt_rate_deg_per_s = settings_.tilt_rate_deg_per_s;
  params.max_angle_deg = settings_.max_angle_deg;
  const bool wet = label_condition(trial.conditions, "surface", "dry") == "wet";
  dem::ModelSpec& spec = params.common.base_spec;
  const std::uint32_t equipment = model_tests::equipment_type(spec);
  // run_slide sets the fillet-equipment coulomb friction and jkr energy itself: hand it the
  // spec's own, so the spec is the one source of the model.
  std::optional<double> friction, surface_energy;
  for (dem::InteractionSpec& interaction : spec.interactions) {
    if (!model_tests::is_fillet_with(interaction, equipment)) continue;
    std::vector<dem::LawSpec>& laws = interaction.contact_laws;
    if (!wet) std::erase_if(laws, [](const dem::LawSpec& law) { return law.name == "wet_film"; });
    const auto coulomb = std::find_if(
        laws.begin(), laws.end(), [](const dem::LawSpec& law) { return law.name == "coulomb"; });
    const auto static_kinetic = std::find_if(laws.begin(), laws.end(), [](const dem::LawSpec& law) {
      return law.name == "static_kinetic_friction";
    });
    if (coulomb != laws.end()) {
      friction = coulomb->parameters.at("friction_coefficient");
    } else if (static_kinetic != laws.end()) {
      // static_kinetic_friction replaced coulomb, but run_slide needs a coulomb to set: one at
      // the static coefficient after it never binds (the force is already limited to that).
      friction = static_kinetic->parameters.at("static_friction_coefficient");
      laws.insert(static_kinetic + 1,
                  dem::LawSpec{"coulomb", {{"friction_coefficient", *friction}}});
    }
    for (const dem::LawSpec& law : laws) {
      if (law.name == "jkr") surface_energy = law.parameters.at("surface_energy_j_per_m2");
    }
  }
  if (!friction || !surface_energy) {
    throw std::runtime_error(
        "the slide model needs a friction law and jkr between fillet and equipment");
  }
  params.friction_coefficient = *friction;
  params.surface_energy_j_per_m2 = *surface_energy;
  const model_tests::SlideResult result = model_tests::run_slide(params);
  if (!result.slide_angle_deg) {
    std::ostringstream reason;
    reason << "the fillet has not slid by " << settings_.max_angle_deg << " deg";
    throw std::runtime_error(reason.str());
  }
  constexpr double kRadPerDeg = std::numbers::pi / 180.0;
  Table table;
  table.channels.push_back(
      {"onset_angle", measured.unit,
       std::vector<double>(trial.data.rows(), *result.slide_angle_deg * kRadPerDeg)});
  table.lines = trial.data.lines;
  return table;
}

std::unique_ptr<TrialModel> make_twin_model(ExperimentType experiment,
                                            const model_tests::CommonParams& common) {
  switch (experiment) {
    case ExperimentType::kCompress:
      return std::make_unique<TwinCompressModel>(common);
    case ExperimentType::kSlide:
      return std::make_unique<TwinSlideModel>(common);
    default:
      throw std::invalid_argument("the twin does not reproduce " +
                                  std::string(to_string(experiment)) + " datasets yet");
  }
}

}  // namespace fl::workbench
