// What diagnose and calibrate share: the channel judged per experiment type, the residuals
// of a model (a base spec) over chosen trials, and the local search that fits parameters.
#pragma once

#include <cstddef>
#include <functional>
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

struct Residuals {
  double rss = 0.0;
  std::size_t samples = 0;
  // Sum of the squared spread of an ensemble twin over the same rows (0 for one run).
  double spread_ss = 0.0;
};

// Sum of squared residuals of the judged channel over the chosen trials, the twin built from
// `common` and `settings`. Throws what the twin throws for a trial it cannot run.
Residuals residuals(const Dataset& dataset, const model_tests::CommonParams& common,
                    const std::vector<std::size_t>& trials, const TwinSettings& settings = {});

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
double minimise_in_unit_box(const UnitBoxObjective& objective, std::vector<double>& x,
                            double start_value, double initial_step, int max_evaluations,
                            std::string_view who);

}  // namespace fl::workbench::detail
