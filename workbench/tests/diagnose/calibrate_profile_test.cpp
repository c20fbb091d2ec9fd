// The profile intervals of a calibration (CalibrationOptions::profile_fit_evaluations): each
// parameter stepped through its box with the others re-fitted. Hundreds of twin runs, so
// these live with the slow diagnosis proofs, out of the sanitizer run.
#include <gtest/gtest.h>

#include <algorithm>
#include <nlohmann/json.hpp>

#include "calibrate_test_support.hpp"

namespace fl::workbench {
namespace {

using test::calibrate_stiffness_and;
using test::kTruthStiffness;
using test::stiffer_bonds_compression;

// The compression pressed by the bonds (calibrate_test.cpp,
// JointIntervalShowsTheTradeOffTheConditionalOneHides): only k_n s^2 shows, so the data trace
// a valley k_n s^2 = 1.8e6 through the box. The local intervals are pinned to the calibrated
// point and the joint one is missing; the profile must follow the valley to where the disk
// scale's box ends it.
TEST(CalibrateProfile, FollowsTheValleyTheLocalIntervalsCannotSee) {
  // 25 evaluations re-fit the disk scale after each step of k_n (15 fell short of the valley's
  // end: the scale moves up to a quarter of its box per step).
  const Calibration result =
      calibrate_stiffness_and(stiffer_bonds_compression(), "bond.bonded_disk_scale=0.5:1.5", 25);
  ASSERT_EQ(result.sensitivity.size(), 2U);
  const ParameterSensitivity& stiffness = result.sensitivity[0];
  const ParameterSensitivity& disk = result.sensitivity[1];
  // The conditional interval of k_n sits on the calibrated point, wherever on the valley the
  // fit landed; the profile holds the truth (1.8e6 at disk scale 1).
  EXPECT_LE(stiffness.profile_interval_low, kTruthStiffness);
  EXPECT_GE(stiffness.profile_interval_high, kTruthStiffness);
  EXPECT_LE(stiffness.profile_interval_low, result.best[0]);
  // The valley's ends: the disk scale at its box's 1.5 and 0.5 puts k_n at 1.8e6 / 1.5^2 =
  // 0.8e6 and 1.8e6 / 0.5^2 = 7.2e6. Past them nothing can compensate, so the bounds lie
  // about there (the upper one within 20 %; the shear bonds end the lower side early).
  EXPECT_GE(stiffness.profile_interval_low, 0.9 * 0.8e6);
  EXPECT_GE(stiffness.profile_interval_high, 0.8 * 7.2e6);
  EXPECT_LE(stiffness.profile_interval_high, 1.1 * 7.2e6);
  EXPECT_FALSE(stiffness.profile_low_open);
  EXPECT_FALSE(stiffness.profile_high_open);
  // Any disk scale in its box fits, with k_n re-fitted: the profile reaches both edges under
  // the threshold, so the data do not bound the scale at all.
  EXPECT_TRUE(disk.profile_low_open);
  EXPECT_TRUE(disk.profile_high_open);
  EXPECT_DOUBLE_EQ(disk.profile_interval_low, 0.5);
  EXPECT_DOUBLE_EQ(disk.profile_interval_high, 1.5);
  // The traced points come sorted by value, the calibrated one among them.
  for (std::size_t p = 0; p < result.sensitivity.size(); ++p) {
    const ParameterSensitivity& s = result.sensitivity[p];
    ASSERT_EQ(s.profile_values.size(), s.profile_rmse.size());
    EXPECT_TRUE(std::is_sorted(s.profile_values.begin(), s.profile_values.end()));
    EXPECT_NE(std::find(s.profile_values.begin(), s.profile_values.end(), result.best[p]),
              s.profile_values.end());
  }
  const nlohmann::json json = nlohmann::json::parse(calibration_json(result));
  const nlohmann::json& disk_json = json["parameters"][1]["sensitivity"];
  EXPECT_EQ(disk_json["profile_interval_95"][0].get<double>(), 0.5);
  EXPECT_EQ(disk_json["profile_open"][1].get<bool>(), true);
  EXPECT_EQ(disk_json["profile_values"].size(), disk.profile_values.size());
}

// One parameter: nothing to re-fit, so the profile is the error along the parameter itself;
// about the minimum that is the parabola the conditional interval takes, and the profile's
// interpolation in sqrt(rise) is exact for a parabola. The halved steps trace it where it
// bends (a tenth of this 33x log box is a 42 % step, far past the 0.3 % interval).
TEST(CalibrateProfile, OneParameterProfileIsItsConditionalInterval) {
  CalibrationOptions options;
  options.hammersley_points = 8;
  options.profile_fit_evaluations = 10;
  const Calibration result = calibrate(
      stiffer_bonds_compression(), test::base_model(),
      {parse_calibrated_parameter("bond.normal_stiffness_n_per_m3=3e5:1e7:log")}, options);
  const ParameterSensitivity& s = result.sensitivity.front();
  const double width = s.interval_high - s.interval_low;
  ASSERT_GT(width, 0.0);
  // Within a tenth of the interval's width: the steps are finite, not the parabola's limit.
  EXPECT_NEAR(s.profile_interval_low, s.interval_low, 0.1 * width);
  EXPECT_NEAR(s.profile_interval_high, s.interval_high, 0.1 * width);
  EXPECT_LE(s.profile_interval_low, kTruthStiffness);
  EXPECT_GE(s.profile_interval_high, kTruthStiffness);
  EXPECT_FALSE(s.profile_low_open || s.profile_high_open);
}

}  // namespace
}  // namespace fl::workbench
