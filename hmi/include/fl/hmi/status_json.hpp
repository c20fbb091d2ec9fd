// The HMI's wire format: LineStatus snapshots and the line layout as JSON (docs/hmi.md,
// "Data protocol"). Built on the broadcaster thread, never in the scan.
#pragma once

#include <cstdint>
#include <deque>
#include <nlohmann/json.hpp>
#include <optional>
#include <string_view>

#include "fl/controller/line_config.hpp"
#include "fl/controller/line_status.hpp"

namespace fl::hmi {

// Drives, cameras, hands, sides and line states go out as fl::to_string names
// (process_image.hpp); fl::parse reads them back.

// Fillets placed per minute over the last minute of snapshots (less at the start).
class ThroughputMeter {
 public:
  void add(std::int64_t time_ns, std::uint64_t placed);
  // Null until 5 s of history are there.
  [[nodiscard]] std::optional<double> placed_per_minute() const;

 private:
  std::deque<std::pair<std::int64_t, std::uint64_t>> samples_;
};

// {"type":"status", ...}: every field of the snapshot the page shows.
nlohmann::json status_to_json(const LineStatus& status, std::optional<double> placed_per_minute);

// {"sections":[...], "cameras":[...], "stations":{...}}: where things are along s_mm.
nlohmann::json layout_to_json(const LineConfig& line);

}  // namespace fl::hmi
