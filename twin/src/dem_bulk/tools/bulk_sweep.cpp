// bulk_sweep: the mailbox's outflow against its opening in the DEM (thesis 6.1 as a model run).
//   bulk_sweep [--config config/bulk_dem.yaml] [--out out/bulk_sweep.csv]
//              [--settle 0.5] [--measure 2.0] [--fill N] [opening_mm ...]
// Prints one line per opening and writes the CSV (fl_report).
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include "fl/twin/dem_bulk/bulk_scene.hpp"

int main(int argc, char** argv) {
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
    // The scene would clamp an opening to the gate's travel and round the times to whole
    // control steps, while the rates are divided by the time asked for: a sweep point that
    // silently measured something other than what was asked is worse than no point. NaN
    // passes every comparison, so each range is written as what is allowed.
    const double step_s = config.simulation.control_step_s;
    const auto refuse = [&config_file](const std::string& what) {
      std::fprintf(stderr, "bulk_sweep: %s (%s)\n", what.c_str(), config_file.c_str());
      return 2;
    };
    const auto whole_steps = [step_s](double seconds) {
      const double steps = seconds / step_s;
      return std::abs(steps - std::round(steps)) <= 1e-9 * std::max(1.0, steps);
    };
    if (!(options.settle_s >= 0.0) || !std::isfinite(options.settle_s) ||
        !whole_steps(options.settle_s)) {
      return refuse("--settle " + std::to_string(options.settle_s) +
                    " s must be zero or more whole control steps of " + std::to_string(step_s) +
                    " s");
    }
    if (!(options.measure_s >= step_s) || !std::isfinite(options.measure_s) ||
        !whole_steps(options.measure_s)) {
      return refuse("--measure " + std::to_string(options.measure_s) +
                    " s must be one or more whole control steps of " + std::to_string(step_s) +
                    " s");
    }
    for (const double opening : openings_mm) {
      if (!(opening >= config.gate.min_opening_mm && opening <= config.gate.max_opening_mm)) {
        return refuse("opening " + std::to_string(opening) + " mm is outside the gate's travel " +
                      std::to_string(config.gate.min_opening_mm) + " to " +
                      std::to_string(config.gate.max_opening_mm) + " mm");
      }
    }
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
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bulk_sweep: %s\n", e.what());
    return 1;
  }
  return 0;
}
