// Tests of the bulk experiment run (twin/include/fl/twin/dem_bulk/bulk_run.hpp): the schedule
// parser against malformed text, the run following its schedule with counts that add up, its
// refusals, its files, and the shipped thesis-size box holding the thesis' 450 fillets.
#include "fl/twin/dem_bulk/bulk_run.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "fl/report/csv.hpp"

namespace fl {
namespace {

const std::filesystem::path kSource(FL_SOURCE_DIR);

std::string refusal(const std::string& text) {
  try {
    (void)parse_setpoint_schedule(text, "--gate");
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(SetpointSchedule, ReadsTimeValuePairsInOrder) {
  const std::vector<TimedSetpoint> s = parse_setpoint_schedule("0:60, 5:100 ,10.5:40", "--gate");
  ASSERT_EQ(s.size(), 3U);
  EXPECT_DOUBLE_EQ(s[0].time_s, 0.0);
  EXPECT_DOUBLE_EQ(s[0].value, 60.0);
  EXPECT_DOUBLE_EQ(s[1].time_s, 5.0);
  EXPECT_DOUBLE_EQ(s[1].value, 100.0);
  EXPECT_DOUBLE_EQ(s[2].time_s, 10.5);
  EXPECT_DOUBLE_EQ(s[2].value, 40.0);
  EXPECT_TRUE(parse_setpoint_schedule("", "--gate").empty());
}

TEST(SetpointSchedule, MalformedEntriesAreNamedByPosition) {
  // Each text goes wrong in its second entry; the message names the option and the entry.
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"0:60,5", "not TIME:VALUE"},      // no colon
      {"0:60,", "not TIME:VALUE"},       // a trailing comma leaves an empty entry
      {"0:60,5:abc", "not a number"},    // text for a value
      {"0:60,5:60mm", "not a number"},   // a unit glued on
      {"0:60,:60", "missing"},           // no time
      {"0:60,5:nan", "not a finite"},    // NaN would pass every range check
      {"0:60,5:inf", "not a finite"},    // so would infinity
      {"0:60,5:1e999", "not a number"},  // out of double's range
      {"0:60,0:70", "must rise"},        // the same time twice
      {"5:60,1:70", "must rise"},        // going back in time
      {"0:60,1:2:3", "not a number"},    // a second colon
      {"0:60,+5:60", "not a number"},    // a sign the C++ number reader does not take
      {"0:60,0x10:60", "not a number"},  // hexadecimal
      {"0:60, ", "not TIME:VALUE"},      // a blank entry
  };
  for (const auto& [text, why] : cases) {
    const std::string what = refusal(text);
    EXPECT_NE(what.find("--gate: entry 2"), std::string::npos) << text << " -> " << what;
    EXPECT_NE(what.find(why), std::string::npos) << text << " -> " << what;
  }
  EXPECT_NE(refusal("-1:60").find("negative"), std::string::npos);
  // Tabs and spaces around the numbers are layout, not part of them.
  EXPECT_EQ(parse_setpoint_schedule("0:60,\t5 :\t70 ", "--gate").size(), 2U);
}

// The shipped 7 mm scene (a few fillets): small enough for the sanitizer run.
BulkDemConfig small_scene() { return load_bulk_dem_config(kSource / "config/bulk_dem.yaml"); }

TEST(BulkRun, FollowsItsScheduleAndItsCountsAddUp) {
  BulkDemConfig config = small_scene();
  // The shipped 400 x 400 mm box's slots take 6 fillets; the feeder would drop the other 6 of
  // its 12 during the run and change the sphere count the checks below rely on.
  config.feeder.initial_fill = 6;
  BulkScene scene(config);
  BulkRunOptions options;
  options.duration_s = 0.4;
  options.sample_s = 0.1;
  // The gate opens from 60 to 100 mm at 0.2 s; its cylinder runs at 50 mm/s (bulk_dem.yaml), so
  // at the end, 0.2 s later, it stands at 60 + 50 * 0.2 = 70 mm.
  options.gate_opening_mm = {{0.0, 60.0}, {0.2, 100.0}};
  options.belt_speed_mps = {{0.0, 0.3}};
  const std::size_t spheres = scene.simulation().state().size();
  std::vector<BulkRunSample> seen;
  std::vector<BulkRunSample> samples;
  const BulkRunSummary summary = run_bulk_experiment(
      scene, options, [&](const BulkRunSample& s) { seen.push_back(s); }, &samples);

  ASSERT_EQ(samples.size(), 5U);  // the start and every 0.1 s of 0.4 s
  ASSERT_EQ(seen.size(), samples.size());
  for (std::size_t k = 0; k < samples.size(); ++k) {
    EXPECT_NEAR(samples[k].time_s, 0.1 * static_cast<double>(k), 1e-9);
    if (k > 0) {
      EXPECT_GE(samples[k].passed_gate, samples[k - 1].passed_gate);
      EXPECT_GE(samples[k].wall_s, samples[k - 1].wall_s);
    }
    EXPECT_DOUBLE_EQ(samples[k].belt_speed_mps, 0.3);
    EXPECT_DOUBLE_EQ(samples[k].gate_target_mm, k <= 2 ? 60.0 : 100.0);
  }
  EXPECT_NEAR(samples.back().gate_opening_mm, 70.0, 0.05);
  for (const BulkRunSample& s : samples) {
    EXPECT_NEAR(s.engine_time_s, s.time_s, 0.5 * summary.timestep_s);
  }

  // The engine's whole steps cover the run to within half a step at each of the 200 control
  // steps' ends (the clock never runs ahead), so the count is the run over the timestep.
  const double steps = options.duration_s / summary.timestep_s;
  EXPECT_NEAR(static_cast<double>(summary.engine_steps), steps, 1.0);
  EXPECT_EQ(samples.back().engine_steps, summary.engine_steps);
  // Nothing reaches the discharge edge (900 mm downstream) in 0.4 s at 0.3 m/s, so every step
  // ran all the spheres and the bonds are all still in the scene.
  EXPECT_EQ(samples.back().discharged, 0U);
  EXPECT_EQ(summary.initial_fillets, 6U);
  EXPECT_EQ(samples.back().fillets_in_scene, 6U);
  EXPECT_DOUBLE_EQ(summary.particle_steps,
                   static_cast<double>(summary.engine_steps) * static_cast<double>(spheres));
  EXPECT_EQ(samples.back().bonds, summary.initial_bonds);
  EXPECT_EQ(samples.back().lost, 0U);
  EXPECT_EQ(samples.back().broken_bonds_total, samples.back().broken_bonds);  // none left
  EXPECT_GT(summary.particle_steps_per_s(), 0.0);

  const std::filesystem::path out = std::filesystem::temp_directory_path() / "fl_bulk_run_test";
  std::filesystem::remove_all(out);
  write_bulk_run_csv(samples, out / "bulk_run.csv");
  write_bulk_run_plots(samples, options, out);
  std::ifstream csv(out / "bulk_run.csv");
  const std::string text((std::istreambuf_iterator<char>(csv)), std::istreambuf_iterator<char>());
  const auto rows = report::parse_csv(text);
  ASSERT_EQ(rows.size(), 6U);  // header and five samples
  EXPECT_EQ(rows[0][0], "time_s");
  // The last row's commanded opening is the second setpoint's, read back by column name.
  const auto column = std::find(rows[0].begin(), rows[0].end(), "gate_target_mm");
  ASSERT_NE(column, rows[0].end());
  EXPECT_EQ(rows[5][static_cast<std::size_t>(column - rows[0].begin())], "100");
  for (const char* plot : {"bulk_run_flow.svg", "bulk_run_pile.svg", "bulk_run_bonds.svg"}) {
    EXPECT_GT(std::filesystem::file_size(out / plot), 1000U) << plot;
  }
}

TEST(BulkRun, WritesVtkFramesAtTheStartAndEachInterval) {
  BulkDemConfig config = small_scene();
  config.feeder.initial_fill = 2;
  BulkScene scene(config);
  BulkRunOptions options;
  options.duration_s = 0.1;
  options.sample_s = 0.05;
  options.vtk_every_s = 0.04;  // frames at 0, 0.04, 0.08 and the end (0.1)
  options.vtk_directory = std::filesystem::temp_directory_path() / "fl_bulk_run_vtk";
  std::filesystem::remove_all(options.vtk_directory);
  const BulkRunSummary summary = run_bulk_experiment(scene, options, {});
  EXPECT_EQ(summary.vtk_frames, 4U);
  EXPECT_TRUE(std::filesystem::exists(options.vtk_directory / "run.pvd"));
  EXPECT_LE(summary.output_wall_s, summary.wall_s);
}

TEST(BulkRun, ShowsFramesAtTheStartAndEachInterval) {
  BulkDemConfig config = small_scene();
  config.feeder.initial_fill = 2;
  BulkScene scene(config);
  BulkRunOptions options;
  options.duration_s = 0.1;
  options.sample_s = 0.1;
  options.frame_every_s = 0.02;  // the start, then 0.02 .. 0.1: six frames
  std::vector<double> frame_times_s;
  options.on_frame = [&](const dem::Simulation& sim) {
    frame_times_s.push_back(sim.state().time_s);
  };
  const BulkRunSummary summary = run_bulk_experiment(scene, options, {});
  ASSERT_EQ(frame_times_s.size(), 6U);
  EXPECT_EQ(summary.frames, 6U);
  // The engine's clock is within half a timestep of each control step's end.
  for (std::size_t k = 0; k < frame_times_s.size(); ++k) {
    EXPECT_NEAR(frame_times_s[k], 0.02 * static_cast<double>(k), 0.5 * summary.timestep_s) << k;
  }
  options.on_frame = nullptr;
  EXPECT_THROW((void)run_bulk_experiment(scene, options, {}), std::invalid_argument);
}

TEST(BulkRun, RefusesARunItCannotMakeAsAsked) {
  BulkDemConfig config = small_scene();
  config.feeder.initial_fill = 0;
  BulkScene scene(config);
  const auto refused = [&](const BulkRunOptions& options) -> std::string {
    try {
      (void)run_bulk_experiment(scene, options, {});
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "";
  };
  const auto with = [](auto change) {
    BulkRunOptions o;
    o.duration_s = 0.01;
    o.sample_s = 0.01;
    change(o);
    return o;
  };
  // 3 ms is one and a half control steps of 2 ms: run as 2 or 4 ms, not as asked.
  EXPECT_NE(refused(with([](BulkRunOptions& o) { o.duration_s = 0.003; })).find("duration 0.003"),
            std::string::npos);
  EXPECT_NE(refused(with([](BulkRunOptions& o) { o.duration_s = std::nan(""); })).find("duration"),
            std::string::npos);
  EXPECT_NE(refused(with([](BulkRunOptions& o) { o.sample_s = 0.0; })).find("sample interval"),
            std::string::npos);
  EXPECT_NE(refused(with([](BulkRunOptions& o) { o.vtk_every_s = 0.01; })).find("directory"),
            std::string::npos);
  EXPECT_NE(refused(with([](BulkRunOptions& o) { o.rate_window_s = -1.0; })).find("rate window"),
            std::string::npos);
  // The gate's travel is 0..150 mm and the belt's 1 m/s (bulk_dem.yaml): beyond, clamped.
  EXPECT_NE(refused(with([](BulkRunOptions& o) {
              o.gate_opening_mm = {{0.0, 200.0}};
            })).find("outside 0 .. 150"),
            std::string::npos);
  EXPECT_NE(refused(with([](BulkRunOptions& o) {
              o.belt_speed_mps = {{0.0, -1.5}};
            })).find("belt speed (m/s) setpoint 1"),
            std::string::npos);
  // A setpoint at the run's end (10 ms) would hold for no step at all.
  for (const double at_s : {0.01, 0.02}) {
    EXPECT_NE(refused(with([&](BulkRunOptions& o) {
                o.gate_opening_mm = {{at_s, 60.0}};
              })).find("not before the run's end"),
              std::string::npos)
        << at_s;
  }
  // The config loader's rotor range is +-1000 rpm, and the scene does not clamp the leveller.
  EXPECT_NE(refused(with([](BulkRunOptions& o) {
              o.leveller_rpm = {{0.0, 2000.0}};
            })).find("leveller (rpm) setpoint 1"),
            std::string::npos);
  EXPECT_NE(refused(with([](BulkRunOptions& o) {
              o.gate_opening_mm = {{0.001, 60.0}};
            })).find("not a whole number of control steps"),
            std::string::npos);
  EXPECT_DOUBLE_EQ(scene.time_s(), 0.0);  // nothing ran
}

// The thesis' bulk run: 450 fillets, "over 160k particles" at 4 mm (paper section C). The box
// of config/bulk_thesis.yaml must hold all of them in the initial fill, inside its walls:
// fillets the fill cannot place would be dropped later by the feeder, another experiment.
TEST(BulkThesisConfig, TheBoxHoldsTheThesis450FilletsInsideItsWalls) {
  const BulkDemConfig config = load_bulk_dem_config(kSource / "config/bulk_thesis.yaml");
  EXPECT_EQ(config.feeder.initial_fill, 450U);
  EXPECT_DOUBLE_EQ(config.simulation.sub_particle_radius_mm, 4.0);
  BulkScene scene(config);
  EXPECT_EQ(scene.fillets_in_scene(), 450U);
  EXPECT_EQ(scene.fillets_in_hopper(), 450U);
  // "Over 160k particles" in the thesis; the project's own fillet mesh fills to about 440
  // spheres a fillet at 4 mm against the thesis' 360, so this box holds about 199k.
  EXPECT_GT(scene.simulation().state().size(), 160000U);
  const double half_width_m = config.belt.half_width_mm * 1e-3;
  const double back_m = config.hopper.back_mm * 1e-3;
  const double gate_m = config.gate.x_mm * 1e-3;
  for (const BulkFilletView& f : scene.fillets()) {
    EXPECT_GT(f.lower_m.z(), 0.0) << f.id;
    EXPECT_LT(f.upper_m.z(), config.hopper.height_mm * 1e-3) << f.id;
    EXPECT_GT(f.lower_m.y(), -half_width_m) << f.id;
    EXPECT_LT(f.upper_m.y(), half_width_m) << f.id;
    EXPECT_GT(f.lower_m.x(), back_m) << f.id;
    EXPECT_LT(f.upper_m.x(), gate_m) << f.id;
  }
}

}  // namespace
}  // namespace fl
