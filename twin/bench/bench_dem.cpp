// DEM engine speed against the peer codes (../shared/bench/README.md): particle-steps per second.
//   bed:     dense bed of 4 mm spheres on a belt plane moving at 0.3 m/s (Hertz-Mindlin +
//            Coulomb, restitution 0.051 as the LIGGGHTS run), side walls instead of periodic x/y.
//   fillets: 10x7x5 blocks at 8 mm pitch, every sphere bonded to neighbours within 8 sqrt(3) mm
//            (bpm with shear, appendix B stiffness), Hertz-Mindlin + JKR + Coulomb, two layers on
//            a belt (gen_fillets.py layout).
// Arguments: spheres (approximate for the bed), threads. Timestep 1.678512e-4 s everywhere.
#include <benchmark/benchmark.h>

#include <cmath>
#include <map>
#include <memory>
#include <random>

#include "fl/twin/dem/config.hpp"
#include "fl/twin/dem/simulation.hpp"

namespace {

using fl::dem::Vec3;
constexpr double kRadius = 0.004;
constexpr double kDt = 1.678512e-4;

fl::dem::ModelSpec base_spec(int threads, bool full_model, bool bonded) {
  fl::dem::ModelSpec spec;
  spec.materials = {{"fillet", 3.7e5, 0.37, 940.0}, {"steel", 2e11, 0.3, 7850.0}};
  spec.types = {{"fillet", 0}, {"belt", 1}};
  std::vector<fl::dem::LawSpec> pp = {
      {"hertz_mindlin", {{"restitution", full_model ? 1e-4 : 0.051}}}};
  std::vector<fl::dem::LawSpec> pw = pp;
  if (full_model) {
    pp.push_back({"jkr", {{"surface_energy_j_per_m2", 0.055}}});
    pw.push_back({"jkr", {{"surface_energy_j_per_m2", 0.055}}});
  }
  pp.push_back({"coulomb", {{"friction_coefficient", 0.1}}});
  pw.push_back({"coulomb", {{"friction_coefficient", 0.5}}});
  fl::dem::InteractionSpec fillet_fillet{0, 0, pp, std::nullopt, false};
  if (bonded) {
    fillet_fillet.bond_law = fl::dem::LawSpec{
        "bpm", {{"normal_stiffness_n_per_m3", 1e6}, {"shear_stiffness_n_per_m3", 6e4}}};
  }
  spec.interactions = {fillet_fillet, {0, 1, pw, std::nullopt, false}};
  spec.timestep_s = kDt;
  spec.thread_count = threads;
  spec.neighbor_skin_m = 0.002;  // as the peers (run_peers.sh: neighbor 0.002 bin)
  return spec;
}

std::unique_ptr<fl::dem::Simulation> make_bed(int spheres, int threads) {
  const double a = 0.0088;
  const int nz = 10;
  const int nxy = static_cast<int>(std::lround(std::sqrt(spheres / nz)));
  fl::dem::ModelSpec spec = base_spec(threads, false, false);
  const double length = nxy * a;
  spec.domain.lower_m = Vec3(-0.01, -0.01, -0.01);
  spec.domain.upper_m = Vec3(length + 0.01, length + 0.01, (nz + 4) * a);
  spec.planes = {{"belt", 1, Vec3::Zero(), Vec3::UnitZ()},
                 {"x0", 1, Vec3::Zero(), Vec3::UnitX()},
                 {"x1", 1, Vec3(length, 0, 0), -Vec3::UnitX()},
                 {"y0", 1, Vec3::Zero(), Vec3::UnitY()},
                 {"y1", 1, Vec3(0, length, 0), -Vec3::UnitY()}};
  auto sim = std::make_unique<fl::dem::Simulation>(std::make_shared<fl::dem::Model>(spec));
  std::mt19937 random(32452843);
  std::uniform_real_distribution<double> jitter(-0.0006, 0.0006);
  sim->reserve(static_cast<std::size_t>(nxy * nxy * nz), 0);
  for (int z = 0; z < nz; ++z)
    for (int y = 0; y < nxy; ++y)
      for (int x = 0; x < nxy; ++x)
        sim->add_sphere(
            {Vec3((x + 0.5) * a + jitter(random), (y + 0.5) * a + jitter(random), (z + 0.5) * a),
             kRadius, 0});
  sim->wall("belt").surface_velocity_m_per_s = Vec3(0.3, 0, 0);
  sim->step(1500);  // settle (0.25 s)
  return sim;
}

std::unique_ptr<fl::dem::Simulation> make_fillets(int fillets, int threads) {
  const double a = 0.008;
  const int per_layer = fillets / 2;
  int fx = static_cast<int>(std::lround(std::sqrt(per_layer)));
  while (per_layer % fx != 0) --fx;
  const int fy = per_layer / fx;
  const double px = 14 * a, py = 12 * a, pz = 8 * a;
  fl::dem::ModelSpec spec = base_spec(threads, true, true);
  const double xmax = a + (fx - 1) * px + 7 * a + 10 * a + 0.02;
  const double ymax = a + (fy - 1) * py + 6 * a + 7 * a + 0.02;
  spec.domain.lower_m = Vec3(-0.05, -0.05, -0.01);
  spec.domain.upper_m = Vec3(xmax + 0.05, ymax + 0.05, 2 * pz + 0.06);
  spec.planes = {{"belt", 1, Vec3::Zero(), Vec3::UnitZ()}};
  auto sim = std::make_unique<fl::dem::Simulation>(std::make_shared<fl::dem::Model>(spec));
  std::vector<Vec3> block;
  for (int k = 0; k < 5; ++k)
    for (int j = 0; j < 7; ++j)
      for (int i = 0; i < 10; ++i) block.emplace_back(i * a, j * a, k * a);
  std::vector<double> radii(block.size(), kRadius);
  std::vector<std::uint8_t> types(block.size(), 0);
  std::vector<fl::dem::BodyBond> bonds;
  for (std::uint32_t p = 0; p < block.size(); ++p)
    for (std::uint32_t q = p + 1; q < block.size(); ++q)
      if ((block[p] - block[q]).norm() < a * std::sqrt(3.0) * 1.001) bonds.push_back({p, q, a});
  sim->reserve(block.size() * static_cast<std::size_t>(fillets),
               bonds.size() * static_cast<std::size_t>(fillets));
  for (int layer = 0; layer < 2; ++layer)
    for (int p = 0; p < fx; ++p)
      for (int q = 0; q < fy; ++q) {
        fl::dem::BodyPose pose;
        pose.position_m =
            Vec3(a + p * px + layer * 7 * a, a + q * py + layer * 6 * a, 0.625 * a + layer * pz);
        sim->add_body(block, radii, types, bonds, pose);
      }
  sim->wall("belt").surface_velocity_m_per_s = Vec3(0.3, 0, 0);
  sim->step(300);  // settle: the blocks land on the belt and on each other
  return sim;
}

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
  auto sim = make_bed(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  run(state, *sim);
}
BENCHMARK(BM_Bed)
    ->Args({10000, 1})
    ->Args({10000, 2})
    ->Args({50000, 1})
    ->Args({50000, 2})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(3.0);

void BM_BondedFillets(benchmark::State& state) {
  auto sim = make_fillets(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  run(state, *sim);
}
BENCHMARK(BM_BondedFillets)
    ->Args({14, 1})
    ->Args({14, 2})
    ->Args({450, 1})
    ->Args({450, 2})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(3.0);

}  // namespace

BENCHMARK_MAIN();
