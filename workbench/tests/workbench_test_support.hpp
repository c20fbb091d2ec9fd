// Fixtures shared by the workbench tests: the base DEM model of the compression, slide and drop
// tests, datasets generated with a hidden effect, and the score a model with a given effect gets on
// them.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <string_view>

#include "fl/twin/dem/config.hpp"
#include "fl/workbench/compare.hpp"
#include "fl/workbench/diagnose.hpp"
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

// Onset-angle noise of the generated slide datasets (the generator's default, an
// inclinometer's repeatability), in degrees.
inline constexpr double kAngleNoiseDeg = 0.3;

// A slide dataset (two variants, dry and wet, 10 repetitions) with `effect` hidden in it.
inline GeneratedDataset generate_slide(const std::string& effect, std::uint64_t seed = 3) {
  GeneratorOptions options;
  options.experiment = ExperimentType::kSlide;
  options.seed = seed;
  options.effect = effect;
  options.angle_noise_deg = kAngleNoiseDeg;
  options.common = base_model();
  return generate_dataset(options);
}

// The overall onset-angle score of the slide twin with the contact `effect` added.
inline double angle_score(const Dataset& data, const HiddenEffect& effect) {
  model_tests::CommonParams common = base_model();
  common.base_spec = with_contact_effect(common.base_spec, effect);
  TwinSlideModel model(common);
  return compare(data, model).overall("onset_angle").score;
}

// Height noise of the generated drop datasets (the generator's default, a 200 fps camera
// tracking the fillet), in millimetres.
inline constexpr double kHeightNoiseMm = 0.5;

// A drop dataset (50, 100 and 200 mm, flat) with `effect` hidden in it.
inline GeneratedDataset generate_drop(const std::string& effect, std::uint64_t seed = 3) {
  GeneratorOptions options;
  options.experiment = ExperimentType::kDrop;
  options.seed = seed;
  options.effect = effect;
  options.height_noise_mm = kHeightNoiseMm;
  options.common = base_model();
  return generate_dataset(options);
}

// The overall height score of the drop twin with the bond `effect` added.
inline double height_score(const Dataset& data, const HiddenEffect& effect) {
  model_tests::CommonParams common = base_model();
  common.base_spec = with_bond_effect(common.base_spec, effect);
  TwinDropModel model(common);
  return compare(data, model).overall("height").score;
}

// Angle noise of the generated bend datasets (the generator's default: an angle read off a
// side photo), in degrees.
inline constexpr double kBendNoiseDeg = 1.0;

// A bend dataset (the three variants over the edge by 60, 80 and 100 mm, 10 repetitions) with
// `effect` hidden in it.
inline GeneratedDataset generate_bend(const std::string& effect, std::uint64_t seed = 3) {
  GeneratorOptions options;
  options.experiment = ExperimentType::kBend;
  options.seed = seed;
  options.effect = effect;
  options.bend_angle_noise_deg = kBendNoiseDeg;
  options.common = base_model();
  return generate_dataset(options);
}

// The overall bend-angle score of the bend twin with the bond `effect` added.
inline double bend_score(const Dataset& data, const HiddenEffect& effect) {
  model_tests::CommonParams common = base_model();
  common.base_spec = with_bond_effect(common.base_spec, effect);
  TwinBendModel model(common);
  return compare(data, model).overall("bend_angle").score;
}

// Issue 6's proof on a dataset made with a hidden effect: diagnose ranks that effect first and
// proposes it, and adding it as fitted makes the error fall by 70 % or more and end within
// twice the noise. `score(data, effect)`: the overall score (RMS over noise) of the channel.
template <typename Score>
void expect_hidden_effect_found(const GeneratedDataset& made, std::string_view channel,
                                const Score& score) {
  SCOPED_TRACE(made.truth.law);
  const Dataset& data = made.dataset;
  const Diagnosis diagnosis = diagnose(data, base_model(), candidates_for(data.experiment));
  ASSERT_FALSE(diagnosis.ranked.empty());
  EXPECT_EQ(diagnosis.channel, channel);
  EXPECT_EQ(diagnosis.ranked.front().law, made.truth.law) << diagnosis.verdict;
  EXPECT_TRUE(diagnosis.ranked.front().proposed) << diagnosis.verdict;
  const double before = score(data, HiddenEffect{});
  const double after = score(data, proposed_effect(diagnosis));
  EXPECT_LE(after, 0.3 * before) << "before " << before << ", after " << after;
  EXPECT_LE(after, 2.0) << "in noise sigmas";
}

// The other half of the proof: residuals at the noise level get no effect proposed.
inline void expect_nothing_proposed(const Dataset& data) {
  const Diagnosis diagnosis = diagnose(data, base_model(), candidates_for(data.experiment));
  for (const CandidateResult& result : diagnosis.ranked) EXPECT_FALSE(result.proposed);
  EXPECT_TRUE(proposed_effect(diagnosis).law.empty());
  EXPECT_NE(diagnosis.verdict.find("nothing missing"), std::string::npos) << diagnosis.verdict;
}

}  // namespace fl::workbench::test
