// DEM engine speed in particle-steps per second (Google Benchmark): the race scenarios of
// dem_scenarios.hpp, 50 steps per iteration after settling. Arguments: size, threads.
// The side-by-side figures with the peer codes come from bench/dem_race/run.sh instead.
#include <benchmark/benchmark.h>

#include <algorithm>

#include "dem_scenarios.hpp"

namespace {

using fl::dem::Vec3;
namespace race = fl::dem::race;

void run(benchmark::State& state, fl::dem::Simulation& sim) {
  constexpr std::size_t kSteps = 50;
  for (auto _ : state) sim.step(kSteps);
  state.counters["particle_steps_per_s"] =
      benchmark::Counter(static_cast<double>(sim.state().size() * kSteps * state.iterations()),
                         benchmark::Counter::kIsRate);
  state.counters["spheres"] = static_cast<double>(sim.state().size());
  state.counters["touching_pairs"] = static_cast<double>(sim.stats().touching_pairs);
  state.counters["rebuilds"] = static_cast<double>(sim.stats().neighbor_rebuilds);
  double max_speed = 0.0;  // what drives the rebuild rate together with the skin
  for (const Vec3& v : sim.state().velocity_m_per_s) max_speed = std::max(max_speed, v.norm());
  state.counters["max_speed_mps"] = max_speed;
}

void BM_Bed(benchmark::State& state) {
  // 50 x 25 x 8 = 10,000 spheres (the peers' lattice), scaled in x and y for other sizes
  const double scale = std::sqrt(static_cast<double>(state.range(0)) / 10000.0);
  auto sim = race::make_bed(static_cast<int>(std::lround(50 * scale)),
                            static_cast<int>(std::lround(25 * scale)), 8,
                            static_cast<int>(state.range(1)), 1500);
  run(state, *sim);
}
BENCHMARK(BM_Bed)
    ->Args({1000, 1})
    ->Args({10000, 1})
    ->Args({10000, 2})
    ->Args({50000, 1})
    ->Args({50000, 2})
    ->Args({200000, 2})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(3.0);

void BM_BondedFillets(benchmark::State& state) {
  auto sim = race::make_fillets(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)),
                                state.range(2) != 0, 300);
  run(state, *sim);
}
BENCHMARK(BM_BondedFillets)
    ->Args({14, 1, 1})
    ->Args({14, 2, 1})
    ->Args({450, 1, 1})
    ->Args({450, 2, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(3.0);

}  // namespace

BENCHMARK_MAIN();
