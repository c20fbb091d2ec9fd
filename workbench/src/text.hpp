// Small text helpers shared by the workbench's readers and report writers.
#pragma once

#include <sstream>
#include <string>
#include <string_view>

namespace fl::workbench::detail {

// Without leading and trailing blanks (spaces and tabs).
inline std::string_view trim(std::string_view text) {
  while (!text.empty() && (text.front() == ' ' || text.front() == '\t')) text.remove_prefix(1);
  while (!text.empty() && (text.back() == ' ' || text.back() == '\t')) text.remove_suffix(1);
  return text;
}

// A number for people to read, to `digits` significant digits: "0.123", "1.5e+06".
inline std::string significant(double value, int digits) {
  std::ostringstream out;
  out.precision(digits);
  out << value;
  return out.str();
}

}  // namespace fl::workbench::detail
