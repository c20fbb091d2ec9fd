#include "cli_support.hpp"

#include <numbers>
#include <stdexcept>

#include "fl/twin/dem_plant/dem_plant.hpp"
#include "fl/twin/fast_plant.hpp"
#include "fl/twin/fast_plant_config.hpp"

namespace fl::apps {

std::filesystem::path default_config(const char* file) {
  const std::filesystem::path source = std::filesystem::path(FL_SOURCE_DIR) / "config" / file;
  if (std::filesystem::exists(source)) return source;
  return std::filesystem::path("config") / file;
}

std::unique_ptr<Plant> make_plant(const std::string& name, const std::string& plant_config,
                                  const LineConfig& line) {
  if (name == "fast") {
    const std::filesystem::path file = plant_config.empty() ? default_config("plant_fast.yaml")
                                                            : std::filesystem::path(plant_config);
    return std::make_unique<FastPlant>(line, load_fast_plant_config(file));
  }
  if (name == "dem") {
    const std::filesystem::path file = plant_config.empty() ? default_config("plant_dem.yaml")
                                                            : std::filesystem::path(plant_config);
    return std::make_unique<DemPlant>(line, load_dem_plant_config(file));
  }
  throw std::runtime_error("--plant " + name + ": unknown plant (choose fast or dem)");
}

LedgerWriter::LedgerWriter(const std::string& path) {
  if (path.empty()) return;
  file_.open(path);
  if (!file_) throw std::runtime_error("--ledger " + path + ": cannot open for writing");
  file_ << "id,created_s,closed_s,outcome,lost_reason,hand,side_seen,singulated,flip_plate1,"
           "flip_plate2,multilane_unit,angle_at_camera1_deg,final_angle_deg,final_y_mm\n";
}

void LedgerWriter::write(const FilletRecord& r) {
  if (!file_.is_open()) return;
  constexpr double kDeg = 180.0 / std::numbers::pi;
  file_ << r.id << ',' << static_cast<double>(r.created_ns) / 1e9 << ','
        << static_cast<double>(r.closed_ns) / 1e9 << ',' << to_string(r.outcome) << ','
        << to_string(r.lost_reason) << ',' << static_cast<int>(r.hand) << ','
        << static_cast<int>(r.side_seen) << ',' << r.singulated << ',' << r.flip_plate1 << ','
        << r.flip_plate2 << ',' << static_cast<int>(r.multilane_unit) << ','
        << r.angle_at_camera1_rad * kDeg << ',' << r.final_angle_rad * kDeg << ',' << r.final_y_mm
        << '\n';
}

}  // namespace fl::apps
