// The likelihood that judges an ensemble on repeated rows (a slide's onset angles): checked
// against the multivariate normal density written out with Eigen, and on the cases it exists
// for. Pure arithmetic: no twin runs.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <numbers>
#include <vector>

#include "residuals.hpp"

namespace fl::workbench::detail {
namespace {

// A trial whose rows are `rows`, modelled as `model_mean` with spread `model_spread`.
TrialRepetitions trial_of(const std::vector<double>& rows, double model_mean, double model_spread) {
  TrialRepetitions trial;
  trial.rows = rows.size();
  for (const double y : rows) trial.measured_mean += y;
  trial.measured_mean /= static_cast<double>(rows.size());
  for (const double y : rows) {
    trial.within_ss += (y - trial.measured_mean) * (y - trial.measured_mean);
  }
  trial.model_mean = model_mean;
  trial.model_spread = model_spread;
  return trial;
}

// -2 ln of the N(mean 1, w I + shared 1 1^T) density at `rows`, from the covariance itself.
double direct_deviance(const std::vector<double>& rows, double mean, double w, double shared) {
  const auto n = static_cast<Eigen::Index>(rows.size());
  const Eigen::MatrixXd covariance =
      w * Eigen::MatrixXd::Identity(n, n) + shared * Eigen::MatrixXd::Ones(n, n);
  Eigen::VectorXd offset(n);
  for (Eigen::Index i = 0; i < n; ++i) offset(i) = rows[static_cast<std::size_t>(i)] - mean;
  const Eigen::LLT<Eigen::MatrixXd> cholesky(covariance);
  const double log_det = 2.0 * cholesky.matrixL().toDenseMatrix().diagonal().array().log().sum();
  return static_cast<double>(n) * std::log(2.0 * std::numbers::pi) + log_det +
         offset.dot(cholesky.solve(offset));
}

// Five rows about 10 with an uneven scatter, so the within and offset terms both count.
const std::vector<double> kRows{10.3, 9.6, 10.9, 10.1, 9.8};
const std::vector<double> kOtherRows{12.0, 12.5, 11.6};

// The scoring of these tests: rows pooled at 0.3 against a stated noise of 0.25 (0.5 squared),
// an ensemble of four. The model's spread^2 is 0.45: one placement's scatter 0.36 (0.45 x 4/5,
// ensemble_spread's sqrt(1 + 1/4) taken out) and the mean's own error 0.36 / 4 = 0.09.
const RepetitionScoring kScoring{
    .within_variance = 0.3, .stated_noise_variance = 0.25, .ensemble_runs = 4};
const double kSpread = std::sqrt(0.45);

TrialRepetitions placed(TrialRepetitions trial, Placement placement) {
  trial.placement = placement;
  return trial;
}

TEST(RepetitionDeviance, LaidOnceIsTheMultivariateNormalOfRowsSharingTheWholeSpread) {
  // The rows scatter by the stated noise only (not the pooled 0.3) and share one placement's
  // offset plus the ensemble mean's own error: 0.36 + 0.09, the whole spread^2.
  const std::vector<TrialRepetitions> trials{
      placed(trial_of(kRows, 9.5, kSpread), Placement::kLaidOnce),
      placed(trial_of(kOtherRows, 12.4, kSpread), Placement::kLaidOnce)};
  const double shared = 0.45;
  const double expected =
      direct_deviance(kRows, 9.5, 0.25, shared) + direct_deviance(kOtherRows, 12.4, 0.25, shared);
  EXPECT_NEAR(repetition_deviance(trials, kScoring), expected, 1e-9 * std::abs(expected));
}

TEST(RepetitionDeviance, RelaidRowsScatterByTheSpreadAndShareOnlyTheMeansError) {
  // Each row its own placement: noise and placement scatter every row (0.25 + 0.36).
  const std::vector<TrialRepetitions> trials{
      placed(trial_of(kRows, 9.5, kSpread), Placement::kRelaid)};
  const double expected = direct_deviance(kRows, 9.5, 0.61, 0.09);
  EXPECT_NEAR(repetition_deviance(trials, kScoring), expected, 1e-9 * std::abs(expected));
  // Without a stated noise the pooled scatter is all there is to go on.
  const RepetitionScoring unstated_noise{.within_variance = 0.3, .ensemble_runs = 4};
  const double pooled = direct_deviance(kRows, 9.5, 0.3, 0.09);
  EXPECT_NEAR(repetition_deviance(trials, unstated_noise), pooled, 1e-9 * std::abs(pooled));
}

TEST(RepetitionDeviance, AnUnstatedPlacementSharesTheSpreadTheRowsDoNotShow) {
  const std::vector<TrialRepetitions> trials{trial_of(kRows, 9.5, kSpread)};
  const auto scored = [&](double pooled, double noise_sq) {
    return repetition_deviance(
        trials, {.within_variance = pooled, .stated_noise_variance = noise_sq, .ensemble_runs = 4});
  };
  // Rows at 0.61 = 0.25 + 0.36 already show the placement scatter: only the mean's error is
  // shared.
  EXPECT_NEAR(scored(0.61, 0.25), direct_deviance(kRows, 9.5, 0.61, 0.09), 1e-9);
  // Rows at 0.25, the noise, show none of it: all of it is shared.
  EXPECT_NEAR(scored(0.25, 0.25), direct_deviance(kRows, 9.5, 0.25, 0.09 + 0.36), 1e-9);
  // Rows at 0.3 show 0.05 of the 0.36: 0.31 is shared.
  EXPECT_NEAR(scored(0.3, 0.25), direct_deviance(kRows, 9.5, 0.3, 0.09 + 0.31), 1e-9);
  // No stated noise: nothing says the fillet lay once, so re-laid is taken.
  EXPECT_NEAR(scored(0.3, 0.0), direct_deviance(kRows, 9.5, 0.3, 0.09), 1e-9);
}

TEST(RepetitionDeviance, RelaidRowsThatScatterBeyondTheNoiseNeedAModelWithSpread) {
  // Ten re-laid rows at +-0.8 (scatter 0.64) against a noise of 0.09: a model without spread
  // calls that 7 noise variances a row; one whose placements scatter by sqrt(0.55) explains
  // it (0.09 + 0.55 = 0.64). Its spread is sqrt(0.55 x 9/8) (ensemble_spread's sqrt(1 + 1/8)),
  // its mean's own error 0.55 / 8. Same mean, so only the rows' scatter decides.
  std::vector<double> rows(10, 0.8);
  for (std::size_t k = 1; k < rows.size(); k += 2) rows[k] = -0.8;
  const RepetitionScoring scoring{
      .within_variance = 0.64, .stated_noise_variance = 0.09, .ensemble_runs = 8};
  const double without =
      repetition_deviance({placed(trial_of(rows, 0.0, 0.0), Placement::kRelaid)}, scoring);
  const double with = repetition_deviance(
      {placed(trial_of(rows, 0.0, std::sqrt(0.55 * 9.0 / 8.0)), Placement::kRelaid)}, scoring);
  // 6.4 / 0.09 + 9 ln 0.09 + ln 0.009 against 6.4 / 0.64 + 9 ln 0.64 + ln(0.064 + 0.55 / 8):
  // 44.7 against 3.9.
  EXPECT_NEAR(without - with,
              (6.4 / 0.09 + 9.0 * std::log(0.09) + std::log(0.009)) -
                  (6.4 / 0.64 + 9.0 * std::log(0.64) + std::log(0.064 + 0.55 / 8.0)),
              1e-9);
  EXPECT_GT(without - with, 40.0);
}

struct ExactAndScattered {
  double exact = 0.0;      // the model without spread
  double scattered = 0.0;  // the same answer with a placement spread of 2
};

// Ten rows at noise 1 about `mean` (one 1 below it, one 1 above), scored against a model
// answering 10, placement unstated with the rows at the noise: the whole spread^2 (one
// placement's scatter and the mean's error) is shared.
ExactAndScattered scored_against_ten(double mean) {
  std::vector<double> rows(10, mean);
  rows[0] = mean - 1.0;
  rows[1] = mean + 1.0;
  const RepetitionScoring scoring{
      .within_variance = 1.0, .stated_noise_variance = 1.0, .ensemble_runs = 8};
  return {repetition_deviance({trial_of(rows, 10.0, 0.0)}, scoring),
          repetition_deviance({trial_of(rows, 10.0, 2.0)}, scoring)};
}

TEST(RepetitionDeviance, AModelWhoseSpreadCoversItsOffsetBeatsAnExactOneThatMissesIt) {
  // The rows' mean sits 2 off the model: 6.3 standard errors of the mean for a model without
  // spread, but 1 sigma for one whose spread is 2.
  const auto [exact, scattered] = scored_against_ten(12.0);
  // 4 / 0.1 + ln 0.1 against 4 / 4.1 + ln 4.1: 37.7 against 2.4.
  EXPECT_NEAR(exact - scattered, (4.0 / 0.1 + std::log(0.1)) - (4.0 / 4.1 + std::log(4.1)), 1e-9);
  EXPECT_GT(exact - scattered, 30.0);
}

TEST(RepetitionDeviance, ASpreadTheDataDoNotNeedCostsItsLogVariance) {
  // The rows on the model's answer: a spread of 2 only widens the likelihood, so it scores
  // worse by ln(4.1 / 0.1) = 3.7: scatter the data do not need is paid for.
  const auto [exact, scattered] = scored_against_ten(10.0);
  EXPECT_NEAR(scattered - exact, std::log(4.1 / 0.1), 1e-9);
}

Dataset slide_dataset(const std::vector<std::vector<double>>& rows_per_trial, double noise) {
  Dataset dataset;
  dataset.experiment = ExperimentType::kSlide;
  if (noise > 0.0) dataset.noise_si["onset_angle"] = noise;
  for (const std::vector<double>& rows : rows_per_trial) {
    Trial trial;
    trial.id = "t" + std::to_string(dataset.trials.size());
    trial.data.channels.push_back({"onset_angle", {}, rows});
    trial.data.lines.resize(rows.size());
    dataset.trials.push_back(trial);
  }
  return dataset;
}

TwinSettings ensemble_of(int runs) {
  TwinSettings settings;
  settings.slide.ensemble_runs = runs;
  return settings;
}

TEST(RepetitionScoringOf, PoolsTheRowsScatterOverTheTrials) {
  // Scatter sums 2 (1, 3: mean 2) and 2/3 (4, 5, 5: mean 14/3) over 1 + 2 degrees of freedom.
  const auto scoring =
      repetition_scoring(slide_dataset({{1.0, 3.0}, {4.0, 5.0, 5.0}}, 0.5), ensemble_of(4));
  ASSERT_TRUE(scoring.has_value());
  EXPECT_NEAR(scoring->within_variance, (2.0 + 2.0 / 3.0) / 3.0, 1e-12);
  EXPECT_DOUBLE_EQ(scoring->stated_noise_variance, 0.25);
  EXPECT_EQ(scoring->ensemble_runs, 4);
}

TEST(RepetitionScoringOf, TakesTheStatedNoiseWhereTheRowsCannotShowAScatter) {
  // One row a trial: no scatter to pool.
  const auto scoring = repetition_scoring(slide_dataset({{1.0}, {2.0}}, 0.5), ensemble_of(4));
  ASSERT_TRUE(scoring.has_value());
  EXPECT_DOUBLE_EQ(scoring->within_variance, 0.25);
}

TEST(RepetitionScoringOf, LeavesTheResidualSumToJudgeWhereItCannotScore) {
  // One run a trial has no spread to weigh: the residual sum judges, as before ensembles.
  EXPECT_FALSE(repetition_scoring(slide_dataset({{1.0, 3.0}, {4.0, 5.0}}, 0.5), ensemble_of(1)));
  // Rows without scatter and no stated noise: no variance to judge an offset against.
  EXPECT_FALSE(repetition_scoring(slide_dataset({{1.0, 1.0}, {4.0, 4.0}}, 0.0), ensemble_of(4)));
  // Rows that are not repetitions (a compress trial's time series).
  Dataset compress = slide_dataset({{1.0, 3.0}, {4.0, 5.0}}, 0.5);
  compress.experiment = ExperimentType::kCompress;
  EXPECT_FALSE(repetition_scoring(compress, ensemble_of(4)));
}

TEST(RepetitionScoringOf, AnUnknownPlacementIsRefusedBeforeAnyTwinRuns) {
  // A dataset made in code skips the loader's check; the residuals name the trial.
  Dataset data = slide_dataset({{0.5, 0.52}}, 0.005);
  data.trials[0].conditions["placement"] = std::string("sideways");
  try {
    (void)residuals(data, {}, {0}, ensemble_of(4));
    FAIL() << "an unknown placement was accepted";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("trial 't0': placement"), std::string::npos);
  }
}

}  // namespace
}  // namespace fl::workbench::detail
