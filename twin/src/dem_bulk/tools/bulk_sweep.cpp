// bulk_sweep: the mailbox's outflow against its opening in the DEM (thesis 6.1 as a model run).
//   bulk_sweep [--config config/bulk_dem.yaml] [--out out/bulk_sweep.csv]
//              [--settle 0.5] [--measure 2.0] [--fill N] [opening_mm ...]
// Prints one line per opening and writes the CSV (fl_report).
#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>
#include <stdexcept>
#include <string>
#include <vector>

#include "fl/twin/dem_bulk/bulk_scene.hpp"

static int checked_main(int argc, char** argv) {
  CLI::App app{"the DEM mailbox's outflow against its gate opening (thesis 6.1)"};
  std::string config_file = "config/bulk_dem.yaml";
  std::string out_file = "out/bulk_sweep.csv";
  fl::GateSweepOptions options;
  int fill = -1;
  std::vector<double> openings_mm = {40.0, 60.0, 80.0, 100.0};
  app.add_option("--config", config_file, "bulk scene configuration")->check(CLI::ExistingFile);
  app.add_option("--out", out_file, "CSV written with one row per opening");
  app.add_option("--settle", options.settle_s, "seconds of flow before measuring");
  app.add_option("--measure", options.measure_s,
                 "seconds measured at each opening (whole control steps)");
  app.add_option("--fill", fill, "fillets in the hopper at the start (default: the config's)")
      ->check(CLI::Range(0, 100000));
  app.add_option("opening_mm", openings_mm, "gate openings in mm (default: 40 60 80 100)");
  CLI11_PARSE(app, argc, argv);
  try {
    fl::BulkDemConfig config = fl::load_bulk_dem_config(config_file);
    if (fill >= 0) config.feeder.initial_fill = static_cast<std::uint32_t>(fill);
    const std::vector<fl::GateSweepPoint> points =
        fl::sweep_gate_opening(config, openings_mm, options);
    for (const fl::GateSweepPoint& p : points) {
      std::printf(
          "opening %6.1f mm: %5.2f fillets/s under the gate (%llu), %5.2f/s discharged, "
          "%6.3f kg/s, leveller %6.3f Nm, %5.1f s wall\n",
          p.opening_mm, p.gate_passes_per_s, static_cast<unsigned long long>(p.gate_passes),
          p.outflow_per_s, p.mass_flow_kg_per_s, p.leveller_torque_nm, p.wall_s);
    }
    fl::write_gate_sweep_csv(points, out_file);
  } catch (const std::runtime_error& e) {  // a sweep the scene cannot measure as asked
    std::fprintf(stderr, "bulk_sweep: %s (%s)\n", e.what(), config_file.c_str());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bulk_sweep: %s\n", e.what());
    return 1;
  }
  return 0;
}

int main(int argc, char** argv) {
  // What escapes the commands' own handling (an option table that throws, memory): a message
  // and exit status 1 instead of std::terminate.
  try {
    return checked_main(argc, argv);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "bulk_sweep: %s\n", error.what());
  } catch (...) {
    std::fprintf(stderr, "bulk_sweep: unknown error\n");
  }
  return 1;
}
