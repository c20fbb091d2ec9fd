#include "fl/workbench/diagnose.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "fl/twin/dem/config.hpp"
#include "fl/workbench/calibrate.hpp"
#include "fl/workbench/twin_models.hpp"
#include "residuals.hpp"

namespace fl::workbench {
namespace {

using detail::judged_channel;
using detail::RepetitionScoring;
using detail::Residuals;
using detail::residuals;

// -2 ln L + k ln n: from the residual sum (the noise taken as its maximum-likelihood estimate)
// for one run a trial, from the repetition deviance for an ensemble on repeated rows.
double bic(const Residuals& r, const std::optional<RepetitionScoring>& scoring,
           std::size_t parameters) {
  const auto n = static_cast<double>(r.samples);
  const double penalty = static_cast<double>(parameters) * std::log(n);
  if (scoring) return detail::repetition_deviance(r.trials, *scoring) + penalty;
  return n * std::log(std::max(r.rss, 1e-300) / n) + penalty;
}

double from_unit(const ParameterBound& bound, double u) {
  return bound.log ? bound.min * std::pow(bound.max / bound.min, u)
                   : bound.min + u * (bound.max - bound.min);
}

struct FitContext {
  const Dataset* dataset = nullptr;
  const model_tests::CommonParams* base = nullptr;
  const EffectCandidate* candidate = nullptr;
  const std::vector<std::size_t>* trials = nullptr;
  const TwinSettings* twin = nullptr;
  const std::optional<RepetitionScoring>* scoring = nullptr;
  int evaluations = 0;
};

model_tests::CommonParams with_effect(const model_tests::CommonParams& base,
                                      const EffectCandidate& candidate, ExperimentType experiment,
                                      const double* unit_point) {
  model_tests::CommonParams common = base;
  if (candidate.law == kRecalibratedBase) {
    std::vector<CalibratedParameter> parameters;
    std::vector<double> values;
    for (std::size_t p = 0; p < candidate.parameters.size(); ++p) {
      const ParameterBound& bound = candidate.parameters[p];
      parameters.push_back({bound.name, bound.min, bound.max, bound.log});
      values.push_back(from_unit(bound, unit_point[p]));
    }
    common.base_spec = with_calibrated(base.base_spec, parameters, values);
    return common;
  }
  HiddenEffect effect;
  effect.law = candidate.law;
  for (std::size_t p = 0; p < candidate.parameters.size(); ++p) {
    effect.parameters[candidate.parameters[p].name] =
        from_unit(candidate.parameters[p], unit_point[p]);
  }
  common.base_spec = with_experiment_effect(base.base_spec, experiment, effect);
  return common;
}

// What the fit minimises over the fit trials with the candidate's parameters at a point of the
// unit box, counted: the RSS, or the repetition deviance where that judges.
double objective(FitContext& context, const std::vector<double>& x) {
  ++context.evaluations;
  const Residuals r = residuals(
      *context.dataset,
      with_effect(*context.base, *context.candidate, context.dataset->experiment, x.data()),
      *context.trials, *context.twin);
  return *context.scoring ? detail::repetition_deviance(r.trials, **context.scoring) : r.rss;
}

CandidateResult fit(const Dataset& dataset, const model_tests::CommonParams& base,
                    const EffectCandidate& candidate, const std::vector<std::size_t>& fit_trials,
                    const std::vector<std::size_t>& all_trials, std::size_t held_out,
                    const DiagnoseOptions& options,
                    const std::optional<RepetitionScoring>& scoring) {
  const auto dimensions = static_cast<unsigned>(candidate.parameters.size());
  FitContext context{&dataset, &base, &candidate, &fit_trials, &options.twin, &scoring};
  // Start from the best of the middle and the points a quarter in from the corners of the
  // (log) box: an effect can be flat over much of its range (a stick speed below the contacts'
  // creep hides any static friction), and a local search started on such a plateau stops
  // there. 2^d + 1 twin runs over the fit trials.
  const detail::UnitBoxObjective fit_objective = [&](const std::vector<double>& point) {
    return objective(context, point);
  };
  const std::string who = "diagnose: " + candidate.law;
  const auto guarded = [&](const std::vector<double>& point) {
    return detail::guarded_value(fit_objective, point, who);
  };
  std::vector<double> x(dimensions, 0.5);
  double start_value = guarded(x);
  for (unsigned corner = 0; corner < (1U << dimensions); ++corner) {
    std::vector<double> point(dimensions);
    for (unsigned p = 0; p < dimensions; ++p) point[p] = (corner >> p) & 1U ? 0.75 : 0.25;
    const double value = guarded(point);
    if (value < start_value) {
      start_value = value;
      x = point;
    }
  }
  // A deviance restarts while it gains 1 (a likelihood ratio of e^0.5, a tenth of the
  // proposal's min_bic_drop); its 1 % would be tens on slide data.
  detail::minimise_in_unit_box(fit_objective, x, start_value, 0.25, options.max_evaluations, who,
                               scoring ? 1.0 : 0.0);
  CandidateResult result;
  result.law = candidate.law;
  result.evaluations = context.evaluations;
  for (std::size_t p = 0; p < dimensions; ++p) {
    result.fitted[candidate.parameters[p].name] = from_unit(candidate.parameters[p], x[p]);
  }
  const model_tests::CommonParams fitted =
      with_effect(base, candidate, dataset.experiment, x.data());
  const Residuals all = residuals(dataset, fitted, all_trials, options.twin);
  result.rss = all.rss;
  for (const detail::TrialRepetitions& trial : all.trials) {
    result.trial_rmse.push_back(std::sqrt(trial.rss / static_cast<double>(trial.rows)));
  }
  result.model_spread = std::sqrt(all.spread_ss / static_cast<double>(all.samples));
  result.bic = bic(all, scoring, dimensions);
  // The held-out trial is one of all_trials: its error is in that run already.
  const auto held_out_at = static_cast<std::size_t>(
      std::find(all_trials.begin(), all_trials.end(), held_out) - all_trials.begin());
  result.held_out_rmse = result.trial_rmse.at(held_out_at);
  return result;
}

}  // namespace

std::optional<EffectCandidate> recalibration_candidate(ExperimentType type,
                                                       const dem::ModelSpec& base) {
  if (type != ExperimentType::kCompress && type != ExperimentType::kDrop &&
      type != ExperimentType::kBend) {
    return std::nullopt;
  }
  constexpr std::string_view kKey = "normal_stiffness_n_per_m3";
  for (const dem::InteractionSpec& interaction : base.interactions) {
    if (!interaction.bond_law) continue;
    const auto found = interaction.bond_law->parameters.find(std::string(kKey));
    if (found == interaction.bond_law->parameters.end() || !(found->second > 0.0)) continue;
    // A factor of three either way: the stiffness a lab's fillets spread over, well short of
    // the decades the effects' own stiffnesses span.
    return EffectCandidate{
        std::string(kRecalibratedBase),
        {{"bond." + std::string(kKey), found->second / 3.0, found->second * 3.0, true}}};
  }
  return std::nullopt;
}

namespace {

template <typename Law>
EffectCandidate candidate_of(const dem::LawInfo<Law>& info) {
  EffectCandidate candidate{info.name, {}};
  for (const dem::LawParameterInfo& parameter : info.parameters) {
    if (!parameter.fit_range) continue;
    const dem::FitRange& range = *parameter.fit_range;
    candidate.parameters.push_back({parameter.name, range.min, range.max, range.log_scale});
  }
  return candidate;
}

}  // namespace

std::vector<EffectCandidate> candidates_for(ExperimentType type, const dem::LawRegistry& registry) {
  if (type == ExperimentType::kBulkFlow) {
    throw std::invalid_argument("no effect candidates for " + std::string(to_string(type)) +
                                " datasets");
  }
  std::vector<EffectCandidate> candidates;
  if (loads_contacts(type)) {
    // A belt's takt loads the fillet-belt contact as a tilted plate does.
    for (const std::string& name : registry.contact_law_names()) {
      const dem::LawInfo<dem::ContactLaw>& info = *registry.find_contact_law(name);
      if (info.is_effect()) candidates.push_back(candidate_of(info));
    }
    return candidates;
  }
  // A drop or a settle loads the same bonds as a compression, at impact rates; a bend loads
  // them along the whole fillet. Compress's specimen is a block with no thickness profile.
  const bool specimen_is_fillet = type != ExperimentType::kCompress;
  for (const std::string& name : registry.bond_law_names()) {
    const dem::LawInfo<dem::BondLaw>& info = *registry.find_bond_law(name);
    if (!info.is_effect()) continue;
    if (!specimen_is_fillet && registry.sample_bond_law(name)->needs_bond_thickness()) continue;
    candidates.push_back(candidate_of(info));
  }
  return candidates;
}

std::size_t held_out_trial(const Dataset& dataset, const std::vector<double>& base_trial_rmse) {
  if (dataset.trials.empty() || base_trial_rmse.size() != dataset.trials.size()) {
    throw std::invalid_argument("held_out_trial: one base error per trial is needed");
  }
  std::optional<std::size_t> fastest;
  double fastest_rate = 0.0;
  for (std::size_t k = 0; k < dataset.trials.size(); ++k) {
    const auto rate = dataset.trials[k].conditions.find("rate");
    if (rate == dataset.trials[k].conditions.end()) continue;
    const double value = std::get<double>(rate->second);
    if (!fastest || value > fastest_rate) {
      fastest = k;
      fastest_rate = value;
    }
  }
  if (fastest) return *fastest;
  std::size_t worst = dataset.trials.size() - 1;
  for (std::size_t k = 0; k < base_trial_rmse.size(); ++k) {
    if (base_trial_rmse[k] > base_trial_rmse[worst]) worst = k;
  }
  return worst;
}

namespace {
// The held-out trial's error fall of a fitted candidate (0 without a held-out error).
double held_out_gain(const Diagnosis& diagnosis, const CandidateResult& result) {
  return diagnosis.base_held_out_rmse > 0.0
             ? 1.0 - result.held_out_rmse / diagnosis.base_held_out_rmse
             : 0.0;
}
}  // namespace

void rank_candidates(Diagnosis& diagnosis, std::vector<CandidateResult> results,
                     const DiagnoseOptions& options) {
  for (CandidateResult& result : results) {
    result.delta_bic = result.bic - diagnosis.base_bic;
    const double rmse = std::sqrt(result.rss / static_cast<double>(diagnosis.samples));
    result.improvement = diagnosis.base_rmse > 0.0 ? 1.0 - rmse / diagnosis.base_rmse : 0.0;
    // The error over all trials must fall too. A likelihood that weighs an ensemble's spread
    // can favour a candidate whose spread covers misses its mean makes (seen: a static friction
    // fitted to one placement a trial, RMS error up 95 %, BIC down 2979): that calls the
    // failure chance, and a user pasting it in would watch the error rise.
    result.proposed = result.delta_bic < -options.min_bic_drop &&
                      held_out_gain(diagnosis, result) > options.min_held_out_gain &&
                      result.improvement > 0.0;
  }
  std::sort(results.begin(), results.end(),
            [](const CandidateResult& a, const CandidateResult& b) { return a.bic < b.bic; });
  // The refitted base is the null an effect must beat: no effect is proposed that does not
  // lower the BIC by min_bic_drop below it, and the refit is never proposed as an effect.
  const auto null = std::find_if(results.begin(), results.end(), [](const CandidateResult& r) {
    return r.law == kRecalibratedBase;
  });
  if (null != results.end()) {
    const bool null_passes = null->proposed;
    for (CandidateResult& result : results) {
      if (&result != &*null && result.bic > null->bic - options.min_bic_drop) {
        result.proposed = false;
      }
    }
    null->proposed = false;
    const bool an_effect_passes = std::any_of(results.begin(), results.end(),
                                              [](const CandidateResult& r) { return r.proposed; });
    diagnosis.base_off = null_passes && !an_effect_passes;
    // The proposal goes to the best effect, which may rank after the refit only when it is
    // not proposed; keep the proposed one first.
    std::stable_partition(results.begin(), results.end(),
                          [](const CandidateResult& r) { return r.proposed; });
  }
  // Only the best may be proposed: the effects compete to explain the same residual. Another
  // that predicts the held-out trial as well and comes within min_bic_drop of the best is
  // named: the data then cannot tell the two apart (on slide onset angles a resting friction
  // and a rolling resistance both raise the angle), and the proposal says so.
  if (!results.empty() && results[0].proposed) {
    for (std::size_t k = 1; k < results.size(); ++k) {
      if (results[k].bic - results[0].bic >= options.min_bic_drop) break;
      if (held_out_gain(diagnosis, results[k]) > options.min_held_out_gain) {
        diagnosis.indistinct_from = results[k].law;
        diagnosis.indistinct_bic_gap = results[k].bic - results[0].bic;
        break;
      }
    }
  }
  for (std::size_t k = 1; k < results.size(); ++k) results[k].proposed = false;
  diagnosis.ranked = std::move(results);
}

std::string diagnosis_verdict(const Diagnosis& diagnosis, const DiagnoseOptions& options) {
  std::ostringstream verdict;
  verdict.precision(3);
  if (diagnosis.base_off) {
    const auto null =
        std::find_if(diagnosis.ranked.begin(), diagnosis.ranked.end(),
                     [](const CandidateResult& r) { return r.law == kRecalibratedBase; });
    verdict << "the base model is off, not missing an effect: refitting";
    for (const auto& [name, value] : null->fitted) verdict << " " << name << " to " << value;
    verdict << " explains the failure (RMS error down " << 100.0 * null->improvement
            << " %, BIC by " << -null->delta_bic << ") and no effect does better by "
            << options.min_bic_drop
            << " of BIC: calibrate the base model (linectl calibrate) and diagnose again";
  } else if (!diagnosis.ranked.empty() && diagnosis.ranked.front().proposed) {
    const CandidateResult& best = diagnosis.ranked.front();
    verdict << best.law << " explains the failure: RMS error falls by " << 100.0 * best.improvement
            << " % (held-out trial '" << diagnosis.held_out_trial << "' "
            << diagnosis.base_held_out_rmse << " -> " << best.held_out_rmse << "), BIC by "
            << -best.delta_bic;
    if (best.model_spread > 0.0) {
      verdict << "; the fitted ensemble's own spread is " << best.model_spread
              << " (RMS), which adds to the noise";
    }
    const double fitted_rmse = std::sqrt(best.rss / static_cast<double>(diagnosis.samples));
    const double floor_si = std::hypot(diagnosis.noise_si, best.model_spread);
    if (floor_si > 0.0 && fitted_rmse > 2.0 * floor_si) {
      verdict << "; with it the model is still " << fitted_rmse / floor_si
              << " noise sigmas off, so part of the failure is left unexplained";
    }
    if (!diagnosis.indistinct_from.empty()) {
      verdict << ". But " << diagnosis.indistinct_from << " explains it nearly as well (BIC only "
              << diagnosis.indistinct_bic_gap << " higher, under " << options.min_bic_drop
              << "): this data cannot tell the two apart, so measure under a condition where "
                 "they differ before trusting either";
    }
  } else {
    const bool by_spread_only = !diagnosis.ranked.empty() &&
                                diagnosis.ranked.front().delta_bic < -options.min_bic_drop &&
                                diagnosis.ranked.front().improvement <= 0.0;
    if (by_spread_only) {
      const CandidateResult& best = diagnosis.ranked.front();
      verdict << best.law << " ranks first (BIC down " << -best.delta_bic
              << ") only through its own spread (" << best.model_spread
              << " RMS): its answers miss by more than the base model's (RMS error up "
              << -100.0 * best.improvement
              << " %), so it calls the failure chance and is not proposed. ";
      if (diagnosis.placement == "relaid") {
        verdict << "The repetitions were re-laid already: diagnose with a larger ensemble, so "
                   "that the model's spread is measured better. ";
      } else {
        verdict << "Repetitions of one placement say little of an answer that turns on the "
                   "placement: measure with the fillet re-laid for each repetition (placement: "
                   "relaid), or diagnose with a larger ensemble. ";
      }
    }
    // The base model's own misfit in noise sigmas (an ensemble's spread counts as noise).
    const double floor_si = std::hypot(diagnosis.noise_si, diagnosis.base_model_spread);
    const bool base_fails = floor_si > 0.0 && diagnosis.base_rmse > 2.0 * floor_si;
    std::string lead = base_fails        ? "no candidate explains the failure: base RMS "
                       : floor_si == 0.0 ? "no candidate is proposed: base RMS "
                                         : "nothing missing among the candidates: base RMS ";
    if (by_spread_only) lead.front() = static_cast<char>(std::toupper(lead.front()));
    verdict << lead << diagnosis.base_rmse;
    if (diagnosis.noise_si > 0.0) verdict << " against noise " << diagnosis.noise_si;
    if (!by_spread_only) {
      verdict << "; the best-ranked effect does not lower the BIC by " << options.min_bic_drop
              << " and the held-out error by " << 100.0 * options.min_held_out_gain << " %";
    }
    if (floor_si == 0.0) {
      verdict << ". The dataset gives no noise for " << diagnosis.channel
              << ", so whether the base model fits cannot be judged: give it in the manifest";
    }
    if (base_fails) {
      verdict << ". The base model is " << diagnosis.base_rmse / floor_si
              << " noise sigmas off: calibrate its base parameters (linectl calibrate), or check "
                 "the dataset's conditions, units and signs against docs/measurements.md";
    }
  }
  const double first_pose_spread =
      std::max(diagnosis.base_first_pose_spread, diagnosis.best_first_pose_spread);
  if (first_pose_spread > diagnosis.first_pose_spread_allowed && diagnosis.noise_si > 0.0) {
    verdict << (diagnosis.experiment == ExperimentType::kSlide
                    ? ". But the onset turns on how the fillet lies: placements turned within "
                      "the tolerance move it by "
                    : ". But the tracks hang on stick or slip: first poses moved within the "
                      "noise move them by ")
            << first_pose_spread << " RMS (" << first_pose_spread / diagnosis.noise_si
            << " noise sigmas), so one run a trial fits chance; diagnose again with --ensemble 8";
  }
  return verdict.str();
}

Diagnosis diagnose(const Dataset& dataset, const model_tests::CommonParams& base,
                   const std::vector<EffectCandidate>& candidates, const DiagnoseOptions& options) {
  const std::string_view channel = judged_channel(dataset.experiment);
  if (dataset.trials.size() < 2) {
    throw std::invalid_argument("diagnose needs two trials or more: one is held out");
  }
  Diagnosis diagnosis;
  diagnosis.channel = std::string(channel);
  diagnosis.experiment = dataset.experiment;
  const auto noise = dataset.noise_si.find(channel);
  diagnosis.noise_si = noise == dataset.noise_si.end() ? 0.0 : noise->second;
  const std::optional<RepetitionScoring> scoring =
      detail::repetition_scoring(dataset, options.twin);
  diagnosis.score = scoring ? "repetition_likelihood" : "residual_sum";
  std::vector<std::size_t> all_trials(dataset.trials.size());
  std::vector<double> base_trial_rmse(dataset.trials.size());
  Residuals base_all;
  for (std::size_t k = 0; k < all_trials.size(); ++k) {
    all_trials[k] = k;
    const Residuals trial = residuals(dataset, base, {k}, options.twin);
    base_trial_rmse[k] = std::sqrt(trial.rss / static_cast<double>(trial.samples));
    base_all.rss += trial.rss;
    base_all.samples += trial.samples;
    base_all.spread_ss += trial.spread_ss;
    base_all.trials.insert(base_all.trials.end(), trial.trials.begin(), trial.trials.end());
  }
  // The placement the residuals read of every trial (one reader of the condition).
  for (const detail::TrialRepetitions& trial : base_all.trials) {
    const std::string placement = trial.placement == detail::Placement::kRelaid     ? "relaid"
                                  : trial.placement == detail::Placement::kLaidOnce ? "laid_once"
                                                                                    : "";
    if (&trial == &base_all.trials.front()) {
      diagnosis.placement = placement;
    } else if (placement != diagnosis.placement) {
      diagnosis.placement = "mixed";
    }
  }
  const std::size_t held_out = held_out_trial(dataset, base_trial_rmse);
  diagnosis.held_out_trial = dataset.trials[held_out].id;
  std::vector<std::size_t> fit_trials;
  for (const std::size_t k : all_trials) {
    if (k != held_out) fit_trials.push_back(k);
  }
  diagnosis.samples = base_all.samples;
  diagnosis.base_rmse = std::sqrt(base_all.rss / static_cast<double>(base_all.samples));
  diagnosis.base_bic = bic(base_all, scoring, 0);
  diagnosis.base_held_out_rmse = base_trial_rmse[held_out];
  diagnosis.base_model_spread =
      std::sqrt(base_all.spread_ss / static_cast<double>(base_all.samples));
  spdlog::info("diagnose: base model RMS {:.4g} (SI) over {} samples, held out '{}', judged by {}",
               diagnosis.base_rmse, diagnosis.samples, diagnosis.held_out_trial, diagnosis.score);

  // The refitted base beside the effects: the null each must beat.
  std::vector<EffectCandidate> fitted_candidates = candidates;
  if (options.recalibrate_base) {
    if (auto null = recalibration_candidate(dataset.experiment, base.base_spec)) {
      fitted_candidates.push_back(std::move(*null));
    }
  }
  const std::vector<EffectCandidate>& all_candidates = fitted_candidates;
  // Candidates in parallel: each fit runs its own twins, nothing shared but the inputs.
  std::vector<CandidateResult> results(all_candidates.size());
  std::mutex next_mutex;
  std::size_t next = 0;
  const auto worker = [&] {
    for (;;) {
      std::size_t index = 0;
      {
        const std::lock_guard<std::mutex> lock(next_mutex);
        if (next == all_candidates.size()) return;
        index = next++;
      }
      results[index] = fit(dataset, base, all_candidates[index], fit_trials, all_trials, held_out,
                           options, scoring);
      spdlog::info("diagnose: {} fitted in {} twin evaluations", all_candidates[index].law,
                   results[index].evaluations);
    }
  };
  std::vector<std::thread> threads;
  const int thread_count = std::clamp(
      options.threads, 1, static_cast<int>(std::max<std::size_t>(all_candidates.size(), 1)));
  threads.reserve(static_cast<std::size_t>(thread_count));
  for (int t = 0; t < thread_count; ++t) threads.emplace_back(worker);
  for (std::thread& thread : threads) thread.join();

  rank_candidates(diagnosis, std::move(results), options);

  // Line tracks or slide from one run a trial: would the answers move if the fillet started
  // elsewhere within what the measurement leaves open? A probe ensemble of the base model and
  // of the best fit says.
  const bool probe_tracks = dataset.experiment == ExperimentType::kLineTracks &&
                            options.twin.line_tracks.ensemble_runs == 1 &&
                            line_tracks_channel_without_noise(dataset).empty();
  const bool probe_slide = dataset.experiment == ExperimentType::kSlide &&
                           options.twin.slide.ensemble_runs == 1 && diagnosis.noise_si > 0.0;
  if (probe_tracks || probe_slide) {
    diagnosis.first_pose_spread_allowed = (probe_slide ? 1.0 : 2.0) * diagnosis.noise_si;
    TwinSettings probe = options.twin;
    probe.line_tracks.ensemble_runs = kFirstPoseProbeRuns;
    probe.slide.ensemble_runs = kFirstPoseProbeRuns;
    const auto spread_of = [&](const model_tests::CommonParams& model) {
      const Residuals r = residuals(dataset, model, all_trials, probe);
      return std::sqrt(r.spread_ss / static_cast<double>(r.samples));
    };
    // The probe only advises: a start it cannot run (a turned fillet that never slides, a
    // jittered track that goes unstable) costs the advice, never the diagnosis.
    try {
      diagnosis.base_first_pose_spread = spread_of(base);
      if (!diagnosis.ranked.empty() && diagnosis.ranked.front().law != kRecalibratedBase) {
        const CandidateResult& best = diagnosis.ranked.front();
        HiddenEffect effect{best.law, best.fitted};
        model_tests::CommonParams fitted = base;
        fitted.base_spec = with_experiment_effect(base.base_spec, dataset.experiment, effect);
        diagnosis.best_first_pose_spread = spread_of(fitted);
      }
    } catch (const std::exception& error) {
      diagnosis.base_first_pose_spread = 0.0;
      diagnosis.best_first_pose_spread = 0.0;
      spdlog::warn(
          "diagnose: the probe of other starts could not run ({}); no advice on an "
          "ensemble",
          error.what());
    }
    spdlog::info(
        "diagnose: starts within what the data leaves open move the answers by {:.3g} (base) "
        "and {:.3g} (best fit), RMS",
        diagnosis.base_first_pose_spread, diagnosis.best_first_pose_spread);
  }

  // Where the error fell, trial by trial, for the first-ranked fit (from its fit's run over
  // all trials).
  if (!diagnosis.ranked.empty() &&
      diagnosis.ranked.front().trial_rmse.size() == all_trials.size()) {
    const std::vector<double>& fitted_rmse = diagnosis.ranked.front().trial_rmse;
    for (const std::size_t k : all_trials) {
      diagnosis.by_trial.push_back({dataset.trials[k].id, base_trial_rmse[k], fitted_rmse[k]});
    }
  }
  diagnosis.verdict = diagnosis_verdict(diagnosis, options);
  return diagnosis;
}

HiddenEffect proposed_effect(const Diagnosis& diagnosis) {
  HiddenEffect effect;
  if (!diagnosis.ranked.empty() && diagnosis.ranked.front().proposed) {
    effect.law = diagnosis.ranked.front().law;
    effect.parameters = diagnosis.ranked.front().fitted;
  }
  return effect;
}

std::string diagnosis_json(const Diagnosis& diagnosis) {
  nlohmann::json json{{"channel", diagnosis.channel},
                      {"score", diagnosis.score},
                      {"placement", diagnosis.placement},
                      {"samples", diagnosis.samples},
                      {"noise_si", diagnosis.noise_si},
                      {"base_rmse_si", diagnosis.base_rmse},
                      {"base_bic", diagnosis.base_bic},
                      {"held_out_trial", diagnosis.held_out_trial},
                      {"base_held_out_rmse_si", diagnosis.base_held_out_rmse},
                      {"base_model_spread_si", diagnosis.base_model_spread},
                      {"base_first_pose_spread_si", diagnosis.base_first_pose_spread},
                      {"best_first_pose_spread_si", diagnosis.best_first_pose_spread},
                      {"first_pose_spread_allowed_si", diagnosis.first_pose_spread_allowed},
                      {"indistinct_from", diagnosis.indistinct_from},
                      {"indistinct_bic_gap", diagnosis.indistinct_bic_gap},
                      {"base_off", diagnosis.base_off},
                      {"verdict", diagnosis.verdict}};
  nlohmann::json ranked = nlohmann::json::array();
  for (const CandidateResult& r : diagnosis.ranked) {
    ranked.push_back({{"law", r.law},
                      {"fitted", r.fitted},
                      {"rss", r.rss},
                      {"bic", r.bic},
                      {"delta_bic", r.delta_bic},
                      {"held_out_rmse_si", r.held_out_rmse},
                      {"improvement", r.improvement},
                      {"model_spread_si", r.model_spread},
                      {"proposed", r.proposed},
                      {"evaluations", r.evaluations}});
  }
  json["ranked"] = ranked;
  nlohmann::json by_trial = nlohmann::json::array();
  for (const Diagnosis::TrialError& t : diagnosis.by_trial) {
    by_trial.push_back(
        {{"trial", t.trial}, {"base_rmse_si", t.base_rmse}, {"fitted_rmse_si", t.fitted_rmse}});
  }
  json["by_trial"] = by_trial;
  return json.dump(1);
}

}  // namespace fl::workbench
