// DEM engine speed in particle-steps per second (Google Benchmark): the race scenarios of
// dem_scenarios.hpp, 50 steps per iteration after settling. Arguments: size, threads.
// The side-by-side figures with the peer codes come from bench/dem_race/run.sh instead.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "dem_scenarios.hpp"
#include "fl/twin/dem/config.hpp"
#include "fl/twin/dem/model.hpp"

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

// The fillet-fillet contact chain of appendix B (hertz_mindlin, jkr, coulomb) on its own, per
// touching pair: the laws' share of the thesis' bulk pile (docs/benchmarks.md) measured on fixed
// pairs, free of the pile's run-to-run spread. 4096 pairs with overlaps from the adhesive neck
// (-5 um) to 60 um (1.5 % of the radius, the pile's deep contacts), sliding at up to 5 mm/s; each
// iteration computes every pair twice, at two overlaps 10 nm apart, so the contact-radius solve
// starts warm as from the last step.
void BM_FilletContactChain(benchmark::State& state) {
  const fl::dem::Model model(fl::dem::appendix_b_model_spec());
  const fl::dem::ContactChain& chain = *model.interaction(0, 0).contact_chain;
  constexpr std::size_t kPairs = 4096;
  std::mt19937 random(7);
  std::uniform_real_distribution<double> overlap_m(-5e-6, 60e-6);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::array<std::vector<fl::dem::PairGeometry>, 2> geometry;
  for (auto& g : geometry) g.resize(kPairs);
  for (std::size_t k = 0; k < kPairs; ++k) {
    fl::dem::PairGeometry g;
    g.normal = Vec3(unit(random), unit(random), unit(random)).normalized();
    g.overlap_m = overlap_m(random);
    g.relative_velocity_m_per_s = 0.005 * Vec3(unit(random), unit(random), unit(random));
    g.effective_radius_m = 0.002;  // two 4 mm spheres
    g.effective_mass_kg = 0.5 * 940.0 * 4.0 / 3.0 * std::numbers::pi * 0.004 * 0.004 * 0.004;
    g.timestep_s = 1.678512e-4;
    geometry[0][k] = g;
    g.overlap_m += 1e-8;
    geometry[1][k] = g;
  }
  std::vector<fl::dem::PairState> states(kPairs);
  for (auto& s : states) s.flags = fl::dem::PairState::kFlagAdhesiveNeck;  // all in contact
  double sink = 0.0;
  for (auto _ : state) {
    for (const auto& pass : geometry) {
      for (std::size_t k = 0; k < kPairs; ++k) {
        fl::dem::ForceAccumulator f;
        chain.compute(pass[k], states[k], f);
        sink += f.normal_force_n;
      }
    }
  }
  benchmark::DoNotOptimize(sink);
  state.counters["pair_evaluations_per_s"] = benchmark::Counter(
      static_cast<double>(2 * kPairs * state.iterations()), benchmark::Counter::kIsRate);
  state.counters["seconds_per_pair"] =
      benchmark::Counter(static_cast<double>(2 * kPairs * state.iterations()),
                         benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["fused"] = chain.fused() ? 1.0 : 0.0;
}
BENCHMARK(BM_FilletContactChain)->Unit(benchmark::kMicrosecond)->MinTime(2.0);

// The bonded law's batch on its own, per bond: the race's 14 fillets (45,962 bpm bonds) settled,
// then the bond pass of a step repeated on the frozen positions. The bond loop is most of the
// bonded race's time; timed alone it is free of the rebuilds' and the contacts' share and of a
// whole step's spread. The histories are restored every 50 passes (a pass adds one step's shear,
// so fifty keep every bond under its strength); the restore is outside the timing.
// Argument: the bond kernel (0 auto, 1 scalar).
void BM_BondBatch(benchmark::State& state) {
  const auto kernel =
      state.range(0) == 0 ? fl::dem::BondKernel::kAuto : fl::dem::BondKernel::kScalar;
  auto sim = race::make_fillets(14, 1, false, 1000, kernel);
  const fl::dem::State& settled = sim->state();
  const fl::dem::BondLaw& law = *sim->model().interaction(0, 0).bond_law;
  const std::vector<fl::dem::BondState> settled_states = settled.bond_states;
  std::vector<fl::dem::BondState> states = settled_states;
  std::vector<Vec3> force(settled.size(), Vec3::Zero());
  std::vector<Vec3> torque(settled.size(), Vec3::Zero());
  fl::dem::BondBatch batch;
  batch.bonds = settled.bonds.data();
  batch.states = states.data();
  batch.end = static_cast<std::uint32_t>(settled.bonds.size());
  batch.position_m = settled.position_m.data();
  batch.velocity_m_per_s = settled.velocity_m_per_s.data();
  batch.angular_velocity_rad_per_s = settled.angular_velocity_rad_per_s.data();
  batch.radius_m = settled.radius_m.data();
  batch.force_n = force.data();
  batch.torque_nm = torque.data();
  batch.timestep_s = race::kDt;
  batch.kernel = kernel;
  bool broke = false;
  std::size_t passes = 0;
  for (auto _ : state) {
    if (passes++ % 50 == 0) {
      state.PauseTiming();
      states = settled_states;
      state.ResumeTiming();
    }
    broke = law.compute_batch(batch) || broke;
    benchmark::ClobberMemory();
  }
  if (broke) state.SkipWithError("a bond broke: the timing is not of the whole list");
  const double bonds = static_cast<double>(batch.end) * static_cast<double>(state.iterations());
  state.counters["bonds_per_s"] = benchmark::Counter(bonds, benchmark::Counter::kIsRate);
  state.counters["seconds_per_bond"] =
      benchmark::Counter(bonds, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_BondBatch)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond)->MinTime(2.0);

}  // namespace

BENCHMARK_MAIN();
