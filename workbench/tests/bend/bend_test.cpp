// The bend experiment in the workbench (thesis 3.4.1, figure 3.11): the twin bends a fillet
// over a table edge under its own weight; the generator's hidden graded stiffness makes the base
// model fail while the truth model sits at the noise level. A bend of the 7 mm fillet runs in
// about 0.1 s.
#include <gtest/gtest.h>

#include <numbers>
#include <string>

#include "fl/workbench/generator.hpp"
#include "fl/workbench/twin_models.hpp"
#include "workbench_test_support.hpp"

namespace fl::workbench {
namespace {

using test::base_model;

constexpr double kRadPerDeg = std::numbers::pi / 180.0;

// One trial of the 172x72x32 fillet over the edge by `overhang_m`, with `rows` repetitions.
Dataset bend_dataset(double overhang_m, int rows = 2) {
  Dataset data;
  data.experiment = ExperimentType::kBend;
  Trial trial;
  trial.id = "b";
  trial.conditions["variant"] = std::string("172x72x32");
  trial.conditions["overhang"] = overhang_m;
  trial.data.channels = {
      {"bend_angle", *find_unit("deg"), std::vector<double>(static_cast<std::size_t>(rows))}};
  trial.data.lines.resize(static_cast<std::size_t>(rows));
  data.trials.push_back(trial);
  return data;
}

double bend_angle_rad(const model_tests::CommonParams& common, const Dataset& data) {
  TwinBendModel model(common);
  const std::vector<double> angle = model.run(data, data.trials.front()).at("bend_angle").values_si;
  EXPECT_EQ(angle.size(), data.trials.front().data.rows());
  EXPECT_EQ(angle.front(), angle.back()) << "the twin is deterministic: one answer per trial";
  return angle.front();
}

TEST(BendTwin, HangsDownAndStifferBondsHoldItHigher) {
  const Dataset data = bend_dataset(0.086);  // half of the 172 mm fillet, as the thesis
  const double base_rad = bend_angle_rad(base_model(), data);
  // Between lying rigid (0) and curling back under the table (beyond 180 deg).
  EXPECT_GT(base_rad, 10.0 * kRadPerDeg);
  EXPECT_LT(base_rad, 180.0 * kRadPerDeg);
  // Thesis 4.1.3: a higher bond stiffness gives a lower bend angle. Ten times stiffer bonds
  // (normal and shear) bend it less.
  model_tests::CommonParams stiff = base_model();
  for (dem::InteractionSpec& interaction : stiff.base_spec.interactions) {
    if (!interaction.bond_law) continue;
    interaction.bond_law->parameters.at("normal_stiffness_n_per_m3") *= 10.0;
    interaction.bond_law->parameters.at("shear_stiffness_n_per_m3") *= 10.0;
  }
  EXPECT_LT(bend_angle_rad(stiff, data), base_rad);
}

TEST(BendTwin, RefusesATrialItCannotReproduce) {
  TwinBendModel model(base_model());
  Dataset data = bend_dataset(0.2);  // beyond the 172 mm fillet's length
  try {
    (void)model.run(data, data.trials.front());
    FAIL() << "a 200 mm overhang of a 172 mm fillet ran";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("overhang"), std::string::npos) << error.what();
  }
  data.trials.front().conditions.erase("overhang");
  EXPECT_THROW((void)model.run(data, data.trials.front()), std::runtime_error);
  data.experiment = ExperimentType::kSlide;
  EXPECT_THROW((void)model.run(data, data.trials.front()), std::runtime_error);
}

TEST(BendGenerator, DatasetRoundTripsThroughTheMeasurementFormat) {
  const GeneratedDataset made = test::generate_bend("none");
  const auto folder = std::filesystem::temp_directory_path() / "fl_bend_round_trip";
  std::filesystem::remove_all(folder);
  write_dataset(made.dataset, folder);
  const Dataset loaded = load_dataset(folder);
  EXPECT_EQ(loaded.experiment, ExperimentType::kBend);
  ASSERT_EQ(loaded.trials.size(), 3U);  // the bend default: one trial per variant
  EXPECT_NEAR(loaded.noise_si.at("bend_angle"), test::kBendNoiseDeg * kRadPerDeg, 1e-15);
  for (std::size_t t = 0; t < loaded.trials.size(); ++t) {
    EXPECT_EQ(made.dataset.trials[t].conditions, loaded.trials[t].conditions);
    EXPECT_NEAR(std::get<double>(loaded.trials[t].conditions.at("overhang")),
                0.06 + 0.02 * static_cast<double>(t), 1e-15);
  }
  std::filesystem::remove_all(folder);
}

TEST(BendGenerator, HiddenGradedStiffnessFailsTheBaseModelAndNotTheTruth) {
  const GeneratedDataset made = test::generate_bend("bpm_graded");
  ASSERT_EQ(made.truth.law, "bpm_graded");
  // The truth leaves only the noise: RMS/sigma over 30 Gaussian angles is 1 within about
  // 1/sqrt(60) = 0.13; 0.4 is three of those.
  EXPECT_NEAR(test::bend_score(made.dataset, made.truth), 1.0, 0.4);
  // The generator's weakest grading (reference 26 mm, square) leaves the base model 7.4 sigmas
  // off on a grid of the range; a 70 % fall to the noise needs more than 3.3.
  EXPECT_GT(test::bend_score(made.dataset, {}), 5.0);
}

TEST(BendGenerator, WithoutAHiddenEffectTheBaseModelSitsAtTheNoise) {
  const GeneratedDataset made = test::generate_bend("none");
  EXPECT_TRUE(made.truth.law.empty());
  EXPECT_NEAR(test::bend_score(made.dataset, {}), 1.0, 0.4);
}

}  // namespace
}  // namespace fl::workbench
