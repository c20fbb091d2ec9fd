// "0x0205", "0x60400010": how the drivers write identifiers, indices and mapping values in
// problems and logs, as device manuals print them (upper-case, zero-padded).
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>

namespace fl::drivers {

inline std::string hex_text(std::uint32_t value, int digits) {
  char text[16];
  std::snprintf(text, sizeof text, "0x%0*X", digits, value);
  return text;
}

}  // namespace fl::drivers
