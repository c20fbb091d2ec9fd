// The line-track experiment in the workbench: fillets tracked on a commanded belt. The twin
// carries a fillet at the belt's speed, leaves it behind on a takt harder than its friction
// holds (against a rigid block's lag), refuses what it cannot run; the generator writes the
// belt command logs and its hidden wet film fails the base model while the truth sits at the
// noise; a hidden resting friction, which makes one run's track turn on less than the noise, is
// told apart by an ensemble of runs. Five 7 mm fillets on a belt for 1.2 s take about 0.4 s.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <numbers>
#include <utility>

#include "fl/workbench/generator.hpp"
#include "fl/workbench/twin_models.hpp"
#include "workbench_test_support.hpp"

namespace fl::workbench {
namespace {

using test::base_model;

constexpr double kGravityMps2 = 9.81;        // appendix B
constexpr double kFilletBeltFriction = 0.5;  // appendix B coulomb, fillet-equipment

LineTracksSettings ensemble(int runs, std::uint64_t seed) {
  LineTracksSettings settings;
  settings.ensemble_runs = runs;
  settings.seed = seed;
  return settings;
}

// One fillet appearing at (0, 20 mm, 30 deg) on a belt, tracked every 20 ms for `end_s`.
Trial one_fillet_trial(double end_s) {
  Trial trial;
  trial.id = "one";
  std::vector<double> t, id, x, y, angle;
  for (int frame = 0; frame * 0.02 <= end_s + 1e-9; ++frame) {
    t.push_back(frame * 0.02);
    id.push_back(1.0);
    x.push_back(0.0);
    y.push_back(0.02);
    angle.push_back(30.0 * std::numbers::pi / 180.0);
  }
  trial.data =
      line_tracks_table(std::move(t), std::move(id), std::move(x), std::move(y), std::move(angle));
  return trial;
}

Dataset tracks_dataset(Trial trial) {
  Dataset data;
  data.experiment = ExperimentType::kLineTracks;
  data.trials.push_back(std::move(trial));
  return data;
}

// A belt at rest until 0.1 s, then at `acceleration` to `speed`, held.
Table takt(double acceleration, double speed) {
  Table commands;
  commands.channels = {{"time", *find_unit("s"), {0.0, 0.1, 0.1 + speed / acceleration}},
                       {"belt_speed", *find_unit("m/s"), {0.0, 0.0, speed}}};
  commands.lines.resize(3);
  return commands;
}

TEST(LineTracksTwin, ASteadyBeltCarriesTheFilletAtItsSpeed) {
  Trial trial = one_fillet_trial(1.0);
  trial.conditions["belt_speed"] = 0.5;  // no command log: the condition drives the belt
  const Dataset data = tracks_dataset(trial);
  TwinLineTracksModel model(base_model());
  const Table track = model.run(data, data.trials[0]);
  const auto& t = trial.data.at("time").values_si;
  const auto& x = track.at("x").values_si;
  const auto& y = track.at("y").values_si;
  const auto& angle = track.at("angle").values_si;
  // The first row is where the fillet appears: exactly the measured pose.
  EXPECT_NEAR(x[0], 0.0, 1e-9);
  EXPECT_NEAR(y[0], 0.02, 1e-9);
  EXPECT_NEAR(angle[0], 30.0 * std::numbers::pi / 180.0, 1e-9);
  // It appears moving with the belt and nothing pushes it: x0 + v t, the pose kept. 1 mm and
  // 1 deg are a camera's noise; settling onto the belt must stay well inside them.
  for (std::size_t k = 0; k < t.size(); ++k) {
    EXPECT_NEAR(x[k], 0.5 * t[k], 0.001) << "at " << t[k] << " s";
    EXPECT_NEAR(y[k], 0.02, 0.001) << "at " << t[k] << " s";
    EXPECT_NEAR(angle[k], angle[0], std::numbers::pi / 180.0) << "at " << t[k] << " s";
  }
}

TEST(LineTracksTwin, AnEnsembleStartsWithinTheNoiseAndReportsItsSpread) {
  Trial trial = one_fillet_trial(0.2);
  trial.conditions["belt_speed"] = 0.5;
  Dataset data = tracks_dataset(trial);
  data.noise_si = {{"x", 0.001}, {"y", 0.001}, {"angle", std::numbers::pi / 180.0}};
  constexpr int kRuns = 8;
  TwinLineTracksModel model(base_model(), ensemble(kRuns, 7));
  const Table track = model.run(data, data.trials[0]);
  const auto& x = track.at("x").values_si;
  const auto& x_spread = track.at("x_spread").values_si;
  ASSERT_EQ(x_spread.size(), x.size());
  ASSERT_EQ(track.at("angle_spread").values_si.size(), x.size());
  // Each member appears where its jittered first pose says, so the first row's mean and spread
  // are those of 8 draws of 1 mm noise: the mean within 3 sigma / sqrt(8) = 1.1 mm of the
  // measured 0, the spread (sample sigma times sqrt(1 + 1/8)) within the 99.8 % range of a
  // sample sigma of 8 draws, 0.35 to 1.75 sigma, times 1.06.
  EXPECT_LT(std::abs(x[0]), 0.0011);
  EXPECT_GT(x_spread[0], 0.35 * 1.06e-3);
  EXPECT_LT(x_spread[0], 1.75 * 1.06e-3);
  // A steady belt carries every member's offset along unchanged (each settles by well under
  // a millimetre, the single-run test's bound), so the spread stays within 0.5 mm of the
  // first row's.
  for (std::size_t k = 0; k < x.size(); ++k) {
    EXPECT_NEAR(x_spread[k], x_spread[0], 0.0005) << "row " << k;
  }
  // The jitter is drawn from the seed and the trial: the same answer again, to the bit.
  EXPECT_EQ(model.run(data, data.trials[0]).at("x").values_si, x);
}

TEST(LineTracksTwin, AnEnsembleNeedsTheNoiseItJittersBy) {
  Trial trial = one_fillet_trial(0.1);
  trial.conditions["belt_speed"] = 0.5;
  Dataset data = tracks_dataset(trial);
  data.noise_si = {{"x", 0.001}, {"y", 0.001}};  // no angle noise
  TwinLineTracksModel model(base_model(), ensemble(4, 1));
  try {
    (void)model.run(data, data.trials[0]);
    FAIL() << "an ensemble ran without the angle's noise";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("'angle'"), std::string::npos) << error.what();
  }
  EXPECT_THROW(TwinLineTracksModel(base_model(), ensemble(0, 1)), std::invalid_argument);
}

// Where the belt has carried a point of it by the end of the trial.
double belt_travel_m(double acceleration, double speed, double end_s) {
  const double ramp_s = speed / acceleration;
  return 0.5 * speed * ramp_s + speed * (end_s - 0.1 - ramp_s);
}

TEST(LineTracksTwin, ATaktHarderThanTheFrictionLeavesTheFilletBehind) {
  TwinLineTracksModel model(base_model());
  constexpr double kSpeed = 1.5, kEndS = 0.8;
  // 4 m/s^2 is below mu g = 4.9 m/s^2: the fillet follows the belt (a millimetre of creep in
  // the flexible fillet's contacts at most).
  Trial gentle = one_fillet_trial(kEndS);
  gentle.commands = takt(4.0, kSpeed);
  const double gentle_lag = belt_travel_m(4.0, kSpeed, kEndS) -
                            model.run(tracks_dataset(gentle), gentle).at("x").values_si.back();
  EXPECT_LT(std::abs(gentle_lag), 0.002);
  // 7 m/s^2: a rigid block with Coulomb friction mu slips while the belt ramps and until it
  // has caught up, and ends behind by (a - mu g) t_r^2 / 2 + dv^2 / (2 mu g), dv = (a - mu g)
  // t_r: 69 mm. The fillet is no rigid block: its bottom spheres roll on the belt (the thesis'
  // bonds pass no torque), so the belt grips it less and it falls further behind (84 mm seen).
  // It must slip by the block's order: between half and twice the block's lag.
  Trial hard = one_fillet_trial(kEndS);
  hard.commands = takt(7.0, kSpeed);
  const double mu_g = kFilletBeltFriction * kGravityMps2;
  const double ramp_s = kSpeed / 7.0;
  const double dv = (7.0 - mu_g) * ramp_s;
  const double block_lag = 0.5 * (7.0 - mu_g) * ramp_s * ramp_s + dv * dv / (2.0 * mu_g);
  const double hard_lag = belt_travel_m(7.0, kSpeed, kEndS) -
                          model.run(tracks_dataset(hard), hard).at("x").values_si.back();
  EXPECT_GT(hard_lag, 0.5 * block_lag) << "block " << block_lag;
  EXPECT_LT(hard_lag, 2.0 * block_lag) << "block " << block_lag;
}

TEST(LineTracksTwin, RefusesATrialItCannotRun) {
  const Trial trial = one_fillet_trial(0.1);  // no command log, no belt_speed
  TwinLineTracksModel model(base_model());
  try {
    (void)model.run(tracks_dataset(trial), trial);
    FAIL() << "a belt without a speed ran";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("belt_speed"), std::string::npos) << error.what();
  }
  Dataset other = tracks_dataset(trial);
  other.experiment = ExperimentType::kDrop;
  EXPECT_THROW((void)model.run(other, trial), std::runtime_error);
}

