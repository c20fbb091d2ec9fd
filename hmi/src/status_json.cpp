#include "fl/hmi/status_json.hpp"

#include <array>
#include <bit>
#include <cmath>

namespace fl::hmi {
namespace {

// One word for the page's colour key: what the controller will do with the fillet next.
const char* item_state(const TrackedItemView& item) {
  if (item.reject_pending) return "reject";
  if (!item.classified) return "unclassified";
  if (item.orienting_done) return "oriented";
  if (item.multilane_unit >= 0) return "orienting";
  return "classified";
}

double ms(std::int64_t ns) { return static_cast<double>(ns) / 1e6; }

// JSON has no NaN: a non-finite value goes out as null.
nlohmann::json number(float value) {
  return std::isfinite(value) ? nlohmann::json(static_cast<double>(value)) : nlohmann::json();
}

}  // namespace

void ThroughputMeter::add(std::int64_t time_ns, std::uint64_t placed) {
  constexpr std::int64_t kWindowNs = 60'000'000'000;
  if (!samples_.empty() && placed < samples_.back().second) samples_.clear();  // counters reset
  samples_.emplace_back(time_ns, placed);
  while (samples_.size() > 2 && time_ns - samples_[1].first >= kWindowNs) samples_.pop_front();
}

std::optional<double> ThroughputMeter::placed_per_minute() const {
  if (samples_.size() < 2) return std::nullopt;
  const auto& [first_ns, first_placed] = samples_.front();
  const auto& [last_ns, last_placed] = samples_.back();
  const double span_s = static_cast<double>(last_ns - first_ns) / 1e9;
  if (span_s < 5.0) return std::nullopt;
  return 60.0 * static_cast<double>(last_placed - first_placed) / span_s;
}

nlohmann::json status_to_json(const LineStatus& status, std::optional<double> placed_per_minute) {
  using nlohmann::json;
  json drives = json::object();
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    const DriveStatus& drive = status.drives[d];
    drives[std::string(to_string(static_cast<DriveId>(d)))] = {
        {"command_mps", number(drive.command_mps)},
        {"speed_mps", number(drive.speed_mps)},
        {"enabled", drive.enabled},
        {"ready", drive.ready},
        {"fault", drive.fault}};
  }
  json fillets = json::array();
  for (std::uint32_t i = 0; i < status.tracked_count && i < status.tracked.size(); ++i) {
    const TrackedItemView& item = status.tracked[i];
    json fillet = {{"id", item.id},
                   {"s_mm", number(item.s_mm)},
                   {"y_mm", number(item.y_mm)},
                   {"angle_rad", item.angle_known ? number(item.angle_rad) : json()},
                   {"state", item_state(item)},
                   {"lane", item.multilane_unit >= 0 ? json(item.multilane_unit + 1) : json()},
                   {"hand", to_string(item.hand)},
                   {"side", to_string(item.side)},
                   {"flip_plate1", item.flip_plate1},
                   {"flip_plate2", item.flip_plate2}};
    if (item.reject_pending) fillet["reject_reason"] = to_string(item.reject_reason);
    fillets.push_back(std::move(fillet));
  }
  json faults = json::array();
  for (std::size_t f = 0; f < static_cast<std::size_t>(FaultCode::kCount); ++f) {
    const auto code = static_cast<FaultCode>(f);
    if ((status.active_faults & fault_bit(code)) != 0) faults.push_back(to_string(code));
  }
  const ControllerCounters& counters = status.counters;
  json outcomes = json::object();
  std::uint64_t closed = 0;
  for (std::size_t o = 1; o < kOutcomeCount; ++o) {  // 0 is "in transit"
    outcomes[to_string(static_cast<Outcome>(o))] = counters.outcomes[o];
    closed += counters.outcomes[o];
  }
  const std::uint64_t placed = counters.outcomes[static_cast<std::size_t>(Outcome::kPlaced)];
  const ScanTimingStatus& timing = status.timing;
  return json{
      {"type", "status"},
      {"sequence", status.sequence},
      {"time_s", static_cast<double>(status.time_ns) / 1e9},
      {"state", to_string(status.state)},
      {"estop_ok", status.estop_ok},
      {"faults", faults},
      {"drives", drives},
      {"actuators",
       {{"flip_plate1",
         {{"flip", status.flip_plate1_flip}, {"flipping", status.flip_plate1_flipping}}},
        {"flip_plate2",
         {{"flip", status.flip_plate2_flip}, {"flipping", status.flip_plate2_flipping}}},
        {"reject_reversing", status.reject_reversing},
        {"final_reject", status.final_reject},
        {"centring_stroke", status.centring_stroke},
        {"centring_shift_mm", number(status.centring_shift_mm)},
        {"squeeze_roller_down", status.squeeze_roller_down},
        {"level_mm", number(status.level_mm)},
        {"hopper_opening_mm", number(status.hopper_opening_mm)},
        {"leveller_speed_rpm", number(status.leveller_speed_rpm)}}},
      {"fillets", fillets},
      {"kpis",
       {{"placed_per_min", placed_per_minute ? json(*placed_per_minute) : json()},
        {"placed", placed},
        {"closed", closed},
        {"placed_share",
         closed > 0 ? json(static_cast<double>(placed) / static_cast<double>(closed)) : json()},
        {"outcomes", outcomes},
        {"items_created", counters.items_created},
        {"items_adopted", counters.items_adopted},
        {"estimates_rejected", counters.estimates_rejected},
        {"records_dropped", status.records_dropped},
        {"events_dropped", status.events_dropped}}},
      {"timing",
       {{"period_ms", ms(timing.period_ns)},
        {"wakeup_latency_ms", ms(timing.last_wakeup_latency_ns)},
        {"compute_ms", ms(timing.last_compute_ns)},
        {"window_max_wakeup_latency_ms", ms(timing.window_max_wakeup_latency_ns)},
        {"window_max_compute_ms", ms(timing.window_max_compute_ns)},
        {"max_wakeup_latency_ms", ms(timing.max_wakeup_latency_ns)},
        {"max_compute_ms", ms(timing.max_compute_ns)},
        {"scans", timing.scans},
        {"overruns", timing.overruns}}}};
}

