// Fixtures shared by the workbench tests: the base DEM model of the compression tests, datasets
// generated with a hidden effect, and the score a model with a given effect gets on them.
#pragma once

#include <cstdint>
#include <string>

#include "fl/twin/dem/config.hpp"
#include "fl/workbench/compare.hpp"
#include "fl/workbench/generator.hpp"
#include "fl/workbench/twin_models.hpp"

namespace fl::workbench::test {

// Force noise of the generated datasets: about 2 % of the ~0.6 N peak force.
inline constexpr double kNoiseN = 0.01;

// The appendix B model at the fast 7 mm sub-particle size of the model tests.
inline model_tests::CommonParams base_model() {
  model_tests::CommonParams common;
  common.sub_particle_radius_m = 0.007;
  common.base_spec = dem::appendix_b_model_spec();
  return common;
}

// A compression dataset with `effect` hidden in it ("none": without), on the base model.
inline GeneratedDataset generate(const std::string& effect, std::uint64_t seed = 3) {
  GeneratorOptions options;
  options.seed = seed;
  options.effect = effect;
  options.force_noise_n = kNoiseN;
  options.common = base_model();
  return generate_dataset(options);
}

// The overall force score of the base model with `effect` added ({}: the base model itself).
inline double force_score(const Dataset& data, const HiddenEffect& effect) {
  model_tests::CommonParams common = base_model();
  common.base_spec = with_bond_effect(common.base_spec, effect);
  TwinCompressModel model(common);
  return compare(data, model).overall("force").score;
}

}  // namespace fl::workbench::test
