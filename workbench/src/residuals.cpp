#include "residuals.hpp"

#include <nlopt.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <variant>

#include "fl/workbench/twin_models.hpp"

namespace fl::workbench::detail {

std::string_view judged_channel(ExperimentType type) {
  // The first response channel: for line tracks x, along the belt, where a slip shows.
  return response_channels(type).front();
}

namespace {

Placement placement_of(const Trial& trial) {
  const auto found = trial.conditions.find("placement");
  if (found == trial.conditions.end()) return Placement::kUnstated;
  const std::string* label = std::get_if<std::string>(&found->second);
  if (label != nullptr && *label == "relaid") return Placement::kRelaid;
  if (label != nullptr && *label == "laid_once") return Placement::kLaidOnce;
  // The loader refuses other labels; a dataset made in code may not have been loaded.
  throw std::invalid_argument("trial '" + trial.id +
                              "': placement is neither relaid nor laid_once");
}

}  // namespace

Residuals residuals(const Dataset& dataset, const model_tests::CommonParams& common,
                    const std::vector<std::size_t>& trials, const TwinSettings& settings) {
  const std::string_view channel = judged_channel(dataset.experiment);
  const std::unique_ptr<TrialModel> model = make_twin_model(dataset.experiment, common, settings);
  const std::string spread_channel = std::string(channel) + "_spread";
  Residuals r;
  for (const std::size_t index : trials) {
    const Trial& trial = dataset.trials[index];
    TrialRepetitions repetitions;
    repetitions.placement = placement_of(trial);  // before the twin runs: refused at once
    const Table predicted = model->run(dataset, trial);
    const std::vector<double>& measured = trial.data.at(channel).values_si;
    const std::vector<double>& modelled = predicted.at(channel).values_si;
    repetitions.rows = measured.size();
    double spread_ss = 0.0;
    for (std::size_t k = 0; k < measured.size(); ++k) {
      const double e = modelled[k] - measured[k];
      // Summed row by row into both: the total keeps its order of addition (a fit's path
      // hangs on its round-off).
      r.rss += e * e;
      repetitions.rss += e * e;
      repetitions.measured_mean += measured[k];
      repetitions.model_mean += modelled[k];
    }
    if (const Channel* spread = predicted.find(spread_channel); spread != nullptr) {
      for (const double s : spread->values_si) spread_ss += s * s;
    }
    r.spread_ss += spread_ss;
    r.samples += measured.size();
    if (!measured.empty()) {
      const auto rows = static_cast<double>(measured.size());
      repetitions.measured_mean /= rows;
      repetitions.model_mean /= rows;
      repetitions.model_spread = std::sqrt(spread_ss / rows);
      for (const double y : measured) {
        repetitions.within_ss += (y - repetitions.measured_mean) * (y - repetitions.measured_mean);
      }
    }
    r.trials.push_back(repetitions);
  }
  return r;
}

bool rows_repeat_one_answer(ExperimentType type) { return type == ExperimentType::kSlide; }

std::optional<RepetitionScoring> repetition_scoring(const Dataset& dataset,
                                                    const TwinSettings& settings) {
  if (!rows_repeat_one_answer(dataset.experiment) || settings.slide.ensemble_runs < 2) {
    return std::nullopt;
  }
  const std::string_view channel = judged_channel(dataset.experiment);
  RepetitionScoring scoring;
  scoring.ensemble_runs = settings.slide.ensemble_runs;
  if (const auto noise = dataset.noise_si.find(channel); noise != dataset.noise_si.end()) {
    scoring.stated_noise_variance = noise->second * noise->second;
  }
  double within_ss = 0.0;
  std::size_t degrees_of_freedom = 0;
  for (const Trial& trial : dataset.trials) {
    const std::vector<double>& rows = trial.data.at(channel).values_si;
    if (rows.size() < 2) continue;
    double mean = 0.0;
    for (const double y : rows) mean += y;
    mean /= static_cast<double>(rows.size());
    for (const double y : rows) within_ss += (y - mean) * (y - mean);
    degrees_of_freedom += rows.size() - 1;
  }
  // Two degrees of freedom at least: one difference of two rows says too little of a scatter.
  if (degrees_of_freedom >= 2 && within_ss > 0.0) {
    scoring.within_variance = within_ss / static_cast<double>(degrees_of_freedom);
  } else {
    scoring.within_variance = scoring.stated_noise_variance;
  }
  if (scoring.within_variance <= 0.0) return std::nullopt;
  return scoring;
}

double repetition_deviance(const std::vector<TrialRepetitions>& trials,
                           const RepetitionScoring& scoring) {
  constexpr double kTwoPi = 6.283185307179586;
  const double pooled = scoring.within_variance;
  const bool noise_stated = scoring.stated_noise_variance > 0.0;
  const double noise_sq = noise_stated ? scoring.stated_noise_variance : pooled;
  // Unstated: the part of the pooled scatter beyond the stated noise is placement scatter the
  // rows already show; without a stated noise all of it is taken to be (re-laid).
  const double shown =
      noise_stated ? std::max(0.0, pooled - noise_sq) : std::numeric_limits<double>::infinity();
  double deviance = 0.0;
  for (const TrialRepetitions& trial : trials) {
    if (trial.rows == 0) continue;
    const auto n = static_cast<double>(trial.rows);
    // The spread is the members' SD s times sqrt(1 + 1/N) (ensemble_spread): one placement
    // scatters by s^2, the ensemble mean errs by s^2 / N, and the two add up to spread^2.
    const double runs = scoring.ensemble_runs;
    const double spread_sq = trial.model_spread * trial.model_spread;
    const double placement_sq = spread_sq * runs / (runs + 1.0);
    const double mean_error = placement_sq / runs;
    double w = pooled;
    double shared = mean_error + std::max(0.0, placement_sq - shown);
    if (trial.placement == Placement::kRelaid) {
      w = noise_stated ? noise_sq + placement_sq : pooled;
      shared = mean_error;
    } else if (trial.placement == Placement::kLaidOnce) {
      w = noise_sq;
      shared = mean_error + placement_sq;
    }
    if (!(w > 0.0)) {
      throw std::invalid_argument(
          "repetition deviance: no scatter to judge an offset against (no noise stated and "
          "rows that do not scatter)");
    }
    const double v = w / n + shared;
    const double offset = trial.measured_mean - trial.model_mean;
    deviance += n * std::log(kTwoPi) + (n - 1.0) * std::log(w) + std::log(n) + std::log(v) +
                trial.within_ss / w + offset * offset / v;
  }
  return deviance;
}

double guarded_value(const UnitBoxObjective& objective, const std::vector<double>& point,
                     std::string_view who) {
  try {
    const double value = objective(point);
    return std::isfinite(value) ? value : 1e300;
  } catch (const std::exception& error) {
    spdlog::debug("{}: the twin refused a point: {}", who, error.what());
    return 1e300;
  }
}

namespace {

struct SearchContext {
  const UnitBoxObjective* objective = nullptr;
  std::string_view who;
};

double nlopt_objective(unsigned n, const double* x, double* gradient, void* data) {
  (void)gradient;  // derivative-free
  const auto& context = *static_cast<const SearchContext*>(data);
  return guarded_value(*context.objective, std::vector<double>(x, x + n), context.who);
}

}  // namespace

double minimise_in_unit_box(const UnitBoxObjective& objective, std::vector<double>& x,
                            double start_value, double initial_step, int max_evaluations,
                            std::string_view who, double min_restart_gain) {
  const auto dimensions = static_cast<unsigned>(x.size());
  SearchContext context{&objective, who};
  const std::vector<double> lower(dimensions, 0.0);
  const std::vector<double> upper(dimensions, 1.0);
  double best = start_value;
  int evaluations_left = max_evaluations;
  // A twin's objective is not smooth at fine scale (a swinging bend's mean angle, contacts
  // that stick or slip), and a model's quadratic can then stop BOBYQA short of the valley's
  // floor. So the search starts once more from where it stopped, with a smaller step, and
  // keeps going while a restart still gains more than 1 %.
  for (double step_size = initial_step; evaluations_left > 0; step_size *= 0.5) {
    const std::vector<double> step(dimensions, step_size);
    nlopt_opt optimiser =
        nlopt_create(dimensions >= 2 ? NLOPT_LN_BOBYQA : NLOPT_LN_NELDERMEAD, dimensions);
    nlopt_set_lower_bounds(optimiser, lower.data());
    nlopt_set_upper_bounds(optimiser, upper.data());
    nlopt_set_min_objective(optimiser, nlopt_objective, &context);
    nlopt_set_maxeval(optimiser, evaluations_left);
    nlopt_set_xtol_rel(optimiser, 1e-3);
    nlopt_set_initial_step(optimiser, step.data());
    std::vector<double> found = x;
    double found_value = best;
    const nlopt_result status = nlopt_optimize(optimiser, found.data(), &found_value);
    evaluations_left -= nlopt_get_numevals(optimiser);
    nlopt_destroy(optimiser);
    if (status < 0) {
      spdlog::warn("{}: the local search stopped with status {}", who, static_cast<int>(status));
    }
    const bool gained =
        min_restart_gain > 0.0 ? found_value < best - min_restart_gain : found_value < 0.99 * best;
    if (found_value < best) {
      best = found_value;
      x = found;
    }
    if (!gained || status < 0) break;
  }
  return best;
}

}  // namespace fl::workbench::detail
