// Controller benchmarks:
//   BM_LogicScan/<items>     compute time of one LineController::update() with that many
//                            fillets tracked on the line (p50/p99/p99.9/max as counters)
//   BM_LockstepClosedLoop    simulated seconds per wall second of the controller in lock
//                            step with the fast plant (the real-time factor)
#include <benchmark/benchmark.h>

#include <chrono>
#include <filesystem>

#include "fl/apps/closed_loop.hpp"
#include "fl/controller/config_loader.hpp"
#include "fl/controller/cycle_stats.hpp"
#include "fl/controller/line_controller.hpp"
#include "fl/twin/fast_plant.hpp"
#include "fl/twin/fast_plant_config.hpp"

namespace fl {
namespace {

const std::filesystem::path kConfigDir = std::filesystem::path(FL_SOURCE_DIR) / "config";

// The reference line holds about 13 items at 64 per minute. A longer hand-off conveyor
// (outfeed to 10 m) keeps the rate and the stations as they are and holds 20 or more.
LineConfig line_holding_20_items() {
  LineConfig line = load_line_config(kConfigDir / "line.yaml");
  line.sections[index(DriveId::kOutfeed)].end_mm = 10'000.0F;
  line.placed_at_s_mm = 10'000.0F;
  return line;
}

void BM_LogicScan(benchmark::State& state) {
  const auto wanted_items = static_cast<std::size_t>(state.range(0));
  const LineConfig line = line_holding_20_items();
  FastPlant plant(line, load_fast_plant_config(kConfigDir / "plant_fast.yaml"));
  LineController controller(line);
  InputImage in;
  OutputImage out;
  plant.reset(1, in);
  controller.request_start();
  // Fill the line until the wanted number of items is tracked.
  for (int scan = 0; scan < 60'000 && controller.tracked_count() < wanted_items; ++scan) {
    controller.update(in, out);
    plant.step(out, 10'000'000, in);
    while (controller.closed_records().pop()) {
    }
    while (controller.events().pop()) {
    }
  }
  if (controller.tracked_count() < wanted_items) {
    state.SkipWithError("the line never held the wanted number of items");
    return;
  }
  DurationHistogram histogram(50, 1'000'000);  // 50 ns bins up to 1 ms
  std::size_t tracked_sum = 0;
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    controller.update(in, out);
    const auto stop = std::chrono::steady_clock::now();
    const auto elapsed = std::chrono::duration<double>(stop - start);
    state.SetIterationTime(elapsed.count());
    histogram.record(std::chrono::duration_cast<std::chrono::nanoseconds>(stop - start).count());
    tracked_sum += controller.tracked_count();
    state.PauseTiming();
    plant.step(out, 10'000'000, in);
    while (controller.closed_records().pop()) {
    }
    while (controller.events().pop()) {
    }
    state.ResumeTiming();
  }
  const DistributionSummary summary = histogram.summary();
  state.counters["p50_us"] = static_cast<double>(summary.p50_ns) / 1e3;
  state.counters["p99_us"] = static_cast<double>(summary.p99_ns) / 1e3;
  state.counters["p999_us"] = static_cast<double>(summary.p999_ns) / 1e3;
  state.counters["max_us"] = static_cast<double>(summary.max_ns) / 1e3;
  state.counters["tracked_mean"] =
      static_cast<double>(tracked_sum) / static_cast<double>(state.iterations());
}
BENCHMARK(BM_LogicScan)
    ->Arg(20)
    ->UseManualTime()
    ->Iterations(100'000)
    ->Unit(benchmark::kMicrosecond);

void BM_LockstepClosedLoop(benchmark::State& state) {
  const LineConfig line = load_line_config(kConfigDir / "line.yaml");
  const FastPlantConfig plant_config = load_fast_plant_config(kConfigDir / "plant_fast.yaml");
  double simulated_s = 0.0;
  double wall_s = 0.0;
  for (auto _ : state) {
    FastPlant plant(line, plant_config);
    apps::RunOptions options;
    options.duration_s = 60.0;
    options.measure_compute = false;
    const auto start = std::chrono::steady_clock::now();
    const apps::Kpis kpis = apps::run_closed_loop(line, plant, options);
    wall_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    simulated_s += kpis.total_simulated_s;
    benchmark::DoNotOptimize(kpis.truth.outfeed);
  }
  state.counters["realtime_factor"] = simulated_s / wall_s;
  state.counters["simulated_s"] = simulated_s / static_cast<double>(state.iterations());
}
BENCHMARK(BM_LockstepClosedLoop)->Unit(benchmark::kMillisecond)->Iterations(5);

}  // namespace
}  // namespace fl

BENCHMARK_MAIN();
