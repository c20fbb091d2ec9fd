// Which trial the diagnosis holds out: a fit on the other trials must predict it. Hand-made
// trials; only their ids and conditions matter here.
#include <gtest/gtest.h>

#include <stdexcept>

#include "fl/workbench/diagnose.hpp"

namespace fl::workbench {
namespace {

Dataset trials(const std::vector<std::pair<std::string, std::optional<double>>>& id_and_rate) {
  Dataset dataset;
  for (const auto& [id, rate] : id_and_rate) {
    Trial trial;
    trial.id = id;
    if (rate) trial.conditions["rate"] = *rate;
    dataset.trials.push_back(trial);
  }
  return dataset;
}

TEST(HeldOutTrial, WithRatesTheFastestIsHeldOutWhateverTheErrors) {
  // The 0.5 mm/s trial is the base model's worst, but a rate law is judged on extrapolation.
  const Dataset data = trials({{"slow", 0.5}, {"fast", 5.0}, {"fast_again", 5.0}, {"mid", 1.0}});
  EXPECT_EQ(held_out_trial(data, {9.0, 1.0, 1.0, 2.0}), 1U);  // the first of the fastest
}

TEST(HeldOutTrial, WithoutRatesTheBaseModelsWorstTrialIsHeldOut) {
  // A wet film lowers the onset on wet trials only: the dry trials' errors are at the noise,
  // the wet ones' are not, so a wet trial is held out wherever it lies in the dataset.
  const Dataset data = trials({{"a_dry", {}}, {"a_wet", {}}, {"b_dry", {}}, {"b_wet", {}}});
  EXPECT_EQ(held_out_trial(data, {0.3, 7.0, 0.3, 6.0}), 1U);
  EXPECT_EQ(held_out_trial(data, {0.3, 6.0, 0.3, 7.0}), 3U);
  // Equal errors (a perfect base model): the last trial.
  EXPECT_EQ(held_out_trial(data, {1.0, 1.0, 1.0, 1.0}), 3U);
}

TEST(HeldOutTrial, ErrorsThatDoNotMatchTheTrialsAreRefused) {
  const Dataset data = trials({{"a", {}}, {"b", {}}});
  EXPECT_THROW(static_cast<void>(held_out_trial(data, {1.0})), std::invalid_argument);
  EXPECT_THROW(static_cast<void>(held_out_trial(Dataset{}, {})), std::invalid_argument);
}

}  // namespace
}  // namespace fl::workbench