GeneratedDataset generate_tracks(const std::string& effect, std::uint64_t seed) {
  GeneratorOptions options;
  options.experiment = ExperimentType::kLineTracks;
  options.effect = effect;
  options.seed = seed;
  options.common = base_model();
  return generate_dataset(options);
}

TEST(LineTracksGenerator, DatasetAndCommandLogsRoundTrip) {
  const GeneratedDataset made = generate_tracks("none", 3);
  const auto folder = std::filesystem::temp_directory_path() / "fl_tracks_round_trip";
  std::filesystem::remove_all(folder);
  write_dataset(made.dataset, folder);
  const Dataset loaded = load_dataset(folder);
  EXPECT_EQ(loaded.experiment, ExperimentType::kLineTracks);
  ASSERT_EQ(loaded.trials.size(), 4U);  // takt 4 and 7 m/s^2, each dry and wet
  EXPECT_NEAR(loaded.noise_si.at("x"), 0.001, 1e-15);
  EXPECT_NEAR(loaded.noise_si.at("angle"), std::numbers::pi / 180.0, 1e-15);
  for (std::size_t t = 0; t < loaded.trials.size(); ++t) {
    const Trial& a = made.dataset.trials[t];
    const Trial& b = loaded.trials[t];
    EXPECT_EQ(a.conditions, b.conditions);
    ASSERT_TRUE(b.commands.has_value());
    EXPECT_EQ(b.commands->at("belt_speed").values_si, a.commands->at("belt_speed").values_si);
    EXPECT_EQ(b.data.rows(), 5U * 61U);  // 5 fillets, 61 frames of 20 ms
    const auto& x = a.data.at("x").values_si;
    const auto& y = b.data.at("x").values_si;
    // Written in millimetres with 17 significant digits and read back: a rounding at most.
    for (std::size_t k = 0; k < x.size(); ++k) EXPECT_NEAR(x[k], y[k], 1e-15);
  }
  std::filesystem::remove_all(folder);
}

