// The bulk-flow experiment in the workbench (thesis 6.1, the mailbox outflow against its
// opening): each row is a fresh bulk scene with the gate at the row's opening; the twin's
// answer is the mass flow under the gate. A narrow scene (200 mm belt, 16 fillets of
// 7 mm spheres) keeps a row at about 2 s of computing.
#include <gtest/gtest.h>

#include <string>

#include "fl/workbench/twin_models.hpp"
#include "workbench_test_support.hpp"

namespace fl::workbench {
namespace {

using test::base_model;

BulkFlowSettings narrow_scene() {
  BulkFlowSettings settings;
  settings.scene.belt.half_width_mm = 100.0;
  settings.scene.hopper.back_mm = -250.0;
  settings.scene.belt.start_mm = -400.0;
  settings.scene.feeder.initial_fill = 16;
  settings.scene.simulation.seed = 7;
  settings.settle_s = 0.5;   // the pile falls 0.3 m and comes to rest in about 0.5 s
  settings.measure_s = 1.5;  // 0.3 m of belt travel at 0.2 m/s: the floor's length
  return settings;
}

Dataset bulk_dataset(const std::vector<double>& openings_m, double belt_speed_mps) {
  Dataset data;
  data.experiment = ExperimentType::kBulkFlow;
  Trial trial;
  trial.id = "v" + std::to_string(belt_speed_mps);
  trial.conditions["belt_speed"] = belt_speed_mps;
  trial.data.channels = {{"opening", *find_unit("mm"), openings_m},
                         {"outflow", *find_unit("kg/s"), std::vector<double>(openings_m.size())}};
  trial.data.lines.resize(openings_m.size());
  data.trials.push_back(trial);
  return data;
}

TEST(BulkFlowTwin, NothingUnderAClosedGateAndFlowUnderAnOpenOne) {
  TwinBulkFlowModel model(base_model(), narrow_scene());
  // 10 mm: under one 14 mm sphere diameter, no fillet fits under the gate; 100 mm: over two
  // fillet thicknesses (a 7 mm raster fillet is 35 to 46 mm thick).
  const Dataset data = bulk_dataset({0.010, 0.100}, 0.2);
  const std::vector<double> outflow = model.run(data, data.trials.front()).at("outflow").values_si;
  ASSERT_EQ(outflow.size(), 2U);
  EXPECT_EQ(outflow[0], 0.0);
  // At least one fillet (over 0.1 kg at 7 mm spheres) under the gate in the 1.5 s.
  EXPECT_GT(outflow[1], 0.1 / 1.5);
}

TEST(BulkFlowTwin, TheBeltSpeedConditionReachesTheScene) {
  TwinBulkFlowModel model(base_model(), narrow_scene());
  // On a still belt the pile only slumps under the open gate (seen: 0.23 kg/s over 1.5 s);
  // a running belt drags the bottom layer out from under it.
  const Dataset still = bulk_dataset({0.100}, 0.0);
  const Dataset running = bulk_dataset({0.100}, 0.2);
  EXPECT_LT(model.run(still, still.trials.front()).at("outflow").values_si.front(),
            model.run(running, running.trials.front()).at("outflow").values_si.front());
}

TEST(BulkFlowTwin, TheFillConditionReachesTheScene) {
  TwinBulkFlowModel model(base_model(), narrow_scene());
  // Two fillets in the hopper: at most both (under 0.5 kg) can pass in 1.5 s, fewer than the
  // narrow scene's 16 let through at the same opening.
  Dataset sparse = bulk_dataset({0.100}, 0.2);
  sparse.trials.front().conditions["fill"] = 2.0;
  Dataset full = bulk_dataset({0.100}, 0.2);
  const double sparse_kg_per_s =
      model.run(sparse, sparse.trials.front()).at("outflow").values_si.front();
  EXPECT_LT(sparse_kg_per_s, 0.5 / 1.5);
  EXPECT_LT(sparse_kg_per_s, model.run(full, full.trials.front()).at("outflow").values_si.front());
  sparse.trials.front().conditions["fill"] = 2.5;
  EXPECT_THROW((void)model.run(sparse, sparse.trials.front()), std::runtime_error);
}

TEST(BulkFlowTwin, TheFeedRateConditionKeepsTheHopperSupplied) {
  TwinBulkFlowModel model(base_model(), narrow_scene());
  // Two fillets to start with: alone, at most both (under 0.5 kg) pass in the 1.5 s. Fed
  // 8 a second from 450 mm up (they land within 0.3 s), about 14 more arrive before the
  // measurement ends, so more passes the open gate.
  Dataset fed = bulk_dataset({0.100}, 0.2);
  fed.trials.front().conditions["fill"] = 2.0;
  Dataset sparse = fed;
  fed.trials.front().conditions["feed_rate"] = 8.0;
  const double sparse_kg_per_s =
      model.run(sparse, sparse.trials.front()).at("outflow").values_si.front();
  const double fed_kg_per_s = model.run(fed, fed.trials.front()).at("outflow").values_si.front();
  EXPECT_GT(fed_kg_per_s, sparse_kg_per_s + 0.1 / 1.5);  // at least one fillet (0.1 kg) more
}

TEST(BulkFlowTwin, RefusesAnOpeningTheGateCannotReach) {
  TwinBulkFlowModel model(base_model(), narrow_scene());
  const Dataset data = bulk_dataset({0.5}, 0.2);  // the cylinder stops at 150 mm
  try {
    (void)model.run(data, data.trials.front());
    FAIL() << "a 500 mm opening ran";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("500 mm"), std::string::npos) << error.what();
  }
}

}  // namespace
}  // namespace fl::workbench
