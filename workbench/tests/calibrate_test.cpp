// Calibration of the base model: parameter boxes parsed and malformed ones refused, the two
// designs of experiments, addresses resolved in the DEM model, and the bond stiffness of a
// compression dataset recovered from a twin whose stiffness is off by a factor of 1.8, and the
// sensitivity that tells a determined parameter from one the data say nothing about.
#include "fl/workbench/calibrate.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>
#include <set>

#include "calibrate_test_support.hpp"
#include "fl/twin/dem/config.hpp"
#include "workbench_test_support.hpp"

namespace fl::workbench {
namespace {

using test::calibrate_stiffness_and;
using test::kTruthStiffness;
using test::stiffer_bonds_compression;

TEST(Calibrate, ParsesParameterBoxes) {
  const CalibratedParameter stiffness =
      parse_calibrated_parameter("bond.normal_stiffness_n_per_m3=3e5:3e6:log");
  EXPECT_EQ(stiffness.address, "bond.normal_stiffness_n_per_m3");
  EXPECT_DOUBLE_EQ(stiffness.min, 3e5);
  EXPECT_DOUBLE_EQ(stiffness.max, 3e6);
  EXPECT_TRUE(stiffness.log);
  const CalibratedParameter friction =
      parse_calibrated_parameter("fillet_equipment.coulomb.friction_coefficient=0.2:0.9");
  EXPECT_FALSE(friction.log);
  EXPECT_DOUBLE_EQ(friction.max, 0.9);
}

TEST(Calibrate, RefusesMalformedParameterBoxesNamingThem) {
  for (const std::string text :
       {"bond.x", "=1:2", "bond.x=1", "bond.x=1:2:3:4", "bond.x=2:1", "bond.x=1:1",
        "bond.x=0:1:log", "bond.x=1:nan", "bond.x=1:2:lin", "bond.x=1e999:2", "bond.x=1:2 "}) {
    SCOPED_TRACE(text);
    try {
      (void)parse_calibrated_parameter(text);
      ADD_FAILURE() << "accepted";
    } catch (const std::invalid_argument& error) {
      EXPECT_NE(std::string(error.what()).find(text), std::string::npos) << error.what();
    }
  }
}

TEST(Calibrate, FullFactorialDesignHoldsEveryLevelCombination) {
  const auto design = full_factorial_design(2, 3);
  ASSERT_EQ(design.size(), 9U);
  std::set<std::vector<double>> distinct(design.begin(), design.end());
  EXPECT_EQ(distinct.size(), 9U);
  EXPECT_TRUE(distinct.contains(std::vector<double>{0.0, 0.0}));
  EXPECT_TRUE(distinct.contains(std::vector<double>{0.5, 0.5}));
  EXPECT_TRUE(distinct.contains(std::vector<double>{1.0, 1.0}));
  EXPECT_EQ(full_factorial_design(3, 1), (std::vector<std::vector<double>>{{0.5, 0.5, 0.5}}));
  EXPECT_THROW((void)full_factorial_design(13, 2), std::invalid_argument);  // 8192 points
  EXPECT_THROW((void)full_factorial_design(0, 3), std::invalid_argument);
}

TEST(Calibrate, HammersleyPointsStratifyTheSquare) {
  // 16 points in base 2 form a (0,4,2)-net: every 4 x 4 cell, and every 2 x 8 and 8 x 2
  // one, holds exactly one point; a random sample of 16 would leave cells empty.
  const auto design = hammersley_design(2, 16);
  ASSERT_EQ(design.size(), 16U);
  for (const auto& [columns, rows] : {std::pair{4, 4}, std::pair{2, 8}, std::pair{8, 2}}) {
    std::set<std::pair<int, int>> cells;
    for (const auto& point : design) {
      cells.insert({static_cast<int>(point[0] * columns), static_cast<int>(point[1] * rows)});
    }
    EXPECT_EQ(cells.size(), 16U) << columns << " x " << rows;
  }
  // The third coordinate is the radical inverse in base 3: point 5 = 12 in base 3 -> 0.21 in
  // base 3 = 2/3 + 1/9.
  EXPECT_DOUBLE_EQ(hammersley_design(3, 8)[5][2], 2.0 / 3.0 + 1.0 / 9.0);
  EXPECT_THROW((void)hammersley_design(9, 8), std::invalid_argument);
}

TEST(Calibrate, AddressesSetEveryLawTheyNameAndNothingElse) {
  const dem::ModelSpec base = dem::appendix_b_model_spec();
  const std::vector<CalibratedParameter> parameters{
      parse_calibrated_parameter("fillet_equipment.coulomb.friction_coefficient=0.1:1"),
      parse_calibrated_parameter("bond.normal_stiffness_n_per_m3=1e5:1e7:log")};
  const dem::ModelSpec spec = with_calibrated(base, parameters, {0.7, 2e6});
  const std::uint32_t equipment = model_tests::equipment_type(spec);
  int equipment_pairs = 0, bonded_pairs = 0;
  for (const dem::InteractionSpec& interaction : spec.interactions) {
    for (const dem::LawSpec& law : interaction.contact_laws) {
      if (law.name != "coulomb") continue;
      const bool with_equipment = model_tests::is_fillet_with(interaction, equipment);
      equipment_pairs += with_equipment ? 1 : 0;
      // Appendix B: fillet-equipment 0.5 becomes 0.7; the fillet-fillet 0.1 stays.
      EXPECT_DOUBLE_EQ(law.parameters.at("friction_coefficient"), with_equipment ? 0.7 : 0.1);
    }
    if (interaction.bond_law) {
      ++bonded_pairs;
      EXPECT_DOUBLE_EQ(interaction.bond_law->parameters.at("normal_stiffness_n_per_m3"), 2e6);
    }
  }
  EXPECT_EQ(equipment_pairs, 2);  // fillet_a and fillet_b with the equipment
  EXPECT_GE(bonded_pairs, 1);
  for (const std::string address : {"bond.no_such_key", "fillet_equipment.no_law.friction",
                                    "fillet_equipment.coulomb", "belt.coulomb.friction"}) {
    try {
      (void)with_calibrated(base, {{address, 0.1, 1.0, false}}, {0.5});
      ADD_FAILURE() << address << " was accepted";
    } catch (const std::invalid_argument& error) {
      EXPECT_NE(std::string(error.what()).find(address), std::string::npos) << error.what();
    }
  }
}

// The curvature matrix from the moves of an exact quadratic bowl rss(u) = 100 + d^T A d,
// d = u - u0, in three parameters: the finite differences are exact for a quadratic, so A comes
// back to rounding. Parameter 1 sits 0.05 below the top of its box, so its up move is not made
// and the pairs move it down (sign -1).
TEST(Calibrate, CurvatureMatrixOfAQuadraticBowl) {
  const std::vector<std::vector<double>> a = {
      {400.0, 300.0, 0.0}, {300.0, 400.0, 100.0}, {0.0, 100.0, 200.0}};
  const std::vector<double> u0 = {0.5, 0.95, 0.3};
  const auto rss = [&](const std::vector<double>& u) {
    double sum = 100.0;
    for (std::size_t p = 0; p < 3; ++p) {
      for (std::size_t q = 0; q < 3; ++q) sum += (u[p] - u0[p]) * a[p][q] * (u[q] - u0[q]);
    }
    return sum;
  };
  constexpr double kStep = 0.1;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<int> sign = {1, -1, 1};
  std::vector<double> down(3);
  std::vector<double> up(3);
  for (std::size_t p = 0; p < 3; ++p) {
    std::vector<double> u = u0;
    u[p] -= kStep;
    down[p] = rss(u);
    u[p] += 2.0 * kStep;
    up[p] = u[p] <= 1.0 ? rss(u) : nan;
  }
  std::vector<double> pairs;
  for (std::size_t p = 0; p < 3; ++p) {
    for (std::size_t q = p + 1; q < 3; ++q) {
      std::vector<double> u = u0;
      u[p] += sign[p] * kStep;
      u[q] += sign[q] * kStep;
      pairs.push_back(rss(u));
    }
  }
  const auto curvature = detail::curvature_matrix(down, up, pairs, sign, rss(u0), kStep);
  ASSERT_EQ(curvature.size(), 3U);
  for (std::size_t p = 0; p < 3; ++p) {
    for (std::size_t q = 0; q < 3; ++q) EXPECT_NEAR(curvature[p][q], a[p][q], 1e-9) << p << q;
  }
  // A pair the twin refused: no matrix, so no joint interval is made up.
  pairs[1] = nan;
  EXPECT_TRUE(detail::curvature_matrix(down, up, pairs, sign, rss(u0), kStep).empty());
}

// Two parameters that trade off, A = [[400, 300], [300, 400]], threshold 16: alone each is
// held to sqrt(16 / 400) = 0.2 (conditional), together to sqrt(16 (A^-1)_00) with
// (A^-1)_00 = 400 / (400^2 - 300^2), 0.302; their correlation is -300 / 400.
TEST(Calibrate, JointIntervalsWidenWhereParametersTradeOff) {
  constexpr double kThreshold = 16.0;
  const detail::JointIntervals joint =
      detail::joint_intervals({{400.0, 300.0}, {300.0, 400.0}}, {0.5, 0.4}, kThreshold);
  ASSERT_EQ(joint.intervals.size(), 2U);
  const double half_width = std::sqrt(kThreshold * 400.0 / (400.0 * 400.0 - 300.0 * 300.0));
  EXPECT_NEAR(joint.intervals[0].first, 0.5 - half_width, 1e-12);
  EXPECT_NEAR(joint.intervals[0].second, 0.5 + half_width, 1e-12);
  EXPECT_NEAR(joint.intervals[1].first, 0.4 - half_width, 1e-12);
  EXPECT_GT(half_width, 1.5 * std::sqrt(kThreshold / 400.0));
  ASSERT_EQ(joint.correlation.size(), 2U);
  EXPECT_NEAR(joint.correlation[0][1], -0.75, 1e-12);
  EXPECT_NEAR(joint.correlation[1][0], -0.75, 1e-12);
  EXPECT_NEAR(joint.correlation[0][0], 1.0, 1e-12);
  // Independent parameters: the joint interval is the conditional one.
  const detail::JointIntervals independent =
      detail::joint_intervals({{400.0, 0.0}, {0.0, 100.0}}, {0.5, 0.5}, kThreshold);
  ASSERT_EQ(independent.intervals.size(), 2U);
  EXPECT_NEAR(independent.intervals[1].second, 0.5 + std::sqrt(kThreshold / 100.0), 1e-12);
  // A saddle or a valley of equal error (a combination the data cannot see): none at all.
  EXPECT_TRUE(detail::joint_intervals({{400.0, 500.0}, {500.0, 400.0}}, {0.5, 0.5}, kThreshold)
                  .intervals.empty());
  EXPECT_TRUE(
      detail::joint_intervals({{1.0, 1.0}, {1.0, 1.0}}, {0.5, 0.5}, kThreshold).intervals.empty());
  EXPECT_TRUE(detail::joint_intervals({}, {}, kThreshold).intervals.empty());
}

// The interval of an exact parabola about the calibrated point, rss(u) = 100 + 400 (u - 0.5)^2,
// sampled at 0.4, 0.5 and 0.6: half width sqrt(3.84 / 400) = 0.098, from both moves or one.
TEST(Calibrate, QuadraticIntervalOfAParabola) {
  const auto rss = [](double u) { return 100.0 + 400.0 * (u - 0.5) * (u - 0.5); };
  constexpr double kThreshold = 3.84;
  const double half_width = std::sqrt(kThreshold / 400.0);
  const auto [low, high] =
      detail::quadratic_interval(rss(0.4), rss(0.5), rss(0.6), 0.5, 0.1, kThreshold);
  EXPECT_NEAR(low, 0.5 - half_width, 1e-12);
  EXPECT_NEAR(high, 0.5 + half_width, 1e-12);
  // One move (the other past the box): the curvature from that side alone.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const auto [low_one, high_one] =
      detail::quadratic_interval(nan, rss(0.5), rss(0.6), 0.5, 0.1, kThreshold);
  EXPECT_NEAR(low_one, 0.5 - half_width, 1e-12);
  EXPECT_NEAR(high_one, 0.5 + half_width, 1e-12);
  // Flat or bending down: the moves do not bound the parameter.
  EXPECT_TRUE(std::isnan(detail::quadratic_interval(5.0, 5.0, 5.0, 0.5, 0.1, kThreshold).first));
  EXPECT_TRUE(std::isnan(detail::quadratic_interval(4.0, 5.0, 4.0, 0.5, 0.1, kThreshold).second));
  EXPECT_TRUE(std::isnan(detail::quadratic_interval(nan, 5.0, nan, 0.5, 0.1, kThreshold).first));
}

TEST(Calibrate, RecoversTheBondStiffnessOfACompressionDataset) {
  // Measured on a block whose bonds are 1.8 times appendix B's; the twin starts from appendix
  // B. The plate force is proportional to the normal stiffness, so the fit must find it to the
  // noise: 0.01 N on forces of about 1 N over ~170 rows is a 0.1 % stiffness resolution; 2 %
  // leaves the local fit's tolerance room.
  const Dataset data = stiffer_bonds_compression();
  CalibrationOptions calibration;
  calibration.hammersley_points = 8;
  const Calibration result = calibrate(
      data, test::base_model(),
      {parse_calibrated_parameter("bond.normal_stiffness_n_per_m3=3e5:1e7:log")}, calibration);
  ASSERT_EQ(result.design.size(), 8U);
  EXPECT_DOUBLE_EQ(result.base_values.front(), 1e6);
  EXPECT_NEAR(result.best.front(), kTruthStiffness, 0.02 * kTruthStiffness);
  EXPECT_GT(result.base_rmse, 5.0 * test::kNoiseN);  // the base model fails it
  EXPECT_LT(result.rmse, 1.2 * test::kNoiseN);       // the calibrated one sits at the noise
  // One parameter: nothing to re-fit, so the joint interval is the conditional one.
  const ParameterSensitivity& alone = result.sensitivity.front();
  EXPECT_NEAR(alone.joint_interval_low, alone.interval_low, 1e-9 * alone.interval_low);
  EXPECT_NEAR(alone.joint_interval_high, alone.interval_high, 1e-9 * alone.interval_high);
  ASSERT_EQ(result.correlation.size(), 1U);
  EXPECT_DOUBLE_EQ(result.correlation[0][0], 1.0);
  // The best design point is no better than the fit.
  const auto best_design =
      std::min_element(result.design.begin(), result.design.end(),
                       [](const DesignRun& a, const DesignRun& b) { return a.rmse < b.rmse; });
  EXPECT_LE(result.rmse, best_design->rmse);
}

TEST(Calibrate, JointIntervalShowsTheTradeOffTheConditionalOneHides) {
  // A compression pressed by the bonds: the normal bond force is k_n A (d - d0) with
  // A = pi (disk_scale R)^2, so a stiffer bond on a smaller disk presses the same. Held alone,
  // each parameter is pinned by the 0.01 N noise; re-fitted together they slide along that
  // valley (only the shear bonds, k_t A, tell them apart a little). The truth is 1.8 times
  // appendix B's stiffness at its disk scale 1.
  const Calibration result =
      calibrate_stiffness_and(stiffer_bonds_compression(), "bond.bonded_disk_scale=0.5:1.5");
  ASSERT_EQ(result.sensitivity.size(), 2U);
  // The fit lands somewhere on the valley: at the noise, with k_n s^2 at the truth's 1.8e6
  // (2 %: the shear bonds' small part and the fit's tolerance).
  EXPECT_LT(result.rmse, 1.2 * test::kNoiseN);
  EXPECT_NEAR(result.best[0] * result.best[1] * result.best[1], kTruthStiffness,
              0.02 * kTruthStiffness);
  for (const ParameterSensitivity& s : result.sensitivity) {
    // Alone, each looks determined, with a narrow interval...
    EXPECT_TRUE(s.determined);
    ASSERT_TRUE(std::isfinite(s.interval_low) && std::isfinite(s.interval_high));
    // ...together they are not: no joint interval, or one at least three times as wide.
    if (std::isfinite(s.joint_interval_low) && std::isfinite(s.joint_interval_high)) {
      EXPECT_GT(s.joint_interval_high - s.joint_interval_low,
                3.0 * (s.interval_high - s.interval_low));
    }
  }
  // Strongly anti-correlated (k_n up, disk down), or not determined together at all.
  if (!result.correlation.empty()) {
    EXPECT_LT(result.correlation[0][1], -0.9);
  }
  // The pair move is one more twin run: 1 base + 8 design + local fit + 4 single + 1 pair.
  EXPECT_GE(result.evaluations, 1 + 8 + 4 + 1);
  const nlohmann::json json = nlohmann::json::parse(calibration_json(result));
  EXPECT_EQ(json["correlation"].is_null(), result.correlation.empty());
  EXPECT_EQ(json["parameters"][0]["sensitivity"]["joint_interval_95"].size(), 2U);
  // No profile was asked for: its interval is null, not made up.
  EXPECT_TRUE(json["parameters"][0]["sensitivity"]["profile_interval_95"][0].is_null());
  EXPECT_TRUE(json["parameters"][0]["sensitivity"]["profile_values"].empty());
}

TEST(Calibrate, SensitivitySaysWhichParametersTheDataDetermine) {
  // A compression between smooth plates: the plate force follows the bond stiffness (a tenth
  // of a 10x log box is a 26 % step: far beyond the 0.01 N noise), while the friction with the
  // plates has nothing to act on (the block is pressed straight down). The stiffness must come
  // out determined and the friction not; the truth is 1.8 times appendix B's stiffness.
  const Calibration result = calibrate_stiffness_and(
      stiffer_bonds_compression(), "fillet_equipment.coulomb.friction_coefficient=0.1:1");
  ASSERT_EQ(result.sensitivity.size(), 2U);
  const ParameterSensitivity& stiffness = result.sensitivity[0];
  const ParameterSensitivity& friction = result.sensitivity[1];
  EXPECT_TRUE(stiffness.determined);
  EXPECT_GT(stiffness.rmse_down, 2.0 * result.rmse);
  EXPECT_GT(stiffness.rmse_up, 2.0 * result.rmse);
  EXPECT_FALSE(friction.determined);
  // The stiffness' 95 % interval holds the truth and is narrow: the noise resolves the
  // stiffness to about 0.3 % here, and 5 % leaves room for the parabola over a 26 % step.
  EXPECT_LE(stiffness.interval_low, kTruthStiffness);
  EXPECT_GE(stiffness.interval_high, kTruthStiffness);
  EXPECT_LT(stiffness.interval_high - stiffness.interval_low, 0.05 * kTruthStiffness);
  // The friction's is unbounded, or spans most of its box: the data say nothing of it.
  const bool friction_bounded =
      std::isfinite(friction.interval_low) && std::isfinite(friction.interval_high);
  if (friction_bounded) {
    EXPECT_GT(friction.interval_high - friction.interval_low, 0.5 * 0.9);
  }
  // The moves are a tenth of the box around the calibrated value, inside the box.
  EXPECT_NEAR(std::log(stiffness.value_up / stiffness.value_down), 0.2 * std::log(1e7 / 3e5), 1e-9);
  EXPECT_LT(friction.value_down, result.best[1]);
  EXPECT_GT(friction.value_up, result.best[1]);
  EXPECT_GE(friction.value_down, 0.1);
  EXPECT_LE(friction.value_up, 1.0);
  // The Hammersley design is sliced in quarters; every quarter of 8 points has some.
  ASSERT_EQ(stiffness.main_effect_rmse.size(), 4U);
  for (const double rmse : stiffness.main_effect_rmse) EXPECT_TRUE(std::isfinite(rmse));
  EXPECT_GE(result.evaluations, 1 + 8 + 5);  // the base model, the design, the five moves

  const std::filesystem::path folder =
      std::filesystem::path(testing::TempDir()) / "calibrate_sensitivity_plots";
  const std::vector<std::filesystem::path> plots = write_sensitivity_plots(result, folder);
  ASSERT_EQ(plots.size(), 2U);
  for (const std::filesystem::path& plot : plots) {
    EXPECT_GT(std::filesystem::file_size(plot), 0U) << plot;
  }
  const nlohmann::json json = nlohmann::json::parse(calibration_json(result));
  EXPECT_TRUE(json["parameters"][0]["sensitivity"]["determined"].get<bool>());
  EXPECT_DOUBLE_EQ(json["parameters"][0]["sensitivity"]["interval_95"][0].get<double>(),
                   stiffness.interval_low);
  EXPECT_FALSE(json["parameters"][1]["sensitivity"]["determined"].get<bool>());
}

}  // namespace
}  // namespace fl::workbench
