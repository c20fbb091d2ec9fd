// bulk_sweep: the mailbox's outflow against its opening in the DEM (thesis 6.1 as a model run).
//   bulk_sweep [--config config/bulk_dem.yaml] [--out out/bulk_sweep.csv]
//              [--settle 0.5] [--measure 2.0] [--fill N] [opening_mm ...]
// Prints one line per opening and writes the CSV (fl_report).
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>

#include "fl/twin/dem_bulk/bulk_scene.hpp"

int main(int argc, char** argv) {
  std::string config_file = "config/bulk_dem.yaml";
  std::string out_file = "out/bulk_sweep.csv";
  fl::GateSweepOptions options;
  long fill = -1;
  std::vector<double> openings;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const bool has_value = i + 1 < argc;
    if (arg == "--config" && has_value) {
      config_file = argv[++i];
    } else if (arg == "--out" && has_value) {
      out_file = argv[++i];
    } else if (arg == "--settle" && has_value) {
      options.settle_s = std::strtod(argv[++i], nullptr);
    } else if (arg == "--measure" && has_value) {
      options.measure_s = std::strtod(argv[++i], nullptr);
    } else if (arg == "--fill" && has_value) {
      fill = std::strtol(argv[++i], nullptr, 10);
    } else {
      openings.push_back(std::strtod(arg.c_str(), nullptr));
    }
  }
  if (openings.empty()) openings = {40.0, 60.0, 80.0, 100.0};
  try {
    fl::BulkDemConfig config = fl::load_bulk_dem_config(config_file);
    if (fill >= 0) config.feeder.initial_fill = static_cast<std::uint32_t>(fill);
    const std::vector<fl::GateSweepPoint> points =
        fl::sweep_gate_opening(config, openings, options);
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
