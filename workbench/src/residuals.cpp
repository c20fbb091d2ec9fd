#include "residuals.hpp"

#include <nlopt.h>
#include <spdlog/spdlog.h>

#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

#include "fl/workbench/twin_models.hpp"

namespace fl::workbench::detail {

std::string_view judged_channel(ExperimentType type) {
  // The first response channel: for line tracks x, along the belt, where a slip shows.
  return response_channels(type).front();
}

Residuals residuals(const Dataset& dataset, const model_tests::CommonParams& common,
                    const std::vector<std::size_t>& trials, const TwinSettings& settings) {
  const std::string_view channel = judged_channel(dataset.experiment);
  const std::unique_ptr<TrialModel> model = make_twin_model(dataset.experiment, common, settings);
  const std::string spread_channel = std::string(channel) + "_spread";
  Residuals r;
  for (const std::size_t index : trials) {
    const Trial& trial = dataset.trials[index];
    const Table predicted = model->run(dataset, trial);
    const std::vector<double>& measured = trial.data.at(channel).values_si;
    const std::vector<double>& modelled = predicted.at(channel).values_si;
    for (std::size_t k = 0; k < measured.size(); ++k) {
      const double e = modelled[k] - measured[k];
      r.rss += e * e;
    }
    if (const Channel* spread = predicted.find(spread_channel); spread != nullptr) {
      for (const double s : spread->values_si) r.spread_ss += s * s;
    }
    r.samples += measured.size();
  }
  return r;
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
                            std::string_view who) {
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
    const bool gained = found_value < 0.99 * best;
    if (found_value < best) {
      best = found_value;
      x = found;
    }
    if (!gained || status < 0) break;
  }
  return best;
}

}  // namespace fl::workbench::detail
