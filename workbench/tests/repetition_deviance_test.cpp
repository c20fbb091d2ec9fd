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

TEST(RepetitionDeviance, IsTheMultivariateNormalOfRowsSharingAnOffset) {
  // A fillet laid once (the rows' scatter is the stated noise): the whole spread is shared,
  // plus the ensemble mean's own error, spread^2 / (runs + 1).
  const RepetitionScoring laid_once{
      .within_variance = 0.25, .stated_noise_variance = 0.25, .ensemble_runs = 4};
  const double spread = 0.6;
  const double shared = spread * spread / 5.0 + spread * spread;
  const std::vector<TrialRepetitions> trials{trial_of(kRows, 9.5, spread),
                                             trial_of(kOtherRows, 12.4, spread)};
  const double expected =
      direct_deviance(kRows, 9.5, 0.25, shared) + direct_deviance(kOtherRows, 12.4, 0.25, shared);
  EXPECT_NEAR(repetition_deviance(trials, laid_once), expected, 1e-9 * std::abs(expected));
}

TEST(RepetitionDeviance, RowsThatShowTheSpreadShareOnlyTheEnsembleMeansError) {
  // Re-laid every repetition: the rows scatter by the noise and the spread together (0.25 +
  // 0.36), so only the ensemble mean's own error, 0.36 / 5, is shared.
  const RepetitionScoring relaid{
      .within_variance = 0.61, .stated_noise_variance = 0.25, .ensemble_runs = 4};
  const std::vector<TrialRepetitions> trials{trial_of(kRows, 9.5, 0.6)};
  const double expected = direct_deviance(kRows, 9.5, 0.61, 0.36 / 5.0);
  EXPECT_NEAR(repetition_deviance(trials, relaid), expected, 1e-9 * std::abs(expected));
  // Without a stated noise nothing says the fillet lay once: re-laid is taken, as above.
  const RepetitionScoring unstated{.within_variance = 0.61, .ensemble_runs = 4};
  EXPECT_NEAR(repetition_deviance(trials, unstated), expected, 1e-9 * std::abs(expected));
}

TEST(RepetitionDeviance, AModelWhoseSpreadCoversItsOffsetBeatsAnExactOneThatMissesIt) {
  // Ten rows at noise 1 whose mean sits 2 off the model: 6.3 standard errors of the mean for
  // a model without spread, but 0.9 sigma for one whose placements scatter by 2.
  std::vector<double> rows(10, 12.0);
  rows[0] = 11.0;
  rows[1] = 13.0;
  const RepetitionScoring scoring{
      .within_variance = 1.0, .stated_noise_variance = 1.0, .ensemble_runs = 8};
  const double exact = repetition_deviance({trial_of(rows, 10.0, 0.0)}, scoring);
  const double scattered = repetition_deviance({trial_of(rows, 10.0, 2.0)}, scoring);
  // 4 / 0.1 + ln 0.1 against 4 / 4.544 + ln 4.544: 37.7 against 2.4.
  EXPECT_NEAR(exact - scattered,
              (4.0 / 0.1 + std::log(0.1)) -
                  (4.0 / (0.1 + 4.0 / 9.0 + 4.0) + std::log(0.1 + 4.0 / 9.0 + 4.0)),
              1e-9);
  EXPECT_GT(exact - scattered, 30.0);
}

TEST(RepetitionDeviance, ASpreadTheDataDoNotNeedCostsItsLogVariance) {
  // The same rows on the model's answer: a spread of 2 only widens the likelihood, so it
  // scores worse by ln(4.544 / 0.1) = 3.8, and a chaotic model cannot buy a fit with scatter.
  std::vector<double> rows(10, 10.0);
  rows[0] = 9.0;
  rows[1] = 11.0;
  const RepetitionScoring scoring{
      .within_variance = 1.0, .stated_noise_variance = 1.0, .ensemble_runs = 8};
  const double exact = repetition_deviance({trial_of(rows, 10.0, 0.0)}, scoring);
  const double scattered = repetition_deviance({trial_of(rows, 10.0, 2.0)}, scoring);
  EXPECT_NEAR(scattered - exact, std::log((0.1 + 4.0 / 9.0 + 4.0) / 0.1), 1e-9);
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

}  // namespace
}  // namespace fl::workbench::detail
