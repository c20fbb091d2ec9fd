// Strict CSV reading for measurement files: RFC 4180 fields (quotes, doubled quotes, no line
// breaks inside a field), '#' comment lines and blank lines skipped, CRLF or LF. Every problem
// carries the file's line number, so a user finds it in their editor.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace fl::workbench::detail {

struct CsvRow {
  int line = 0;  // 1-based line in the file
  std::vector<std::string> fields;
};

struct CsvIssue {
  int line = 0;
  int column = 0;  // 1-based field number; 0 for the whole line
  std::string message;
};

// Appends the rows (header first) to `rows` and problems to `issues`; false when the file
// could not be read at all.
bool read_csv(const std::filesystem::path& file, std::vector<CsvRow>& rows,
              std::vector<CsvIssue>& issues);

// One line's fields; nullopt-like empty result with an issue when quoting is broken.
bool split_csv_line(const std::string& line, std::vector<std::string>& fields, std::string& error);

}  // namespace fl::workbench::detail