TEST(LineTracksGenerator, AHiddenWetFilmFailsTheBaseModelAndNotTheTruth) {
  const GeneratedDataset made = generate_tracks("wet_film", 3);
  const auto score = [&made](const HiddenEffect& effect) {
    model_tests::CommonParams common = base_model();
    common.base_spec = with_contact_effect(common.base_spec, effect);
    TwinLineTracksModel model(common);
    return compare(made.dataset, model).overall("x").score;
  };
  // The truth leaves the noise: RMS/sigma over 1200 Gaussian positions (the first rows are the
  // start, not residuals) is 1 within about 1/sqrt(2400) = 0.02; 0.1 is five of those.
  EXPECT_NEAR(score(made.truth), 1.0, 0.1);
  // A film of 30 % or more lets the fillets slip centimetres on every wet takt.
  EXPECT_GT(score({}), 10.0);
}

TEST(LineTracksGenerator, AnEnsembleTellsAHiddenStaticFrictionWhereOneRunCannot) {
  // Seed 3 hides mu_s 0.81175 (stick speed 13.7 mm/s) against the sliding 0.5: the 7 m/s^2
  // takts ask for 0.71 g, so whether each contact sticks or slips is close.
  const GeneratedDataset made = generate_tracks("static_kinetic_friction", 3);
  ASSERT_EQ(made.truth.law, "static_kinetic_friction");
  HiddenEffect nudged = made.truth;
  nudged.parameters["static_friction_coefficient"] += 3e-4;  // 0.04 %: far inside any fit
  const auto score = [&made](const HiddenEffect& effect, int runs) {
    model_tests::CommonParams common = base_model();
    common.base_spec = with_contact_effect(common.base_spec, effect);
    TwinLineTracksModel model(common, ensemble(runs, 1));
    return compare(made.dataset, model).overall("x").score;
  };
  // One run: the truth starts where the generator's did and scores 1 (0.1: as the wet film
  // above), but the nudged truth falls off the noise (1.86 seen): no fit can come that close.
  EXPECT_NEAR(score(made.truth, 1), 1.0, 0.1);
  EXPECT_GT(score(nudged, 1), 1.5);
  // Eight runs from first poses within the noise: truth and nudged truth both within the noise
  // and the spread (0.72 and 0.74 seen; 1.2 leaves room for the 8 runs' own scatter), and the
  // base model beyond twice that (2.39 seen): the effect shows, the nudge does not.
  EXPECT_LT(score(made.truth, 8), 1.2);
  EXPECT_LT(score(nudged, 8), 1.2);
  EXPECT_GT(score({}, 8), 2.0);
}

