#include "csv_reader.hpp"

#include <fstream>

namespace fl::workbench::detail {

bool split_csv_line(const std::string& line, std::vector<std::string>& fields, std::string& error) {
  fields.clear();
  std::string field;
  std::size_t k = 0;
  for (;;) {
    field.clear();
    if (k < line.size() && line[k] == '"') {
      ++k;
      for (;;) {
        if (k >= line.size()) {
          error = "a quoted field is not closed";
          return false;
        }
        if (line[k] == '"') {
          if (k + 1 < line.size() && line[k + 1] == '"') {
            field += '"';
            k += 2;
            continue;
          }
          ++k;
          break;
        }
        field += line[k++];
      }
      if (k < line.size() && line[k] != ',') {
        error = "text after a closing quote (field " + std::to_string(fields.size() + 1) + ")";
        return false;
      }
    } else {
      while (k < line.size() && line[k] != ',') {
        if (line[k] == '"') {
          error =
              "a quote inside an unquoted field (field " + std::to_string(fields.size() + 1) + ")";
          return false;
        }
        field += line[k++];
      }
    }
    fields.push_back(field);
    if (k >= line.size()) return true;
    ++k;  // the comma
  }
}

bool read_csv(const std::filesystem::path& file, std::vector<CsvRow>& rows,
              std::vector<CsvIssue>& issues) {
  std::ifstream in(file, std::ios::binary);
  if (!in) {
    issues.push_back({0, 0, "cannot open the file"});
    return false;
  }
  std::string line;
  int number = 0;
  std::string error;
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.find('\0') != std::string::npos) {
      issues.push_back({number, 0, "binary data (a NUL byte): not a text file"});
      return true;
    }
    const auto first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    CsvRow row;
    row.line = number;
    if (!split_csv_line(line, row.fields, error)) {
      issues.push_back({number, 0, error});
      continue;
    }
    rows.push_back(std::move(row));
  }
  return true;
}

}  // namespace fl::workbench::detail