nlohmann::json layout_to_json(const LineConfig& line) {
  using nlohmann::json;
  json sections = json::array();
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    const BeltSection& section = line.sections[d];
    if (section.end_mm <= section.start_mm) continue;  // bulk, multilane right belts
    sections.push_back({{"drive", to_string(static_cast<DriveId>(d))},
                        {"start_mm", section.start_mm},
                        {"end_mm", section.end_mm},
                        {"nominal_speed_mps", section.nominal_speed_mps}});
  }
  json cameras = json::array();
  for (std::size_t c = 0; c < kCameraCount; ++c) {
    cameras.push_back({{"name", to_string(static_cast<CameraId>(c))},
                       {"s_mm", line.cameras[c].s_mm},
                       {"field_of_view_mm", line.cameras[c].field_of_view_mm}});
  }
  return json{{"type", "layout"},
              {"takt_belt_length_mm", line.takt_belt_length_mm},
              {"placed_at_s_mm", line.placed_at_s_mm},
              {"sections", sections},
              {"cameras", cameras},
              {"stations",
               {{"flip_plate1_s_mm", line.flip.plate1_s_mm},
                {"flip_plate2_s_mm", line.flip.plate2_s_mm},
                {"centring_s_mm", line.centring.s_mm},
                {"squeeze_roller_s_mm", line.squeeze.roller_s_mm},
                {"final_reject_s_mm", line.tolerance.final_reject_s_mm}}},
              {"drives", kDriveNames},
              {"camera_names", kCameraNames}};
}

}  // namespace fl::hmi
