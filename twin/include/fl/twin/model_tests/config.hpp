// config/model_tests.yaml: the setups of the model tests (plate sizes, speeds, angles, sweep
// ranges), read strictly with fl::YamlReader like config/dem.yaml: every problem is reported
// with file:line:column and key path, all at once, as one fl::ConfigError.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "fl/twin/model_tests/model_tests.hpp"

namespace fl::model_tests {

struct ModelTestsConfig {
  // common
  double sub_particle_radius_m = 0.007;
  std::size_t variant = 2;
  std::filesystem::path fillet_mesh_stl;  // as written; resolve_path() makes it usable
  double rayleigh_fraction = 0.15;
  double bond_step_fraction = 0.2;
  std::uint32_t seed = 1;

  // settle
  SettleParams settle;
  double basic_drop_height_m = 0.1;
  double basic_duration_s = 1.0;
  double no_shear_stiffness_n_per_m3 = 1.0;
  std::vector<double> restitution_sweep;

  // bend
  BendParams bend;
  std::vector<double> bend_stiffness_factors;  // x appendix-B stiffness (both together)

  // slide
  SlideParams slide;
  std::vector<double> friction_sweep;
  std::vector<double> surface_energy_sweep_j_per_m2;

  // compress
  CompressParams compress;

  // impact
  DropParams impact_drop;
  std::vector<double> impact_speeds_m_per_s;
  std::vector<Stiffness> impact_stiffness_sets;
  int impact_orientations = 3;

  // drop angle
  DropParams angle_drop;
  int angle_samples = 200;

  // scaling
  DropParams scaling_drop;
  std::vector<double> scales;
  std::vector<double> timestep_factors;  // x bond critical step, at scale 1

  // doe (appendix C)
  std::vector<double> doe_normal_levels_n_per_m3;
  std::vector<double> doe_shear_levels_n_per_m3;
  double doe_duration_s = 1.5;
  bool doe_bend = true;
  double doe_bend_duration_s = 1.0;
};

// Throws fl::ConfigError listing every problem.
ModelTestsConfig load_model_tests_config(const std::filesystem::path& yaml_file);
ModelTestsConfig load_model_tests_config_text(std::string_view yaml_text,
                                              std::string_view source_name);

// Copies the common settings (radius, variant, fractions, seed) into every test's params.
void apply_common(ModelTestsConfig& config, const CommonParams& common);

}  // namespace fl::model_tests
