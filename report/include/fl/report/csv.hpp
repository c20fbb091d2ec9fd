// CSV tables for people and spreadsheets: a header row whose column names carry their units
// ("time_s", "force_n"), RFC 4180 quoting (fields with a comma, quote, CR or LF are quoted,
// quotes doubled), CRLF line ends, numbers in the shortest text that reads back exactly.
//
//   fl::report::CsvTable table({"time_s", "force_n", "note"});
//   table.add_row({0.0, 1.5, "start"});
//   table.write("out/compress.csv");
//
// Malformed input throws fl::report::ReportError naming the row and column: a row of the wrong
// length, a NaN or infinite number (write an empty cell, CsvCell{}, for a missing value),
// empty or duplicate column names.
#pragma once

#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

namespace fl::report {

class ReportError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

// Empty (missing value), number, or text.
using CsvCell = std::variant<std::monostate, double, std::string>;

class CsvTable {
 public:
  explicit CsvTable(std::vector<std::string> columns);

  void add_row(std::vector<CsvCell> cells);
  // Adds one row per index from equally long numeric columns.
  void add_columns(const std::vector<std::vector<double>>& columns);

  [[nodiscard]] const std::vector<std::string>& columns() const { return columns_; }
  [[nodiscard]] std::size_t row_count() const { return rows_.size(); }
  [[nodiscard]] std::string to_string() const;
  // Creates parent folders; throws ReportError when the file cannot be written.
  void write(const std::filesystem::path& file) const;

 private:
  std::vector<std::string> columns_;
  std::vector<std::vector<CsvCell>> rows_;
};

// Shortest decimal text that reads back as the same double ("0.1", "1e+300").
std::string format_double(double value);

// One text field as CsvTable writes it: quoted, quotes doubled, when it holds a comma, quote,
// CR or LF; as it is otherwise. For writers that append rows themselves.
std::string csv_quote(std::string_view field);

// RFC 4180 reader (also accepts LF line ends): rows of fields, quotes removed. Throws
// ReportError for an unterminated quote or text after a closing quote.
std::vector<std::vector<std::string>> parse_csv(std::string_view text);

}  // namespace fl::report
