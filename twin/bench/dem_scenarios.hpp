// Scenarios of the DEM speed race against the peer codes (../shared/bench/README.md), shared by
// bench_dem (Google Benchmark) and dem_race (the side-by-side script's command).
//   bed:     dense bed of 4 mm spheres on a lattice of 8.8 mm (nx x ny x nz, as the peers' input)
//            on a belt plane moving at 0.3 m/s, Hertz-Mindlin (restitution 0.051, as the
//            LIGGGHTS run) + Coulomb 0.1 / 0.5. Side walls where the peers are periodic in x, y.
//   fillets: 10x7x5 blocks at 8 mm pitch, every sphere bonded to its neighbours within
//            8 sqrt(3) mm (bpm: normal 1e6 N/m^3 = the peers' 50.3 N/m on a 4 mm disk, plus shear
//            6e4 N/m^3), Hertz-Mindlin (restitution 1e-4) [+ JKR 0.055 J/m^2] + Coulomb, two
//            layers on the belt (gen_fillets.py layout). Bonded pairs are left out of contact.
// Timestep 1.678512e-4 s and skin 2 mm everywhere, as the peers.
#pragma once

#include <cmath>
#include <memory>
#include <random>

#include "fl/twin/dem/simulation.hpp"

namespace fl::dem::race {

constexpr double kRadius = 0.004;
constexpr double kDt = 1.678512e-4;

inline ModelSpec base_spec(int threads, bool with_jkr, bool bonded) {
  ModelSpec spec;
  spec.materials = {{"fillet", 3.7e5, 0.37, 940.0}, {"steel", 2e11, 0.3, 7850.0}};
  spec.types = {{"fillet", 0}, {"belt", 1}};
  std::vector<LawSpec> pp = {{"hertz_mindlin", {{"restitution", bonded ? 1e-4 : 0.051}}}};
  std::vector<LawSpec> pw = pp;
  if (with_jkr) {
    pp.push_back({"jkr", {{"surface_energy_j_per_m2", 0.055}}});
    pw.push_back({"jkr", {{"surface_energy_j_per_m2", 0.055}}});
  }
  pp.push_back({"coulomb", {{"friction_coefficient", 0.1}}});
  pw.push_back({"coulomb", {{"friction_coefficient", 0.5}}});
  InteractionSpec fillet_fillet{0, 0, pp, std::nullopt, false};
  if (bonded) {
    fillet_fillet.bond_law =
        LawSpec{"bpm", {{"normal_stiffness_n_per_m3", 1e6}, {"shear_stiffness_n_per_m3", 6e4}}};
  }
  spec.interactions = {fillet_fillet, {0, 1, pw, std::nullopt, false}};
  spec.timestep_s = kDt;
  spec.thread_count = threads;
  spec.min_particles_per_thread = 1;  // the thread count asked for, whatever the size
  spec.neighbor_skin_m = 0.002;       // as the peers (run_peers.sh: neighbor 0.002 bin)
  return spec;
}

// nx x ny x nz spheres on an 8.8 mm lattice with 0.6 mm jitter; settle_steps before returning.
inline std::unique_ptr<Simulation> make_bed(int nx, int ny, int nz, int threads, int settle_steps) {
  const double a = 0.0088;
  ModelSpec spec = base_spec(threads, false, false);
  const double length_x = nx * a;
  const double length_y = ny * a;
  spec.domain.lower_m = Vec3(-0.01, -0.01, -0.01);
  spec.domain.upper_m = Vec3(length_x + 0.01, length_y + 0.01, (nz + 4) * a);
  spec.planes = {{"belt", 1, Vec3::Zero(), Vec3::UnitZ()},
                 {"x0", 1, Vec3::Zero(), Vec3::UnitX()},
                 {"x1", 1, Vec3(length_x, 0, 0), -Vec3::UnitX()},
                 {"y0", 1, Vec3::Zero(), Vec3::UnitY()},
                 {"y1", 1, Vec3(0, length_y, 0), -Vec3::UnitY()}};
  auto sim = std::make_unique<Simulation>(std::make_shared<Model>(spec));
  std::mt19937 random(32452843);
  std::uniform_real_distribution<double> jitter(-0.0006, 0.0006);
  sim->reserve(
      static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny) * static_cast<std::size_t>(nz),
      0);
  for (int z = 0; z < nz; ++z) {
    for (int y = 0; y < ny; ++y) {
      for (int x = 0; x < nx; ++x) {
        sim->add_sphere(
            {Vec3((x + 0.5) * a + jitter(random), (y + 0.5) * a + jitter(random), (z + 0.5) * a),
             kRadius, 0});
      }
    }
  }
  sim->wall("belt").surface_velocity_m_per_s = Vec3(0.3, 0, 0);
  sim->step(static_cast<std::size_t>(settle_steps));
  return sim;
}

// `fillets` blocks in two layers (fillets / 2 per layer on a near-square grid).
inline std::unique_ptr<Simulation> make_fillets(int fillets, int threads, bool with_jkr,
                                                int settle_steps,
                                                BondKernel kernel = BondKernel::kAuto) {
  const double a = 0.008;
  const int per_layer = fillets / 2;
  int fx = static_cast<int>(std::lround(std::sqrt(per_layer)));
  while (per_layer % fx != 0) --fx;
  const int fy = per_layer / fx;
  const double px = 14 * a, py = 12 * a, pz = 8 * a;
  ModelSpec spec = base_spec(threads, with_jkr, true);
  spec.bond_kernel = kernel;
  const double xmax = a + (fx - 1) * px + 7 * a + 10 * a + 0.02;
  const double ymax = a + (fy - 1) * py + 6 * a + 7 * a + 0.02;
  spec.domain.lower_m = Vec3(-0.05, -0.05, -0.01);
  spec.domain.upper_m = Vec3(xmax + 0.05, ymax + 0.05, 2 * pz + 0.06);
  spec.planes = {{"belt", 1, Vec3::Zero(), Vec3::UnitZ()}};
  auto sim = std::make_unique<Simulation>(std::make_shared<Model>(spec));
  std::vector<Vec3> block;
  for (int k = 0; k < 5; ++k) {
    for (int j = 0; j < 7; ++j) {
      for (int i = 0; i < 10; ++i) block.emplace_back(i * a, j * a, k * a);
    }
  }
  std::vector<double> radii(block.size(), kRadius);
  std::vector<std::uint8_t> types(block.size(), 0);
  std::vector<BodyBond> bonds;
  for (std::uint32_t p = 0; p < block.size(); ++p) {
    for (std::uint32_t q = p + 1; q < block.size(); ++q) {
      if ((block[p] - block[q]).norm() < a * std::sqrt(3.0) * 1.001) bonds.push_back({p, q, a});
    }
  }
  sim->reserve(block.size() * static_cast<std::size_t>(fillets),
               bonds.size() * static_cast<std::size_t>(fillets));
  for (int layer = 0; layer < 2; ++layer) {
    for (int p = 0; p < fx; ++p) {
      for (int q = 0; q < fy; ++q) {
        BodyPose pose;
        pose.position_m =
            Vec3(a + p * px + layer * 7 * a, a + q * py + layer * 6 * a, 0.625 * a + layer * pz);
        sim->add_body(block, radii, types, bonds, pose);
      }
    }
  }
  sim->wall("belt").surface_velocity_m_per_s = Vec3(0.3, 0, 0);
  sim->step(static_cast<std::size_t>(settle_steps));
  return sim;
}

}  // namespace fl::dem::race
