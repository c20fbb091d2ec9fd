// The drop experiment in the workbench: the twin tracks a flat fillet's height through free
// fall, impact and settling; the generator's hidden bond effects make the base model fail
// while the truth model sits at the noise level. A drop of the 7 mm fillet (61 spheres) runs in
// about 0.2 s.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "fl/twin/model_tests/model_tests.hpp"
#include "fl/workbench/generator.hpp"
#include "fl/workbench/twin_models.hpp"
#include "workbench_test_support.hpp"

namespace fl::workbench {
namespace {

using test::base_model;
using test::generate_drop;

constexpr double kGravityMps2 = 9.81;  // appendix B

TEST(DropTwin, FallsAsABodyInFreeFallUntilItMeetsThePlate) {
  model_tests::DropParams params;
  params.common = base_model();
  params.drop_height_m = 0.1;
  params.speed_m_per_s = 0.0;
  params.orientation = Eigen::Quaterniond::Identity();
  const double impact_s = std::sqrt(2.0 * params.drop_height_m / kGravityMps2);
  for (double t = 0.0; t < impact_s; t += 0.005) params.height_times_s.push_back(t);
  const model_tests::DropResult result = model_tests::run_drop(params);
  ASSERT_EQ(result.centre_height_m.size(), params.height_times_s.size());
  const double start_m = result.centre_height_m.front();
  // The centre starts above the lowest point by more than a sphere radius and by less than the
  // 32 mm thickness of the fillet.
  EXPECT_GT(start_m - params.drop_height_m, params.common.sub_particle_radius_m);
  EXPECT_LT(start_m - params.drop_height_m, 0.032);
  // No contact before the impact: h0 - g t^2 / 2. Sampling at the nearest step and the
  // integrator's first-order position error each stay below the impact speed times a step.
  const double tolerance_m =
      std::sqrt(2.0 * kGravityMps2 * params.drop_height_m) * result.timestep_s;
  for (std::size_t k = 0; k < params.height_times_s.size(); ++k) {
    const double t = params.height_times_s[k];
    EXPECT_NEAR(result.centre_height_m[k], start_m - 0.5 * kGravityMps2 * t * t, tolerance_m)
        << "at " << t << " s";
  }
}

TEST(DropTwin, LandsAndComesToRestOnThePlate) {
  const Dataset data = generate_drop("none").dataset;
  TwinDropModel model(base_model());
  const Trial& trial = data.trials.front();  // 50 mm
  ASSERT_EQ(trial.id, "h50mm");
  const std::vector<double> height = model.run(data, trial).at("height").values_si;
  ASSERT_EQ(height.size(), trial.data.rows());
  const double offset_m = height.front() - 0.05;  // centre above the lowest point
  // Never through the plate: the lowest spheres' centres stay above half their 7 mm radius,
  // so the fillet's centre (above them) does too.
  for (const double h : height) EXPECT_GT(h, 0.5 * 0.007);
  // A 1 m/s landing breaks no appendix B bond (thesis 4.2.1: the fillet survives 10 m/s), so
  // 0.4 s later it lies flat as it fell: its centre within 1 mm (two noise sigmas) of the
  // height it had above its lowest point.
  EXPECT_NEAR(height.back(), offset_m, 0.001);
}

TEST(DropTwin, PhasesFollowTheDropHeight) {
  const Dataset data = generate_drop("none").dataset;
  const Trial& trial = data.trials[1];  // 100 mm: the impact after sqrt(0.2 / 9.81) = 143 ms
  const std::vector<std::string> phase = phases_of(ExperimentType::kDrop, trial);
  const std::vector<double>& t = trial.data.at("time").values_si;
  for (std::size_t k = 0; k < phase.size(); ++k) {
    const char* expected = t[k] < 0.1428 ? "fall" : (t[k] < 0.2428 ? "landing" : "settling");
    EXPECT_EQ(phase[k], expected) << "at " << t[k] << " s";
  }
}

TEST(DropTwin, RefusesATrialItCannotReproduce) {
  Dataset data = generate_drop("none").dataset;
  TwinDropModel model(base_model());
  Trial trial = data.trials.front();
  trial.conditions.erase("drop_height");
  try {
    (void)model.run(data, trial);
    FAIL() << "a drop without its height ran";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("drop_height"), std::string::npos) << error.what();
  }
  data.experiment = ExperimentType::kSlide;
  EXPECT_THROW((void)model.run(data, data.trials.front()), std::runtime_error);
}

TEST(SettleTwin, ComesToRestWhereItWasReleased) {
  // A settle trial: released at rest lying flat, tracked every 5 ms for 0.5 s.
  Dataset data;
  data.experiment = ExperimentType::kSettle;
  Trial trial;
  trial.id = "s";
  trial.conditions["variant"] = std::string("172x72x32");
  std::vector<double> t;
  for (int row = 0; row <= 100; ++row) t.push_back(0.005 * row);
  trial.data.channels = {{"time", *find_unit("s"), t},
                         {"height", *find_unit("mm"), std::vector<double>(t.size())}};
  trial.data.lines.resize(t.size());
  data.trials.push_back(trial);
  TwinDropModel model(base_model());
  const std::vector<double> height = model.run(data, trial).at("height").values_si;
  ASSERT_EQ(height.size(), t.size());
  // Released with its lowest point 1 mm over the plate: it falls that millimetre and sags a
  // fraction of one under its own weight, so every height stays within 2 mm below the first
  // and never above it by more than the integrator's rounding.
  for (const double h : height) {
    EXPECT_LT(h, height.front() + 1e-6);
    EXPECT_GT(h, height.front() - 0.002);
  }
  // At rest after 0.5 s: the last 0.1 s moves by under 0.2 mm (under half the camera noise).
  for (std::size_t k = 80; k < height.size(); ++k) EXPECT_NEAR(height[k], height.back(), 2e-4);
  // A settle trial needs no drop_height: the same model refuses a drop without one.
  data.experiment = ExperimentType::kDrop;
  EXPECT_THROW((void)model.run(data, trial), std::runtime_error);
}

TEST(DropGenerator, DatasetRoundTripsThroughTheMeasurementFormat) {
  const GeneratedDataset made = generate_drop("none");
  const auto folder = std::filesystem::temp_directory_path() / "fl_drop_round_trip";
  std::filesystem::remove_all(folder);
  write_dataset(made.dataset, folder);
  const Dataset loaded = load_dataset(folder);
  EXPECT_EQ(loaded.experiment, ExperimentType::kDrop);
  ASSERT_EQ(loaded.trials.size(), 3U);  // the drop default: 50, 100, 200 mm
  EXPECT_NEAR(loaded.noise_si.at("height"), test::kHeightNoiseMm * 1e-3, 1e-15);
  for (std::size_t t = 0; t < loaded.trials.size(); ++t) {
    const Trial& a = made.dataset.trials[t];
    const Trial& b = loaded.trials[t];
    EXPECT_EQ(a.id, b.id);
    EXPECT_EQ(a.conditions, b.conditions);
    EXPECT_NEAR(std::get<double>(b.conditions.at("drop_height")), 0.05 * std::pow(2.0, t), 1e-15);
    const auto& x = a.data.at("height").values_si;
    const auto& y = b.data.at("height").values_si;
    ASSERT_EQ(x.size(), y.size());
    // Written in millimetres with 17 significant digits and read back: a rounding at most.
    for (std::size_t k = 0; k < x.size(); ++k) EXPECT_NEAR(x[k], y[k], 1e-15);
  }
  std::filesystem::remove_all(folder);
}

TEST(DropGenerator, EveryHiddenEffectFailsTheBaseModelAndNotTheTruth) {
  for (const std::string& effect : drop_effect_candidates()) {
    SCOPED_TRACE(effect);
    const GeneratedDataset made = generate_drop(effect);
    ASSERT_EQ(made.truth.law, effect);
    // The truth leaves only the noise: RMS/sigma over ~300 Gaussian heights is 1 within about
    // 1/sqrt(600) = 0.04; 0.15 is under four of those.
    EXPECT_NEAR(test::height_score(made.dataset, made.truth), 1.0, 0.15);
    // The weakest effect in the generator's ranges moves the height by 2.5 mm RMS: 5 sigmas,
    // where a 70 % fall of the error is possible at all (to the noise: 1 - 1/5 = 80 %).
    EXPECT_GT(test::height_score(made.dataset, {}), 4.5);
  }
}

TEST(DropGenerator, WithoutAHiddenEffectTheBaseModelSitsAtTheNoise) {
  const GeneratedDataset made = generate_drop("none");
  EXPECT_TRUE(made.truth.law.empty());
  EXPECT_NEAR(test::height_score(made.dataset, {}), 1.0, 0.15);
}

}  // namespace
}  // namespace fl::workbench
