#include "duration.hpp"

#include <cctype>
#include <charconv>
#include <cmath>

namespace fl::apps {

std::optional<double> parse_duration_s(std::string_view text) {
  if (text.empty()) return std::nullopt;
  double total_s = 0.0;
  std::size_t pos = 0;
  while (pos < text.size()) {
    double value = 0.0;
    const auto [end, error] = std::from_chars(text.data() + pos, text.data() + text.size(), value);
    if (error != std::errc{} || end == text.data() + pos || !std::isfinite(value) || value < 0.0) {
      return std::nullopt;
    }
    pos = static_cast<std::size_t>(end - text.data());
    double unit_s = 1.0;  // a bare number is seconds
    if (pos < text.size()) {
      switch (text[pos]) {
        case 's':
          unit_s = 1.0;
          break;
        case 'm':
          unit_s = 60.0;
          break;
        case 'h':
          unit_s = 3600.0;
          break;
        default:
          return std::nullopt;
      }
      ++pos;
    } else if (total_s > 0.0) {
      return std::nullopt;  // "1h30" is ambiguous
    }
    total_s += value * unit_s;
  }
  if (total_s <= 0.0) return std::nullopt;
  return total_s;
}

}  // namespace fl::apps
