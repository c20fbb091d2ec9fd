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

}  // namespace
}  // namespace fl::workbench
