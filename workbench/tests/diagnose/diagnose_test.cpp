// The proof issue 6 asks for, on compression data: a dataset made with a hidden effect gets
// that effect ranked first and proposed; adding it with the fitted parameters makes the error
// fall by 70 % or more and end within twice the noise; a dataset without a hidden effect gets
// nothing proposed. The candidates' bounds are the diagnosis' own (decades wide), not the
// generator's ranges.
#include "fl/workbench/diagnose.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "calibrate_test_support.hpp"
#include "workbench_test_support.hpp"

namespace fl::workbench {
namespace {

using test::base_model;

TEST(Diagnose, FindsEachHiddenEffectAndTheErrorFalls) {
  // Seeds 11 and 12 draw different parameters for each effect; the effect is named, so both
  // candidates are proven whatever the random choice would pick.
  for (const auto& [effect, seed] : {std::pair{std::string("bpm_viscoelastic"), 11},
                                     std::pair{std::string("bpm_plastic"), 12}}) {
    SCOPED_TRACE(effect);
    const GeneratedDataset made = test::generate(effect, static_cast<std::uint64_t>(seed));
    const Dataset& data = made.dataset;
    const Diagnosis diagnosis =
        diagnose(data, base_model(), candidates_for(ExperimentType::kCompress));
    ASSERT_FALSE(diagnosis.ranked.empty());
    EXPECT_EQ(diagnosis.ranked.front().law, made.truth.law) << diagnosis.verdict;
    EXPECT_TRUE(diagnosis.ranked.front().proposed) << diagnosis.verdict;
    const double before = test::force_score(data, {});
    const double after = test::force_score(data, proposed_effect(diagnosis));
    EXPECT_LE(after, 0.3 * before) << "before " << before << ", after " << after;
    EXPECT_LE(after, 2.0) << "in noise sigmas";
  }
}

TEST(Diagnose, FindsItThroughAFastLoggersDisplacementNoise) {
  // The same proof on a 10 kHz log with 0.5 um of encoder noise on the displacement (an outside
  // lab's): the twin's plate follows the crosshead's path with the noise taken out, so the
  // fitted model can end within twice the noise (row by row it scored 8.4 sigmas even as the
  // truth).
  GeneratorOptions options;
  options.experiment = ExperimentType::kCompress;
  options.seed = 11;
  options.effect = "bpm_viscoelastic";
  options.force_noise_n = test::kNoiseN;
  options.displacement_noise_um = 0.5;
  options.compress_row_s = 1e-4;
  options.common = base_model();
  const GeneratedDataset made = generate_dataset(options);
  const Diagnosis diagnosis =
      diagnose(made.dataset, base_model(), candidates_for(ExperimentType::kCompress));
  ASSERT_FALSE(diagnosis.ranked.empty());
  EXPECT_EQ(diagnosis.ranked.front().law, made.truth.law) << diagnosis.verdict;
  EXPECT_TRUE(diagnosis.ranked.front().proposed) << diagnosis.verdict;
  const double before = test::force_score(made.dataset, {});
  const double after = test::force_score(made.dataset, proposed_effect(diagnosis));
  EXPECT_LE(after, 0.3 * before) << "before " << before << ", after " << after;
  EXPECT_LE(after, 2.0) << "in noise sigmas";
}

TEST(Diagnose, ProposesNothingWhenResidualsAreAtTheNoise) {
  const Dataset data = test::generate("none", 13).dataset;
  const Diagnosis diagnosis =
      diagnose(data, base_model(), candidates_for(ExperimentType::kCompress));
  for (const CandidateResult& result : diagnosis.ranked) EXPECT_FALSE(result.proposed);
  EXPECT_TRUE(proposed_effect(diagnosis).law.empty());
  EXPECT_NE(diagnosis.verdict.find("nothing missing"), std::string::npos) << diagnosis.verdict;
}

// Found by an audit: bonds 20 % softer than the model's and no effect, and the Maxwell arm of
// bpm_viscoelastic, its relaxation time at the bound, stood in for the missing stiffness and
// was proposed (RMS down 82 %). The refitted base is the null every effect must beat.
TEST(Diagnose, ABaseStiffnessOffIsABaseErrorNotAMissingEffect) {
  const Dataset data = test::stiffer_bonds_compression();  // 1.8 times the model's stiffness
  const Diagnosis diagnosis =
      diagnose(data, base_model(), candidates_for(ExperimentType::kCompress));
  EXPECT_TRUE(diagnosis.base_off) << diagnosis.verdict;
  EXPECT_TRUE(proposed_effect(diagnosis).law.empty());
  const auto null =
      std::find_if(diagnosis.ranked.begin(), diagnosis.ranked.end(),
                   [](const CandidateResult& r) { return r.law == kRecalibratedBase; });
  ASSERT_NE(null, diagnosis.ranked.end());
  // The force is linear in the stiffness at 1.8 % strain; the noise (2 % of the peak) leaves it
  // known to about a percent.
  EXPECT_NEAR(null->fitted.at("bond.normal_stiffness_n_per_m3"), test::kTruthStiffness,
              0.03 * test::kTruthStiffness);
  EXPECT_NE(diagnosis.verdict.find("the base model is off"), std::string::npos)
      << diagnosis.verdict;
  // Where the error fell: every trial, each from the base's miss to the noise (0.01 N) or near.
  ASSERT_EQ(diagnosis.by_trial.size(), data.trials.size());
  for (const Diagnosis::TrialError& trial : diagnosis.by_trial) {
    EXPECT_GT(trial.base_rmse, 5.0 * test::kNoiseN) << trial.trial;
    EXPECT_LT(trial.fitted_rmse, 1.5 * test::kNoiseN) << trial.trial;
  }
}

TEST(Diagnose, RefusesWhatItCannotJudge) {
  GeneratorOptions options;
  options.effect = "none";
  options.trials = 1;
  options.common = base_model();
  const Dataset one_trial = generate_dataset(options).dataset;
  EXPECT_THROW((void)diagnose(one_trial, base_model(), candidates_for(ExperimentType::kCompress)),
               std::invalid_argument);
}

// The judgement alone, on fitted figures made by hand (no twin runs). 100 samples, noise 1, a
// base model 5 noise sigmas off on all trials and on the held-out one.
Diagnosis base_five_sigmas_off() {
  Diagnosis diagnosis;
  diagnosis.samples = 100;
  diagnosis.noise_si = 1.0;
  diagnosis.base_rmse = 5.0;
  diagnosis.base_held_out_rmse = 5.0;
  diagnosis.base_bic = 100.0 * std::log(25.0);  // n ln(rss / n), no parameters added
  return diagnosis;
}

CandidateResult fitted(const std::string& law, double rmse, double held_out_rmse, int parameters) {
  CandidateResult result;
  result.law = law;
  result.rss = 100.0 * rmse * rmse;
  result.bic = 100.0 * std::log(rmse * rmse) + parameters * std::log(100.0);
  result.held_out_rmse = held_out_rmse;
  return result;
}

TEST(DiagnoseJudgement, AnEffectMustBeatTheRefittedBase) {
  const DiagnoseOptions options;
  // The refit and an effect both reach the noise: the effect's extra parameter costs it
  // ln(100) = 4.6 of BIC, so it does not beat the refit by 10. The base is off; nothing is
  // proposed, the refit least of all.
  Diagnosis tie = base_five_sigmas_off();
  rank_candidates(tie,
                  {fitted("bpm_viscoelastic", 1.0, 1.0, 2),
                   fitted(std::string(kRecalibratedBase), 1.0, 1.0, 1)},
                  options);
  EXPECT_TRUE(tie.base_off);
  for (const CandidateResult& result : tie.ranked) EXPECT_FALSE(result.proposed) << result.law;
  EXPECT_NE(diagnosis_verdict(tie, options).find("the base model is off"), std::string::npos);
  // An effect at the noise where the refit stays 3 sigmas off: 100 ln 9 = 220 of BIC apart.
  Diagnosis effect = base_five_sigmas_off();
  rank_candidates(
      effect,
      {fitted(std::string(kRecalibratedBase), 3.0, 3.0, 1), fitted("bpm_plastic", 1.0, 1.0, 1)},
      options);
  EXPECT_FALSE(effect.base_off);
  ASSERT_EQ(effect.ranked.front().law, "bpm_plastic");
  EXPECT_TRUE(effect.ranked.front().proposed);
  EXPECT_FALSE(effect.ranked.back().proposed);
}

TEST(DiagnoseJudgement, ARunnerUpTheDataCannotTellFromTheBestIsNamed) {
  const DiagnoseOptions options;  // proposal: BIC down by 10, held-out error down by 20 %
  // Both fall to the noise; static friction's two parameters against rolling resistance's one
  // cost it ln(100) = 4.6 of BIC, under the 10 that would tell them apart.
  Diagnosis close = base_five_sigmas_off();
  rank_candidates(close,
                  {fitted("static_kinetic_friction", 1.0, 1.0, 2),
                   fitted("rolling_resistance", 1.0, 1.1, 1), fitted("wet_film", 4.9, 5.0, 1)},
                  options);
  ASSERT_EQ(close.ranked.size(), 3U);
  EXPECT_EQ(close.ranked[0].law, "rolling_resistance");
  EXPECT_TRUE(close.ranked[0].proposed);
  EXPECT_FALSE(close.ranked[1].proposed);  // only the best is proposed
  EXPECT_EQ(close.indistinct_from, "static_kinetic_friction");
  EXPECT_NEAR(close.indistinct_bic_gap, std::log(100.0), 1e-9);
  const std::string verdict = diagnosis_verdict(close, options);
  EXPECT_NE(verdict.find("rolling_resistance explains the failure"), std::string::npos);
  EXPECT_NE(verdict.find("But static_kinetic_friction explains it nearly as well"),
            std::string::npos)
      << verdict;
  // The runner-up 1.2 sigmas off: 100 ln(1.44) = 36 of BIC behind, told apart, not named.
  Diagnosis apart = base_five_sigmas_off();
  rank_candidates(
      apart,
      {fitted("rolling_resistance", 1.2, 1.3, 1), fitted("static_kinetic_friction", 1.0, 1.0, 1)},
      options);
  EXPECT_TRUE(apart.indistinct_from.empty());
  EXPECT_EQ(diagnosis_verdict(apart, options).find("nearly as well"), std::string::npos);
  // A runner-up that does not predict the held-out trial (its error down 4 %, not 20 %) is no
  // rival; a third within the margin that does is named past it.
  Diagnosis third = base_five_sigmas_off();
  rank_candidates(third,
                  {fitted("static_kinetic_friction", 1.0, 1.0, 1),
                   fitted("rolling_resistance", 1.0, 4.8, 2), fitted("wet_film", 1.01, 1.0, 2)},
                  options);
  EXPECT_EQ(third.ranked[1].law, "rolling_resistance");
  EXPECT_EQ(third.indistinct_from, "wet_film");
}

TEST(DiagnoseJudgement, TheVerdictNeverCallsAFailingModelComplete) {
  const DiagnoseOptions options;
  // No candidate helps (4.9 sigmas after the fit): the base model still fails.
  Diagnosis failing = base_five_sigmas_off();
  rank_candidates(failing, {fitted("bpm_plastic", 4.9, 4.9, 1)}, options);
  EXPECT_FALSE(failing.ranked[0].proposed);
  const std::string verdict = diagnosis_verdict(failing, options);
  EXPECT_EQ(verdict.find("nothing missing"), std::string::npos) << verdict;
  EXPECT_NE(verdict.find("no candidate explains the failure"), std::string::npos) << verdict;
  EXPECT_NE(verdict.find("5 noise sigmas off"), std::string::npos) << verdict;
  // A base model at 1.5 sigmas (under the twice the noise the proof accepts) is complete.
  Diagnosis fine = base_five_sigmas_off();
  fine.base_rmse = 1.5;
  fine.base_held_out_rmse = 1.5;
  fine.base_bic = 100.0 * std::log(2.25);
  rank_candidates(fine, {fitted("bpm_plastic", 1.49, 1.5, 1)}, options);
  EXPECT_NE(diagnosis_verdict(fine, options).find("nothing missing"), std::string::npos);
  // An ensemble's own spread counts as noise: 5 off against a floor of hypot(1, 3) = 3.2 is
  // 1.6 sigmas, complete.
  failing.base_model_spread = 3.0;
  EXPECT_NE(diagnosis_verdict(failing, options).find("nothing missing"), std::string::npos);
  // Without a noise figure nothing can be called complete.
  Diagnosis unknown = base_five_sigmas_off();
  unknown.noise_si = 0.0;
  rank_candidates(unknown, {fitted("bpm_plastic", 4.9, 4.9, 1)}, options);
  const std::string blind = diagnosis_verdict(unknown, options);
  EXPECT_EQ(blind.find("nothing missing"), std::string::npos) << blind;
  EXPECT_NE(blind.find("cannot be judged"), std::string::npos) << blind;
  // A best whose spread alone wins the likelihood while its answers miss by more than the
  // base's (RMS 6 against 5: up 20 %, though BIC down 100 and the held-out error down 40 %)
  // is not proposed, and the verdict says why and what to measure.
  Diagnosis chance = base_five_sigmas_off();
  CandidateResult spread_only = fitted("static_kinetic_friction", 6.0, 3.0, 2);
  spread_only.bic = chance.base_bic - 100.0;
  spread_only.model_spread = 8.0;
  rank_candidates(chance, {spread_only}, options);
  EXPECT_FALSE(chance.ranked[0].proposed);
  const std::string as_chance = diagnosis_verdict(chance, options);
  EXPECT_NE(as_chance.find("only through its own spread"), std::string::npos) << as_chance;
  EXPECT_NE(as_chance.find("RMS error up 20 %"), std::string::npos) << as_chance;
  EXPECT_NE(as_chance.find("placement: relaid"), std::string::npos) << as_chance;
  EXPECT_EQ(as_chance.find("does not lower the BIC"), std::string::npos) << as_chance;
  EXPECT_NE(as_chance.find(". No candidate explains the failure"), std::string::npos) << as_chance;
  // Rows re-laid already: the advice is the larger ensemble alone.
  chance.placement = "relaid";
  const std::string relaid = diagnosis_verdict(chance, options);
  EXPECT_NE(relaid.find("re-laid already"), std::string::npos) << relaid;
  EXPECT_EQ(relaid.find("placement: relaid"), std::string::npos) << relaid;
  // A proposed effect that leaves the model 3 sigmas off says part is unexplained.
  Diagnosis partly = base_five_sigmas_off();
  rank_candidates(partly, {fitted("bpm_plastic", 3.0, 3.0, 1)}, options);
  ASSERT_TRUE(partly.ranked[0].proposed);
  EXPECT_NE(diagnosis_verdict(partly, options).find("still 3 noise sigmas off"), std::string::npos);
}

}  // namespace
}  // namespace fl::workbench
