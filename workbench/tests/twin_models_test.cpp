// The DEM twin as the model of a compression dataset: it reproduces its own measurement
// exactly, and a hidden relaxation in the "measurement" shows as a failing hold phase.
#include "fl/workbench/twin_models.hpp"

#include <gtest/gtest.h>

#include "workbench_test_support.hpp"

namespace fl::workbench {
namespace {

// Load to 0.5 mm (1.8 % of the 28 mm tall 4-layer block) in 0.1 s, hold 0.1 s, unload in
// 0.1 s; 61 rows. Short, so the DEM runs take well under a second.
Trial profile_trial(const std::string& id) {
  Trial trial;
  trial.id = id;
  std::vector<double> t, d;
  for (int k = 0; k <= 60; ++k) {
    const double time = 0.005 * k;
    t.push_back(time);
    if (time <= 0.1) {
      d.push_back(0.5e-3 * time / 0.1);
    } else if (time <= 0.2) {
      d.push_back(0.5e-3);
    } else {
      d.push_back(0.5e-3 * (0.3 - time) / 0.1);
    }
  }
  trial.data.channels = {{"time", *find_unit("s"), t},
                         {"displacement", *find_unit("mm"), d},
                         {"force", *find_unit("N"), std::vector<double>(t.size(), 0.0)}};
  trial.data.lines.resize(t.size());
  return trial;
}

model_tests::CommonParams common_with_bond_law(const std::string& law,
                                               const dem::LawParameters& extra = {}) {
  model_tests::CommonParams common = test::base_model();
  for (dem::InteractionSpec& interaction : common.base_spec.interactions) {
    if (!interaction.bond_law) continue;
    interaction.bond_law->name = law;
    for (const auto& [key, value] : extra) interaction.bond_law->parameters[key] = value;
  }
  return common;
}

// The "measurement": the given model's force at the trial's rows, written into the trial.
Dataset measured_by(TwinCompressModel& truth) {
  Dataset data;
  data.name = "twin-made";
  data.experiment = ExperimentType::kCompress;
  data.trials = {profile_trial("a")};
  const Table force = truth.run(data, data.trials[0]);
  data.trials[0].data.channels[2].values_si = force.at("force").values_si;
  return data;
}

TEST(TwinCompressModel, ReproducesItsOwnMeasurementExactly) {
  TwinCompressModel twin(common_with_bond_law("bpm"));
  const Dataset data = measured_by(twin);
  const std::vector<double>& force = data.trials[0].data.at("force").values_si;
  // The block pushes back: the peak force is positive and the hold carries load.
  EXPECT_GT(force[20], 0.0);
  EXPECT_GT(force[30], 0.0);
  const CompareReport report = compare(data, twin);
  EXPECT_EQ(report.overall("force").rmse_si, 0.0);  // deterministic: the same run twice
}

TEST(TwinCompressModel, HiddenRelaxationShowsAsRateDependenceThatRelaxesInTheHold) {
  // Truth: a Maxwell arm as stiff as the bond spring, relaxing in 20 ms; the load ramp takes
  // 100 ms and the hold 100 ms. The elastic model misses force while the plate moves (the
  // arm carries load) and agrees again once the arm has relaxed late in the hold.
  TwinCompressModel truth(common_with_bond_law(
      "bpm_viscoelastic", {{"relaxation_stiffness_n_per_m3", 1e6}, {"relaxation_time_s", 0.02}}));
  const Dataset data = measured_by(truth);
  TwinCompressModel elastic(common_with_bond_law("bpm"));
  const CompareReport report = compare(data, elastic);
  EXPECT_NE(report.cells.front().phase, "hold");
  EXPECT_NE(report.cells.front().phase, "");
  double loading_rmse = -1.0;
  for (const ErrorCell& cell : report.cells) {
    if (cell.group == "phase loading") loading_rmse = cell.rmse_si;
  }
  ASSERT_GT(loading_rmse, 0.0);
  const TrialTrace& trace = report.traces[0];
  const ChannelTrace& force = trace.channels[0];
  // At the end of the load (row 20) the truth is stiffer: the arm adds force.
  EXPECT_GT(force.measured_si[20], force.model_si[20]);
  std::size_t last_hold = 0;
  for (std::size_t k = 0; k < trace.phase.size(); ++k) {
    if (trace.phase[k] == "hold") last_hold = k;
  }
  ASSERT_GT(last_hold, 20U);
  // Four time constants into the hold the arm keeps e^-4 = 2 % of its load.
  EXPECT_LT(std::abs(force.measured_si[last_hold] - force.model_si[last_hold]), 0.1 * loading_rmse);
}

}  // namespace
}  // namespace fl::workbench
