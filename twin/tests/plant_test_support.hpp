// Scaffolding both plants' tests share (fast/fast_test_support.hpp,
// dem_plant/dem_plant_test_support.hpp), and twin/bench/dem_line_load: time steps and an
// output image that runs the belts.
#pragma once

#include <cstdint>
#include <utility>

#include "fl/controller/line_config.hpp"
#include "fl/controller/process_image.hpp"

namespace fl::test {

inline constexpr std::int64_t kMs = 1000000;

// Every product-path drive enabled at its nominal speed, ramping as fast as allowed; no
// infeed (bulk and leveller off, so nothing is fed), stations idle.
inline OutputImage belts_running(const LineConfig& line) {
  OutputImage out{};
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    out.drives[d].enable = true;
    out.drives[d].speed_mps = line.sections[d].nominal_speed_mps;
    out.drives[d].accel_mps2 = 0.0F;
  }
  // The right multilane belts have no section of their own: same speed as the left.
  for (auto [left, right] : {std::pair{DriveId::kMultilane1Left, DriveId::kMultilane1Right},
                             std::pair{DriveId::kMultilane2Left, DriveId::kMultilane2Right}}) {
    out.drives[index(right)].speed_mps = out.drives[index(left)].speed_mps;
  }
  out.drives[index(DriveId::kBulk)].speed_mps = 0.0F;
  return out;
}

}  // namespace fl::test
