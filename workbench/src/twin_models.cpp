#include "fl/workbench/twin_models.hpp"

#include <cmath>
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

}  // namespace fl::workbench
