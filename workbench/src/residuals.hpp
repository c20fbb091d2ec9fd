// What diagnose and calibrate share: the channel judged per experiment type and the residuals
// of a model (a base spec) over chosen trials.
#pragma once

#include <cstddef>
#include <string_view>
#include <vector>

#include "fl/twin/model_tests/fixtures.hpp"
#include "fl/workbench/dataset.hpp"

namespace fl::workbench::detail {

// The channel judged for an experiment type (the twin and where an effect goes follow from
// the type too: make_twin_model, with_experiment_effect). Throws std::invalid_argument for a
// type the twin does not reproduce.
std::string_view judged_channel(ExperimentType type);

struct Residuals {
  double rss = 0.0;
  std::size_t samples = 0;
};

// Sum of squared residuals of the judged channel over the chosen trials, the twin built from
// `common`. Throws what the twin throws for a trial it cannot run.
Residuals residuals(const Dataset& dataset, const model_tests::CommonParams& common,
                    const std::vector<std::size_t>& trials);

}  // namespace fl::workbench::detail
