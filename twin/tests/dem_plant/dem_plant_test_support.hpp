// Shared scaffolding for the DEM plant's tests: one plant per test binary run (templates take
// a moment), the reference line, belts running at their nominal speeds.
#pragma once

#include <cmath>
#include <cstdint>
#include <memory>

#include "../plant_test_support.hpp"
#include "fl/controller/line_config.hpp"
#include "fl/twin/dem_plant/dem_plant.hpp"

namespace fl::test {

// The shipped configuration (7 mm spheres) on one engine thread: a test rig holds a few
// fillets (under 200 spheres), where the threads' barriers cost more than they share, above
// all on a loaded machine. The determinism test runs two threads.
inline DemPlantConfig test_config(int threads = 1) {
  DemPlantConfig config = load_dem_plant_config(FL_SOURCE_DIR "/config/plant_dem.yaml");
  config.simulation.thread_count = threads;
  return config;
}

struct DemRig {
  explicit DemRig(DemPlantConfig plant_config = test_config(),
                  LineConfig line_config = default_line_config(), std::uint64_t seed = 1)
      : line(line_config),
        config(std::move(plant_config)),
        plant(std::make_unique<DemPlant>(line, config)),
        out(belts_running(line)) {
    plant->reset(seed, in);
  }
  void step(std::int64_t dt_ns = 10 * kMs) { plant->step(out, dt_ns, in); }
  void run(double seconds, std::int64_t dt_ns = 10 * kMs) {
    const auto steps = std::llround(seconds * 1e9 / static_cast<double>(dt_ns));
    for (std::int64_t i = 0; i < steps; ++i) step(dt_ns);
  }
  LineConfig line;
  DemPlantConfig config;
  std::unique_ptr<DemPlant> plant;
  OutputImage out;
  InputImage in{};
};

}  // namespace fl::test
