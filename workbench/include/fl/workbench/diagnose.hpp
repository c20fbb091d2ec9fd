// Which physical effect is missing? For each candidate effect of the effect library that the
// model lacks, fit its parameters to the dataset (bounded, derivative-free least squares with
// NLopt's BOBYQA over the DEM twin), then judge it two ways: the Bayesian information
// criterion over all trials (the fit must pay for its parameters) and the error on a trial
// left out of the fit (it must predict, not memorise). A candidate is proposed only when both
// say so, so residuals at the noise level get no effect.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "fl/twin/model_tests/fixtures.hpp"
#include "fl/workbench/dataset.hpp"
#include "fl/workbench/generator.hpp"
#include "fl/workbench/twin_models.hpp"

namespace fl::workbench {

struct ParameterBound {
  std::string name;
  double min = 0.0;
  double max = 0.0;
  bool log = false;  // searched on a log scale (stiffnesses, time constants)
};

struct EffectCandidate {
  // A law of the effect library: a bond law for compress datasets, a fillet-equipment contact
  // law for slide datasets (the experiment type decides where it goes in the model).
  std::string law;
  std::vector<ParameterBound> parameters;
};

// The null candidate every effect must beat: the base model with one of its own parameters
// refitted (its parameters' names are calibrate's addresses, calibrate.hpp). A model whose base
// is off (a bond stiffness 20 % low) is otherwise "explained" by whichever effect can stand in
// for the parameter: a Maxwell arm whose relaxation time sits at its bound is an extra spring.
inline constexpr std::string_view kRecalibratedBase = "recalibrated_base";

// The null candidate for a dataset's experiment and base model: compress, drop and bend, the
// bonds' normal stiffness within a factor of three of the base's; none for the others
// (nullopt: slide and line tracks have none yet).
std::optional<EffectCandidate> recalibration_candidate(ExperimentType type,
                                                       const dem::ModelSpec& base);

// The effect library's candidates for a dataset's experiment: every law of the registry with a
// fit range (dem::LawInfo::is_effect) of the kind the experiment's twin loads (loads_contacts:
// contact laws, else bond laws; a bond law that reads bond thickness only where the specimen
// is a fillet, not compress's block), each searched over its fit ranges (wide enough for any
// fillet, not the generator's ranges). A law registered with fit ranges is thereby a candidate
// with no change here. Throws std::invalid_argument for an experiment diagnose does not judge
// (bulk flow).
std::vector<EffectCandidate> candidates_for(
    ExperimentType type, const dem::LawRegistry& registry = dem::LawRegistry::builtin());

struct CandidateResult {
  std::string law;
  dem::LawParameters fitted;   // the effect's own parameters
  double rss = 0.0;            // sum of squared residuals over all trials, SI^2
  double bic = 0.0;            // -2 ln L + k ln n (Diagnosis::score says which likelihood)
  double delta_bic = 0.0;      // against the base model (< 0: better)
  double held_out_rmse = 0.0;  // on the trial left out of the fit
  double improvement = 0.0;    // 1 - rmse / base rmse, all trials
  double model_spread = 0.0;   // an ensemble twin's own spread, RMS over all trials (else 0)
  bool proposed = false;
  int evaluations = 0;
  // RMS per trial over all trials, in the dataset's order (what Diagnosis::by_trial reads).
  std::vector<double> trial_rmse;
};

struct Diagnosis {
  std::string channel;  // the channel judged ("force")
  // The likelihood behind every BIC: "residual_sum" (Gaussian rows, the noise estimated from
  // the residuals: n ln(rss / n)), or "repetition_likelihood" for an ensemble on an experiment
  // whose rows repeat one answer a trial (detail::repetition_deviance: a trial's mean offset
  // is judged against the rows' scatter and the ensemble's own spread).
  std::string score;
  // A slide dataset's `placement` when every trial states the same one ("relaid",
  // "laid_once"), "mixed" when they differ, empty when none states it (or not a slide).
  std::string placement;
  std::size_t samples = 0;
  double base_rmse = 0.0;
  double base_bic = 0.0;
  double base_held_out_rmse = 0.0;
  double noise_si = 0.0;
  double base_model_spread = 0.0;  // the base ensemble's own spread, RMS (one run: 0)
  // Line tracks or slide diagnosed from one run a trial: how far the answers of the base model
  // and of the best-ranked fit move, RMS, when the fillet starts elsewhere within what the
  // measurement leaves open (line tracks: the first poses within the noise; slide: the
  // placement within SlideSettings' tolerance), from a probe of kFirstPoseProbeRuns runs each.
  // Beyond first_pose_spread_allowed the answer hangs on stick or slip, and the verdict says to
  // use an ensemble. 0 when not probed.
  double base_first_pose_spread = 0.0;
  double best_first_pose_spread = 0.0;
  // Line tracks: twice the noise (each row is judged on its own). Slide: the noise (the rows
  // repeat one answer, so a trial's offset is what the fit sees, and one noise sigma is
  // sqrt(n) standard errors of an n-repetition mean, three for the usual ten). On the
  // generator's data the coulomb base reads 0.19 deg RMS (the 172 mm fillet's two ways of
  // starting to slide; a dataset of that fillet alone would read about 0.28, close under the
  // line) and a fitted static friction 0.44 deg, against 0.3 deg of noise.
  double first_pose_spread_allowed = 0.0;
  ExperimentType experiment = ExperimentType::kCompress;
  std::string held_out_trial;
  std::vector<CandidateResult> ranked;  // best (lowest BIC) first
  // When the best is proposed and the runner-up would pass as well with a BIC less than
  // DiagnoseOptions::min_bic_drop above it: its law and that gap (the data cannot tell them
  // apart). Empty and 0 otherwise.
  std::string indistinct_from;
  double indistinct_bic_gap = 0.0;
  // The refitted base (kRecalibratedBase) passes the tests an effect must pass and no effect
  // beats it by min_bic_drop: the base model is off, not missing an effect. Nothing is proposed.
  bool base_off = false;
  // Where the error fell: per trial, the base model's RMS and that of the first-ranked fit (the
  // proposed effect, or the refit when the base is off), in the dataset's order. Empty when
  // nothing was fitted.
  struct TrialError {
    std::string trial;
    double base_rmse = 0.0;
    double fitted_rmse = 0.0;
  };
  std::vector<TrialError> by_trial;
  // "bpm_viscoelastic explains it: ..." or "nothing missing: ...".
  std::string verdict;
};

// Runs of the first-pose probe of a line-track or slide diagnosis from one run a trial.
inline constexpr int kFirstPoseProbeRuns = 4;

struct DiagnoseOptions {
  int max_evaluations = 100;  // per candidate
  int threads = 2;            // candidates fitted at once
  // Proposed when BIC falls by more than this (Kass and Raftery: > 10 is very strong), the
  // held-out error falls by more than min_held_out_gain and the error over all trials falls.
  double min_bic_drop = 10.0;
  double min_held_out_gain = 0.2;
  // Fit recalibration_candidate's null candidate beside the effects (where the experiment has
  // one): an effect is then proposed only when it beats the refitted base by min_bic_drop.
  bool recalibrate_base = true;
  // How the twins run: line tracks and slides may run an ensemble per trial
  // (LineTracksSettings, SlideSettings), whose mean is fitted: one run's answer can hang on a
  // stick or slip that the noise or the placement decides.
  TwinSettings twin;
};

// The trial a fit on the others must predict. With rates: the fastest (the first of equals),
// as extrapolating in rate is what a rate law is for. Without (slide): the trial the base
// model misses by the most (base_trial_rmse, one per trial; the last of equals), so an effect
// that shows under one condition only (a wet plate) is judged on a trial where it shows, and
// is fitted on the others where it shows too. Throws std::invalid_argument when the errors do
// not match the trials.
std::size_t held_out_trial(const Dataset& dataset, const std::vector<double>& base_trial_rmse);

// The channel judged, the twin and where the effect goes come from the experiment type
// (compress: force, bond law; slide: onset_angle, fillet-equipment contact chain; drop:
// height, bond law). The trial held out is held_out_trial's. Throws std::invalid_argument for
// a dataset it cannot diagnose (compress, slide and drop only, two trials or more so one can
// be held out).
Diagnosis diagnose(const Dataset& dataset, const model_tests::CommonParams& base,
                   const std::vector<EffectCandidate>& candidates,
                   const DiagnoseOptions& options = {});

// diagnose()'s judgement of fitted candidates, given a diagnosis whose base figures (samples,
// base_rmse, base_bic, base_held_out_rmse) are set: each candidate's BIC change and RMS fall,
// ranked by BIC, the best proposed when it passes the tests (DiagnoseOptions), and
// indistinct_from set when a runner-up passes too within min_bic_drop of it.
void rank_candidates(Diagnosis& diagnosis, std::vector<CandidateResult> results,
                     const DiagnoseOptions& options);
// The one-paragraph verdict of a ranked diagnosis: what explains the failure, or that nothing
// does; a base model still beyond twice the noise when nothing is proposed; a runner-up the
// data cannot tell from the best; a best that wins through its ensemble's spread alone; a fit
// that hangs on its first poses or placement.
[[nodiscard]] std::string diagnosis_verdict(const Diagnosis& diagnosis,
                                            const DiagnoseOptions& options);

// The proposed effect as a HiddenEffect-style law change of the base model (empty law when
// nothing is proposed).
HiddenEffect proposed_effect(const Diagnosis& diagnosis);
[[nodiscard]] std::string diagnosis_json(const Diagnosis& diagnosis);

}  // namespace fl::workbench