TEST(LineTracksGenerator, FromTheTruePoseOnlyAnEnsembleMatchesTheTruth) {
  // As on a real line: each fillet starts where it is, and the camera's first sight of it is
  // off by the noise like any later one. No effect hidden, so the base model is the truth.
  GeneratorOptions options;
  options.experiment = ExperimentType::kLineTracks;
  options.effect = "none";
  options.seed = 1;
  options.common = base_model();
  options.truth_starts_at_true_pose = true;
  const Dataset data = generate_dataset(options).dataset;
  const auto score = [&data](int runs) {
    TwinLineTracksModel model(base_model(), ensemble(runs, 1));
    return compare(data, model).overall("x").score;
  };
  // One run from the seen first poses carries their error along: sqrt(2) noise sigmas for a
  // fillet carried rigidly, more where a takt turns it (1.92 seen). 1.3 is well past the
  // statistical 1 of a right model.
  EXPECT_GT(score(1), 1.3);
  // Eight runs from first poses within the noise: the truth at the noise and its spread (1.06
  // seen), within the 0.3 that the eight runs' own scatter leaves.
  EXPECT_NEAR(score(8), 1.0, 0.3);
}

}  // namespace
}  // namespace fl::workbench

namespace fl::workbench {
namespace {

// Tracks taken on the line (machine: line): the generator's trials replayed on the DEM plant.
// Four trials of five fillets over the multilane units, 97 rows each: about 0.8 s a trial.
GeneratedDataset generate_on_line(const std::string& effect, std::uint64_t seed) {
  GeneratorOptions options;
  options.experiment = ExperimentType::kLineTracks;
  options.line_tracks_on_line = true;
  options.effect = effect;
  options.seed = seed;
  options.common = base_model();
  return generate_dataset(options);
}

const ErrorCell& cell_of(const CompareReport& report, std::string_view channel,
                         std::string_view group) {
  for (const ErrorCell& cell : report.cells) {
    if (cell.channel == channel && cell.group == group) return cell;
  }
  throw std::out_of_range("no cell " + std::string(channel) + " " + std::string(group));
}

TEST(LineTracksOnTheLine, AHiddenWetFilmFailsTheWetTrialsOnlyAndTheTruthSitsAtTheNoise) {
  const GeneratedDataset made = generate_on_line("wet_film", 1);
  // Written and read back: the line logs name every belt by its drive name.
  const auto folder = std::filesystem::temp_directory_path() / "fl_tracks_on_line";
  std::filesystem::remove_all(folder);
  write_dataset(made.dataset, folder);
  const Dataset loaded = load_dataset(folder);
  std::filesystem::remove_all(folder);
  ASSERT_EQ(loaded.trials.size(), 4U);
  for (const Trial& trial : loaded.trials) {
    EXPECT_TRUE(runs_on_line(trial.conditions));
    ASSERT_TRUE(trial.commands.has_value());
    EXPECT_NE(trial.commands->find("multilane2_right"), nullptr);
    EXPECT_EQ(trial.data.rows(), 5U * 97U);  // 5 fillets, 97 frames of 25 ms
  }
  const auto report_of = [&loaded](const HiddenEffect& effect) {
    model_tests::CommonParams common = base_model();
    common.base_spec = with_contact_effect(common.base_spec, effect);
    TwinLineTracksModel model(common);
    return compare(loaded, model);
  };
  // The truth replays the generator's run: RMS/sigma over about 1900 Gaussian positions is 1
  // within about 1/sqrt(3800) = 0.016 per channel; 0.1 is six of those.
  const CompareReport truth = report_of(made.truth);
  EXPECT_NEAR(truth.overall("x").score, 1.0, 0.1);
  EXPECT_NEAR(truth.overall("angle").score, 1.0, 0.1);
  // Without the film the base model is right where the belts are dry and wrong where they are
  // wet: the film lets the fillets slip where the multilane belts pull them on and apart.
  const CompareReport base = report_of({});
  EXPECT_NEAR(cell_of(base, "x", "surface=dry").score, 1.0, 0.1);
  EXPECT_GT(cell_of(base, "x", "surface=wet").score, 2.0);
  EXPECT_GT(cell_of(base, "angle", "surface=wet").score, 2.0);
}

}  // namespace
}  // namespace fl::workbench
