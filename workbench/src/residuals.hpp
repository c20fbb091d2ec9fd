// What diagnose and calibrate share: the channel judged per experiment type, the residuals
// of a model (a base spec) over chosen trials, and the local search that fits parameters.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <string_view>
#include <vector>

#include "fl/twin/model_tests/fixtures.hpp"
#include "fl/workbench/dataset.hpp"
#include "fl/workbench/twin_models.hpp"

namespace fl::workbench::detail {

// The channel judged for an experiment type (the twin and where an effect goes follow from
// the type too: make_twin_model, with_experiment_effect). Throws std::invalid_argument for a
// type the twin does not reproduce.
std::string_view judged_channel(ExperimentType type);

// How a trial's repetitions were laid (a slide trial's `placement` condition).
enum class Placement : std::uint8_t { kUnstated, kRelaid, kLaidOnce };

// One trial's rows read as repetitions of one answer (a slide's onset angle): what the
// repetition deviance needs of it.
struct TrialRepetitions {
  Placement placement = Placement::kUnstated;
  std::size_t rows = 0;
  double measured_mean = 0.0;
  double within_ss = 0.0;  // the measured rows' squared scatter about their mean
  double model_mean = 0.0;
  double model_spread = 0.0;  // an ensemble twin's spread (0 for one run)
  double rss = 0.0;           // the trial's own share of Residuals::rss
};

struct Residuals {
  double rss = 0.0;
  std::size_t samples = 0;
  // Sum of the squared spread of an ensemble twin over the same rows (0 for one run).
  double spread_ss = 0.0;
  std::vector<TrialRepetitions> trials;  // one a trial, in the order asked for
};

// Sum of squared residuals of the judged channel over the chosen trials, the twin built from
// `common` and `settings`. Throws what the twin throws for a trial it cannot run, and
// std::invalid_argument for a placement condition other than relaid or laid_once.
Residuals residuals(const Dataset& dataset, const model_tests::CommonParams& common,
                    const std::vector<std::size_t>& trials, const TwinSettings& settings = {});

// How an ensemble twin is judged on an experiment whose rows repeat one answer a trial
// (rows_repeat_one_answer). One run a trial is judged by its residual sum; an ensemble by the
// likelihood of the rows, so that a model whose answer scatters with the fillet's placement
// pays for that scatter and is not judged by where one draw of it fell.
struct RepetitionScoring {
  // The rows' scatter about their trial's mean, pooled over the trials (SI^2): the noise, and
  // the placement scatter too where each repetition re-laid the fillet.
  double within_variance = 0.0;
  // The manifest's noise squared (0 when not stated).
  double stated_noise_variance = 0.0;
  int ensemble_runs = 1;
};

// Whether the judged channel's rows within a trial repeat one answer (slide: the onset angle).
bool rows_repeat_one_answer(ExperimentType type);

// The scoring of an ensemble on `dataset`: set for an experiment whose rows repeat one answer,
// run as an ensemble (settings), whose rows scatter (pooled over trials with 2 degrees of
// freedom or more) or whose noise is stated; empty otherwise (the residual sum judges).
std::optional<RepetitionScoring> repetition_scoring(const Dataset& dataset,
                                                    const TwinSettings& settings);

// -2 ln of the likelihood of the trials' rows. A trial's n rows are its answer plus an offset
// shared by all of them plus a scatter of their own:
//   y_i = m + d + e_i,  e_i ~ N(0, w),  d ~ N(0, shared).
// The model's spread (ensemble_spread: the members' SD s times sqrt(1 + 1/runs)) splits into
// one placement's scatter, p = s^2 = spread^2 runs / (runs + 1), and the ensemble mean's own
// error, p / runs. The mean's error is always shared; the placement scatter is shared where
// the fillet lay once for all rows, and each row's own where it was re-laid for each:
//   relaid:    w = noise^2 + p,        shared = p / runs
//   laid_once: w = noise^2,            shared = p / runs + p   (= spread^2)
//   unstated:  w = the pooled scatter, shared = p / runs plus the part of p the pooled scatter
//              does not show beyond the noise (none without a noise: re-laid, the usual lab
//              protocol, is taken)
// with noise^2 the stated noise (the pooled scatter where none is stated; then a re-laid
// trial's w is the pooled scatter too). Exact for the multivariate normal:
//   n ln 2pi + (n - 1) ln w + ln n + ln V + W / w + (mean - m)^2 / V,  V = w / n + shared,
// with W the rows' squared scatter about their mean. Throws std::invalid_argument for a
// variance of 0 (no noise stated and rows that do not scatter).
double repetition_deviance(const std::vector<TrialRepetitions>& trials,
                           const RepetitionScoring& scoring);

using UnitBoxObjective = std::function<double(const std::vector<double>&)>;

// The objective at a point, with a point it throws for or answers non-finite counted as a very
// bad one (1e300), not the end of a search: the engine refuses some parameter sets (an
// unstable timestep, say). `who` names the caller in the debug log.
double guarded_value(const UnitBoxObjective& objective, const std::vector<double>& point,
                     std::string_view who);

// A bounded, derivative-free local search over the unit box [0, 1]^n (BOBYQA; bounded
// Nelder-Mead for one dimension, which BOBYQA does not take), started at `x` with the given
// step and left at the best point found (`start_value` is the objective there, already known
// to the caller), every point guarded as by guarded_value. Returns the objective at `x`.
// It restarts from where a search stopped while a restart still gains: 1 % of the value for
// a sum of squares or an RMS (min_restart_gain 0), or min_restart_gain itself for a deviance,
// whose zero is arbitrary.
double minimise_in_unit_box(const UnitBoxObjective& objective, std::vector<double>& x,
                            double start_value, double initial_step, int max_evaluations,
                            std::string_view who, double min_restart_gain = 0.0);

}  // namespace fl::workbench::detail
