#include "residuals.hpp"

#include <memory>
#include <stdexcept>
#include <string>

#include "fl/workbench/twin_models.hpp"

namespace fl::workbench::detail {

std::string_view judged_channel(ExperimentType type) {
  switch (type) {
    case ExperimentType::kCompress:
      return "force";
    case ExperimentType::kSlide:
      return "onset_angle";
    case ExperimentType::kDrop:
      return "height";
    case ExperimentType::kLineTracks:
      return "x";  // along the belt: where a slip shows
    default:
      throw std::invalid_argument(
          "the workbench fits the twin to compress, slide, drop and line_tracks datasets, not " +
          std::string(to_string(type)));
  }
}

Residuals residuals(const Dataset& dataset, const model_tests::CommonParams& common,
                    const std::vector<std::size_t>& trials) {
  const std::string_view channel = judged_channel(dataset.experiment);
  const std::unique_ptr<TrialModel> model = make_twin_model(dataset.experiment, common);
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
    r.samples += measured.size();
  }
  return r;
}

}  // namespace fl::workbench::detail
