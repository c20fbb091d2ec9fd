// dem_race: one timed run of a race scenario (dem_scenarios.hpp) in the peers' format, for
// bench/dem_race/run.sh. Settles, then times `--steps` steps and prints one TSV line:
//   code scenario N bonds cores steps wall_s particle_steps_per_s contact_coord
// as ../shared/bench/run_peers.sh does for LIGGGHTS, LAMMPS and Yade.
#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <exception>
#include <string>

#include "dem_scenarios.hpp"

static int checked_main(int argc, char** argv) {
  CLI::App app{"time one DEM race scenario (particle-steps per second)"};
  std::string scenario;
  std::string tag;
  int nx = 50;
  int ny = 25;
  int nz = 8;
  int fillets = 14;
  int threads = 1;
  int settle_steps = 3000;
  int steps = 3000;
  app.add_option("--scenario", scenario, "bed | fillets | fillets_jkr")
      ->required()
      ->check(CLI::IsMember({"bed", "fillets", "fillets_jkr"}));
  app.add_option("--tag", tag, "name in the output (default: the scenario)");
  app.add_option("--nx", nx, "bed lattice count in x")->check(CLI::Range(1, 2000));
  app.add_option("--ny", ny, "bed lattice count in y")->check(CLI::Range(1, 2000));
  app.add_option("--nz", nz, "bed layers")->check(CLI::Range(1, 100));
  app.add_option("--fillets", fillets, "bonded blocks (even)")->check(CLI::Range(2, 100000));
  app.add_option("--threads", threads, "engine threads")->check(CLI::Range(1, 256));
  app.add_option("--settle", settle_steps, "steps before timing")->check(CLI::Range(0, 10000000));
  app.add_option("--steps", steps, "timed steps")->check(CLI::Range(1, 10000000));
  std::string bond_kernel = "auto";
  app.add_option("--bond-kernel", bond_kernel,
                 "bonded law's code (same results): auto | scalar | avx2")
      ->check(CLI::IsMember({"auto", "scalar", "avx2"}));
  CLI11_PARSE(app, argc, argv);
  const fl::dem::BondKernel kernel = bond_kernel == "scalar" ? fl::dem::BondKernel::kScalar
                                     : bond_kernel == "avx2" ? fl::dem::BondKernel::kAvx2Vector
                                                             : fl::dem::BondKernel::kAuto;
  if (tag.empty()) tag = scenario;

  namespace race = fl::dem::race;
  auto sim = scenario == "bed" ? race::make_bed(nx, ny, nz, threads, settle_steps)
                               : race::make_fillets(fillets, threads, scenario == "fillets_jkr",
                                                    settle_steps, kernel);
  const std::uint64_t rebuilds_before = sim->stats().neighbor_rebuilds;
  const auto start = std::chrono::steady_clock::now();
  sim->step(static_cast<std::size_t>(steps));
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double n = static_cast<double>(sim->state().size());
  std::printf("ours\t%s\t%zu\t%zu\t%d\t%d\t%.3f\t%.3e\t%.2f\n", tag.c_str(), sim->state().size(),
              sim->state().bonds.size() - sim->stats().broken_bonds, sim->active_thread_count(),
              steps, wall_s, n * steps / wall_s,
              2.0 * static_cast<double>(sim->stats().touching_pairs) / n);
  // stderr, so that the TSV line stays one line: how often the Verlet list was rebuilt
  const bool vector_bonds = kernel != fl::dem::BondKernel::kScalar &&
                            fl::dem::avx2_bond_kernel_available() && !sim->state().bonds.empty();
  std::fprintf(stderr, "%s: %llu neighbour rebuilds in %d timed steps; bonds %s\n", tag.c_str(),
               static_cast<unsigned long long>(sim->stats().neighbor_rebuilds - rebuilds_before),
               steps,
               sim->state().bonds.empty() ? "none"
               : vector_bonds             ? "avx2"
                                          : "scalar");
  return 0;
}

int main(int argc, char** argv) {
  // What escapes the commands' own handling (an option table that throws, memory): a message
  // and exit status 1 instead of std::terminate.
  try {
    return checked_main(argc, argv);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "dem_race: %s\n", error.what());
  } catch (...) {
    std::fprintf(stderr, "dem_race: unknown error\n");
  }
  return 1;
}
