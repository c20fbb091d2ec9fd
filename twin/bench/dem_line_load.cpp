// dem_line_load: the DEM line's pace against the load it carries, without the controller
// (issue 3: the real-time factor with about 20 fillets on the belts). In closed loop the line
// holds what the infeed supplies, 12 or 13 fillets at the shipped takt; here fillets are
// spawned onto the first transition belt at a fixed rate, every belt at its nominal speed,
// plates closed and the roller up, so the load is what the rate makes it (about 11.5 s from
// the barrier to the outfeed: 1.75 fillets a second keep about 20 on the line). After a
// warm-up it times whole seconds of line time, 10 ms control steps as `linectl run` takes,
// and prints each second's load and pace, then the summary.
//
//   dem_line_load [--rate 1.75] [--warmup 14] [--seconds 20] [--seed 1]
//                 [--config config/plant_dem.yaml] [--line config/line.yaml]
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <numbers>
#include <random>
#include <string>

#include "../tests/plant_test_support.hpp"  // belts_running: the belts as the plants' tests run them
#include "fl/controller/config_loader.hpp"
#include "fl/twin/dem_plant/dem_plant.hpp"

namespace {

constexpr std::int64_t kStepNs = 10'000'000;  // the scan period: the plant's control step
constexpr int kStepsPerSecond = 100;

}  // namespace

static int checked_main(int argc, char** argv) {
  CLI::App app{"time the DEM line at a steady load of spawned fillets"};
  double rate_per_s = 1.75;
  double warmup_s = 14.0;
  int seconds = 20;
  std::uint64_t seed = 1;
  std::string config_path = FL_SOURCE_DIR "/config/plant_dem.yaml";
  std::string line_path = FL_SOURCE_DIR "/config/line.yaml";
  app.add_option("--rate", rate_per_s, "fillets spawned per second of line time")
      ->check(CLI::Range(0.1, 5.0));
  app.add_option("--warmup", warmup_s, "line time before the timing starts [s]")
      ->check(CLI::Range(0.0, 600.0));
  app.add_option("--seconds", seconds, "whole seconds of line time timed")
      ->check(CLI::Range(1, 3600));
  app.add_option("--seed", seed, "plant seed, and the spawned fillets' variants and headings");
  app.add_option("--config", config_path, "plant_dem.yaml")->check(CLI::ExistingFile);
  app.add_option("--line", line_path, "line.yaml")->check(CLI::ExistingFile);
  CLI11_PARSE(app, argc, argv);

  const fl::LineConfig line = fl::load_line_config(line_path);
  const fl::DemPlantConfig config = fl::load_dem_plant_config(config_path);
  fl::DemPlant plant(line, config);
  fl::InputImage in{};
  plant.reset(seed, in);
  const fl::OutputImage out = fl::test::belts_running(line);

  // Spawned on the first transition belt, clear of the barrier: a variant, a side and a
  // heading drawn per fillet; the spacing in time is kept even when a spawn must wait for room.
  const fl::BeltSection& first = line.sections[fl::index(fl::DriveId::kTransition1)];
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<int> variant(0, 5);
  std::uniform_real_distribution<double> heading(-std::numbers::pi, std::numbers::pi);
  const auto spawn_period_steps =
      static_cast<std::int64_t>(std::llround(kStepsPerSecond / rate_per_s));
  std::int64_t step = 0;
  std::int64_t next_spawn = 0;
  std::uint64_t spawned = 0;
  const auto advance = [&] {
    if (step >= next_spawn) {
      fl::DemFilletSpawn spawn;
      spawn.s_mm = first.start_mm + 120.0;
      spawn.v_mps = first.nominal_speed_mps;
      spawn.variant = static_cast<std::uint8_t>(variant(rng));
      spawn.side = variant(rng) % 2 == 0 ? fl::SideUp::kSkin : fl::SideUp::kBone;
      spawn.angle_rad = heading(rng);
      if (plant.spawn_fillet(spawn)) ++spawned;
      next_spawn += spawn_period_steps;
    }
    plant.step(out, kStepNs, in);
    ++step;
  };
  const auto warmup_steps = static_cast<std::int64_t>(std::llround(warmup_s * kStepsPerSecond));
  while (step < warmup_steps) advance();

  std::printf("second\tfillets_on_line\twall_s\trealtime_factor\n");
  double total_wall_s = 0.0;
  double slowest_wall_s = 0.0;
  double load_sum = 0.0;
  std::uint64_t load_max = 0;
  for (int second = 0; second < seconds; ++second) {
    const auto start = std::chrono::steady_clock::now();
    for (int i = 0; i < kStepsPerSecond; ++i) advance();
    const double wall_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const std::uint64_t load = plant.fillets_on_line();
    std::printf("%d\t%llu\t%.3f\t%.2f\n", second, static_cast<unsigned long long>(load), wall_s,
                1.0 / wall_s);
    total_wall_s += wall_s;
    slowest_wall_s = std::max(slowest_wall_s, wall_s);
    load_sum += static_cast<double>(load);
    load_max = std::max(load_max, load);
  }
  std::printf(
      "# %d s at %.2f fillets/s (%llu spawned in all): %.1f fillets on the line on average, "
      "%llu at most; %.2fx real time overall, %.2fx in the slowest second; %d engine threads, "
      "%zu spheres at the end\n",
      seconds, rate_per_s, static_cast<unsigned long long>(spawned), load_sum / seconds,
      static_cast<unsigned long long>(load_max), seconds / total_wall_s, 1.0 / slowest_wall_s,
      plant.simulation().active_thread_count(), plant.simulation().state().size());
  return 0;
}

int main(int argc, char** argv) {
  try {
    return checked_main(argc, argv);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "dem_line_load: %s\n", error.what());
  }
  return 1;
}
