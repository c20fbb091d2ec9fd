#include "fl/controller/line_config.hpp"

namespace fl {

DriveId drive_under(const LineConfig& line, double s_mm) {
  // Flow order is DriveId order (config_loader's check_sections); takt is the first belt.
  DriveId before = DriveId::kTakt;
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    const auto id = static_cast<DriveId>(d);
    if (!has_section(id)) continue;
    if (s_mm < line.sections[d].start_mm) return before;
    if (s_mm < line.sections[d].end_mm) return id;
    before = id;
  }
  return before;
}

LineConfig default_line_config() {
  LineConfig config;
  auto section = [&](DriveId id, float start_mm, float end_mm, float speed_mps) {
    config.sections[index(id)] = BeltSection{start_mm, end_mm, speed_mps};
  };
  // Product path, s = 0 at the takt barrier. Belts get faster downstream so that each
  // transfer pulls the items further apart (thesis 5.2.3, speed transitions).
  section(DriveId::kTakt, -600.0F, 0.0F, 0.12F);
  section(DriveId::kTransition1, 0.0F, 500.0F, 0.30F);
  section(DriveId::kTransition2, 500.0F, 1000.0F, 0.45F);
  section(DriveId::kGuide, 1000.0F, 2000.0F, 0.50F);
  // 2000..2200: the two flip plates, passive slides between guide and reject belt.
  section(DriveId::kReject, 2200.0F, 2800.0F, 0.50F);
  section(DriveId::kCentring, 2800.0F, 3400.0F, 0.50F);
  section(DriveId::kMultilane1Left, 3400.0F, 3800.0F, 0.60F);
  section(DriveId::kMultilane2Left, 3800.0F, 4200.0F, 0.60F);
  section(DriveId::kSqueeze, 4200.0F, 4900.0F, 0.50F);
  section(DriveId::kOutfeed, 4900.0F, 5500.0F, 0.50F);
  config.placed_at_s_mm = 5500.0F;
  config.takt_belt_length_mm = 600.0F;

  for (auto& limits : config.limits) limits = DriveLimits{1.0F, 5.0F, 10.0F};
  config.limits[index(DriveId::kTakt)].max_accel_mps2 = 8.0F;
  for (DriveId id : {DriveId::kMultilane1Left, DriveId::kMultilane1Right, DriveId::kMultilane2Left,
                     DriveId::kMultilane2Right}) {
    config.limits[index(id)].max_accel_mps2 = 6.0F;
  }

  auto camera = [&](CameraId id, float s_mm, float fov_mm, float period_s, float max_age_s) {
    config.cameras[index(id)] = CameraMount{s_mm, fov_mm, period_s, max_age_s};
  };
  camera(CameraId::kOrientation, 1850.0F, 300.0F, 0.04F, 0.1F);
  camera(CameraId::kPosition, 2950.0F, 300.0F, 0.04F, 0.1F);
  camera(CameraId::kMultilane1, 3600.0F, 400.0F, 0.025F, 0.06F);
  camera(CameraId::kMultilane2, 4000.0F, 400.0F, 0.025F, 0.06F);
  camera(CameraId::kFinal, 4650.0F, 300.0F, 0.04F, 0.1F);

  config.flip.plate1_s_mm = 2050.0F;
  config.flip.plate2_s_mm = 2150.0F;
  config.centring.s_mm = 3200.0F;
  config.squeeze.roller_s_mm = 4400.0F;
  config.tolerance.final_reject_s_mm = 4850.0F;
  return config;
}

}  // namespace fl
