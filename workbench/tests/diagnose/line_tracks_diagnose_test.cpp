// The proof issue 6 asks for, on line-track data (fillets tracked on a belt through takt
// accelerations): a hidden wet film is ranked first and proposed, adding it makes the error
// along the belt fall by 70 % or more to within twice the noise, and a dataset without a
// hidden effect gets nothing proposed. Two fillets per trial keep each proof under a minute;
// docs/benchmarks.md times the 20-fillet dataset. A hidden static friction is not among the
// proofs: the fillet's stick and slip on a takt is so sensitive to mu_s (0.812 against 0.8118
// moves one run's error from 1 to 1.9 noise sigmas) that no single-run fit comes near the
// noise. An ensemble (LineTracksSettings) tells it apart (line_tracks_test.cpp), and diagnose
// with one finds it on 20 fillets in 4.5 minutes (docs/benchmarks.md), too long for this
// suite; on two fillets a trial it does not (one 7 m/s^2 takt to fit on is too little).
#include <gtest/gtest.h>

#include "fl/workbench/diagnose.hpp"
#include "workbench_test_support.hpp"

namespace fl::workbench {
namespace {

using test::base_model;

GeneratedDataset generate_tracks(const std::string& effect, std::uint64_t seed) {
  GeneratorOptions options;
  options.experiment = ExperimentType::kLineTracks;
  options.effect = effect;
  options.seed = seed;
  options.fillets_per_trial = 2;
  options.common = base_model();
  return generate_dataset(options);
}

double x_score(const Dataset& data, const HiddenEffect& effect) {
  model_tests::CommonParams common = base_model();
  common.base_spec = with_contact_effect(common.base_spec, effect);
  TwinLineTracksModel model(common);
  return compare(data, model).overall("x").score;
}

TEST(LineTracksDiagnose, FindsAHiddenWetFilm) {
  test::expect_hidden_effect_found(generate_tracks("wet_film", 61), "x", x_score);
}

TEST(LineTracksDiagnose, ProposesNothingWhenResidualsAreAtTheNoise) {
  test::expect_nothing_proposed(generate_tracks("none", 63).dataset);
}

TEST(LineTracksDiagnose, ProbesHowFarTheFirstPosesMoveTheTracks) {
  // One fillet a trial and one cheap candidate: the probe, not the fit, is under test.
  GeneratorOptions options;
  options.experiment = ExperimentType::kLineTracks;
  options.effect = "none";
  options.seed = 5;
  options.fillets_per_trial = 1;
  options.common = base_model();
  const Dataset data = generate_dataset(options).dataset;
  const std::vector<EffectCandidate> candidates{{"wet_film", {{"lubrication", 0.0, 0.95, false}}}};
  DiagnoseOptions quick;
  quick.max_evaluations = 2;
  const Diagnosis single = diagnose(data, base_model(), candidates, quick);
  // First poses jittered by 1 mm move every later position by that much at least: a spread of
  // at least half the noise (4 runs' sample sigma is rarely below half the true one).
  EXPECT_GT(single.base_first_pose_spread, 0.5 * single.noise_si);
  EXPECT_GT(single.best_first_pose_spread, 0.5 * single.noise_si);
  const bool hinted = single.verdict.find("--ensemble") != std::string::npos;
  EXPECT_EQ(hinted, std::max(single.base_first_pose_spread, single.best_first_pose_spread) >
                        2.0 * single.noise_si)
      << single.verdict;
  // An ensemble diagnosis needs no probe: its spread is in the score already.
  quick.twin.line_tracks.ensemble_runs = 2;
  const Diagnosis ensemble = diagnose(data, base_model(), candidates, quick);
  EXPECT_EQ(ensemble.base_first_pose_spread, 0.0);
  EXPECT_GT(ensemble.base_model_spread, 0.0);
  EXPECT_EQ(ensemble.verdict.find("--ensemble"), std::string::npos) << ensemble.verdict;
}

}  // namespace
}  // namespace fl::workbench
