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

// Noise of the generated datasets, the generator's defaults. Force: about 2 % of the ~0.6 N
// peak force of the compression block.
inline constexpr double kNoiseN = 0.01;
// Onset angle of the slide: an inclinometer's repeatability, in degrees.
inline constexpr double kAngleNoiseDeg = 0.3;
// Height of a drop: a 200 fps camera tracking the fillet, in millimetres.
inline constexpr double kHeightNoiseMm = 0.5;
// Bend angle: an angle read off a side photo, in degrees.
inline constexpr double kBendNoiseDeg = 1.0;

// The appendix B model at the fast 7 mm sub-particle size of the model tests.
inline model_tests::CommonParams base_model() {
  model_tests::CommonParams common;
  common.sub_particle_radius_m = 0.007;
  common.base_spec = dem::appendix_b_model_spec();
  return common;
}

// A dataset of the generator's default trials of `type` with `effect` hidden in it ("none":
// without), on the base model.
inline GeneratedDataset generate_of(ExperimentType type, const std::string& effect,
                                    std::uint64_t seed) {
  GeneratorOptions options;
  options.experiment = type;
  options.seed = seed;
  options.effect = effect;
  options.force_noise_n = kNoiseN;
  options.angle_noise_deg = kAngleNoiseDeg;
  options.height_noise_mm = kHeightNoiseMm;
  options.bend_angle_noise_deg = kBendNoiseDeg;
  options.common = base_model();
  return generate_dataset(options);
}

// Compression: three loading rates.
inline GeneratedDataset generate(const std::string& effect, std::uint64_t seed = 3) {
  return generate_of(ExperimentType::kCompress, effect, seed);
}
// Slide: two variants, dry and wet, 10 repetitions.
inline GeneratedDataset generate_slide(const std::string& effect, std::uint64_t seed = 3) {
  return generate_of(ExperimentType::kSlide, effect, seed);
}
// Drop: 50, 100 and 200 mm, flat.
inline GeneratedDataset generate_drop(const std::string& effect, std::uint64_t seed = 3) {
  return generate_of(ExperimentType::kDrop, effect, seed);
}
// Bend: the three variants over the edge by 60, 80 and 100 mm, 10 repetitions.
inline GeneratedDataset generate_bend(const std::string& effect, std::uint64_t seed = 3) {
  return generate_of(ExperimentType::kBend, effect, seed);
}

// The overall score (RMS over noise) of `channel` for the twin `Model` on the base model's
// spec with `effect` where the dataset's experiment puts it.
template <typename Model>
double twin_score(const Dataset& data, const HiddenEffect& effect, std::string_view channel) {
  model_tests::CommonParams common = base_model();
  common.base_spec = with_experiment_effect(common.base_spec, data.experiment, effect);
  Model model(common);
  return compare(data, model).overall(channel).score;
}

// The overall scores of the twins with a bond or contact `effect` added ({}: the base model).
inline double force_score(const Dataset& data, const HiddenEffect& effect) {
  return twin_score<TwinCompressModel>(data, effect, "force");
}
inline double angle_score(const Dataset& data, const HiddenEffect& effect) {
  return twin_score<TwinSlideModel>(data, effect, "onset_angle");
}
inline double height_score(const Dataset& data, const HiddenEffect& effect) {
  return twin_score<TwinDropModel>(data, effect, "height");
}
inline double bend_score(const Dataset& data, const HiddenEffect& effect) {
  return twin_score<TwinBendModel>(data, effect, "bend_angle");
}

// Issue 6's proof on a dataset made with a hidden effect: diagnose ranks that effect first and
// proposes it, and adding it as fitted makes the error fall by 70 % or more and end within
// twice the noise. `score(data, effect)`: the overall score (RMS over noise) of the channel.
// Returns the diagnosis, for what a test checks beyond the proof.
template <typename Score>
Diagnosis expect_hidden_effect_found(const GeneratedDataset& made, std::string_view channel,
                                     const Score& score) {
  SCOPED_TRACE(made.truth.law);
  const Dataset& data = made.dataset;
  Diagnosis diagnosis = diagnose(data, base_model(), candidates_for(data.experiment));
  if (diagnosis.ranked.empty()) {
    ADD_FAILURE() << "no candidate ranked: " << diagnosis.verdict;
    return diagnosis;
  }
  EXPECT_EQ(diagnosis.channel, channel);
  EXPECT_EQ(diagnosis.ranked.front().law, made.truth.law) << diagnosis.verdict;
  EXPECT_TRUE(diagnosis.ranked.front().proposed) << diagnosis.verdict;
  const double before = score(data, HiddenEffect{});
  const double after = score(data, proposed_effect(diagnosis));
  EXPECT_LE(after, 0.3 * before) << "before " << before << ", after " << after;
  EXPECT_LE(after, 2.0) << "in noise sigmas";
  return diagnosis;
}

// The other half of the proof: residuals at the noise level get no effect proposed. Returns
// the diagnosis.
inline Diagnosis expect_nothing_proposed(const Dataset& data) {
  Diagnosis diagnosis = diagnose(data, base_model(), candidates_for(data.experiment));
  for (const CandidateResult& result : diagnosis.ranked) EXPECT_FALSE(result.proposed);
  EXPECT_TRUE(proposed_effect(diagnosis).law.empty());
  EXPECT_NE(diagnosis.verdict.find("nothing missing"), std::string::npos) << diagnosis.verdict;
  return diagnosis;
}

}  // namespace fl::workbench::test
