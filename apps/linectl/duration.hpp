// Parsing of human durations for the command line: "90", "90s", "10m", "1h", "1h30m".
#pragma once

#include <optional>
#include <string_view>

namespace fl::apps {

// Seconds, or nullopt when the text is not a positive duration.
std::optional<double> parse_duration_s(std::string_view text);

}  // namespace fl::apps
