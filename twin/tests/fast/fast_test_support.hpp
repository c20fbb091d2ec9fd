// Shared scaffolding for the fast plant's tests: a plant on the reference line, an output
// image that runs the belts, and stepping helpers.
#pragma once

#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>

#include "../plant_test_support.hpp"
#include "fl/controller/line_config.hpp"
#include "fl/twin/fast_plant.hpp"

namespace fl::test {

// A plant without random disturbances on the bodies, for analytic checks.
inline FastPlantConfig quiet_config() {
  FastPlantConfig config;
  config.multilane.disturbance_rad_per_sqrt_s = 0.0F;
  config.squeeze.stuck_disturbance_rad_per_sqrt_s = 0.0F;
  return config;
}

struct Rig {
  explicit Rig(FastPlantConfig plant_config = quiet_config(),
               LineConfig line_config = default_line_config(), std::uint64_t seed = 1)
      : line(line_config),
        config(plant_config),
        plant(std::make_unique<FastPlant>(line, config)),
        out(belts_running(line)) {
    plant->reset(seed, in);
  }

  void step(std::int64_t dt_ns = kMs) { plant->step(out, dt_ns, in); }

  // Runs whole steps of dt for `seconds`.
  void run(double seconds, std::int64_t dt_ns = kMs) {
    const auto steps = std::llround(seconds * 1e9 / static_cast<double>(dt_ns));
    for (std::int64_t i = 0; i < steps; ++i) step(dt_ns);
  }

  // Steps until `done` holds (true) or `max_seconds` pass (false).
  bool run_until(const std::function<bool()>& done, double max_seconds, std::int64_t dt_ns = kMs) {
    const std::int64_t end_ns = in.time_ns + static_cast<std::int64_t>(max_seconds * 1e9);
    while (in.time_ns < end_ns) {
      if (done()) return true;
      step(dt_ns);
    }
    return done();
  }

  // The body of a group id, or nullptr once it has left.
  [[nodiscard]] const FilletBody* body(std::uint32_t group_id) const {
    for (const FilletBody& candidate : plant->bodies()) {
      if (candidate.group_id == group_id) return &candidate;
    }
    return nullptr;
  }

  [[nodiscard]] double time_s() const { return static_cast<double>(in.time_ns) * 1e-9; }

  LineConfig line;
  FastPlantConfig config;
  std::unique_ptr<FastPlant> plant;
  OutputImage out;
  InputImage in{};
};

}  // namespace fl::test
