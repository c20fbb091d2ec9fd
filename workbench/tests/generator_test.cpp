// The hidden-effect generator: datasets round-trip through the measurement format, a hidden
// effect makes the base model fail while the truth model sits at the noise level, and a
// dataset without an effect leaves the base model at the noise level.
#include "fl/workbench/generator.hpp"

#include <gtest/gtest.h>

#include <set>

#include "workbench_test_support.hpp"

namespace fl::workbench {
namespace {

using test::base_model;
using test::generate;
using test::kNoiseN;

TEST(Generator, DatasetRoundTripsThroughTheMeasurementFormat) {
  const GeneratedDataset made = generate("none");
  const auto folder = std::filesystem::temp_directory_path() / "fl_generator_round_trip";
  std::filesystem::remove_all(folder);
  write_dataset(made.dataset, folder);
  write_truth(made.truth, folder.string() + ".truth.yaml");
  const Dataset loaded = load_dataset(folder);
  ASSERT_EQ(loaded.trials.size(), made.dataset.trials.size());
  EXPECT_DOUBLE_EQ(loaded.noise_si.at("force"), kNoiseN);
  for (std::size_t t = 0; t < loaded.trials.size(); ++t) {
    const Trial& a = made.dataset.trials[t];
    const Trial& b = loaded.trials[t];
    EXPECT_EQ(a.id, b.id);
    EXPECT_DOUBLE_EQ(std::get<double>(a.conditions.at("rate")),
                     std::get<double>(b.conditions.at("rate")));
    for (const char* name : {"time", "displacement", "force"}) {
      const auto& x = a.data.at(name).values_si;
      const auto& y = b.data.at(name).values_si;
      ASSERT_EQ(x.size(), y.size());
      // Written in the file's unit (mm) and read back: a rounding of the unit factor at most.
      for (std::size_t k = 0; k < x.size(); ++k) EXPECT_NEAR(x[k], y[k], 1e-15);
    }
  }
  std::filesystem::remove_all(folder);
  std::filesystem::remove(folder.string() + ".truth.yaml");
}

TEST(Generator, EveryHiddenEffectFailsTheBaseModelAndNotTheTruth) {
  for (const std::string& effect : compress_effect_candidates()) {
    SCOPED_TRACE(effect);
    const GeneratedDataset made = generate(effect);
    ASSERT_EQ(made.truth.law, effect);
    // The truth model leaves only the noise: RMS/sigma of ~200 Gaussian samples is 1 within
    // about 0.05 per sigma; 0.15 is three of those.
    EXPECT_NEAR(test::force_score(made.dataset, made.truth), 1.0, 0.15);
    EXPECT_GT(test::force_score(made.dataset, {}), 3.0);
  }
}

TEST(Generator, WithoutAHiddenEffectTheBaseModelSitsAtTheNoise) {
  const GeneratedDataset made = generate("none");
  EXPECT_TRUE(made.truth.law.empty());
  EXPECT_NEAR(test::force_score(made.dataset, {}), 1.0, 0.15);
}

TEST(Generator, RandomChoiceIsSeededAndCoversTheCandidates) {
  GeneratorOptions options;
  options.common = base_model();
  options.trials = 1;
  std::set<std::string> chosen;
  for (std::uint64_t seed = 1; seed <= 8; ++seed) {
    options.seed = seed;
    const GeneratedDataset a = generate_dataset(options);
    const GeneratedDataset b = generate_dataset(options);
    EXPECT_EQ(a.truth.law, b.truth.law);
    EXPECT_EQ(a.truth.parameters, b.truth.parameters);
    chosen.insert(a.truth.law);
  }
  // 8 fair draws of 2 candidates miss one with probability 2 / 2^8: seeded, so fixed here.
  EXPECT_EQ(chosen.size(), compress_effect_candidates().size());
}

TEST(Generator, RefusesWhatItCannotMake) {
  GeneratorOptions options;
  options.effect = "magic";
  EXPECT_THROW((void)generate_dataset(options), std::invalid_argument);
  options.effect = "none";
  // Settle: no effect in reach moves a fillet released at rest by what a camera sees; bulk flow
  // is not generated. Each refusal says which types it makes.
  for (const ExperimentType type : {ExperimentType::kSettle, ExperimentType::kBulkFlow}) {
    options.experiment = type;
    try {
      (void)generate_dataset(options);
      ADD_FAILURE() << to_string(type) << " was generated";
    } catch (const std::invalid_argument& error) {
      EXPECT_NE(std::string(error.what()).find(to_string(type)), std::string::npos) << error.what();
    }
  }
  // A bend effect is not a compress one.
  options.experiment = ExperimentType::kBend;
  options.effect = "bpm_plastic";
  EXPECT_THROW((void)generate_dataset(options), std::invalid_argument);
}

}  // namespace
}  // namespace fl::workbench
