// CSV writing and reading (fl/report/csv.hpp).
#include "fl/report/csv.hpp"

#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <set>

namespace fl::report {
namespace {

std::string cell_text(const CsvCell& cell) {
  if (const auto* number = std::get_if<double>(&cell)) return format_double(*number);
  if (const auto* text = std::get_if<std::string>(&cell)) return csv_quote(*text);
  return {};
}

}  // namespace

std::string csv_quote(std::string_view field) {
  if (field.find_first_of(",\"\r\n") == std::string_view::npos) {
    return std::string(field);
  }
  std::string quoted = "\"";
  for (const char c : field) {
    if (c == '"') quoted += '"';  // RFC 4180: a quote inside a quoted field is doubled
    quoted += c;
  }
  quoted += '"';
  return quoted;
}

std::string format_double(double value) {
  std::array<char, 32> buffer{};
  const auto result = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
  return std::string(buffer.data(), result.ptr);
}

CsvTable::CsvTable(std::vector<std::string> columns) : columns_(std::move(columns)) {
  if (columns_.empty()) throw ReportError("csv: a table needs at least one column");
  std::set<std::string, std::less<>> seen;
  for (std::size_t c = 0; c < columns_.size(); ++c) {
    if (columns_[c].empty()) {
      throw ReportError("csv: column " + std::to_string(c) + " has an empty name");
    }
    if (!seen.insert(columns_[c]).second) {
      throw ReportError("csv: duplicate column name '" + columns_[c] + "'");
    }
  }
}

void CsvTable::add_row(std::vector<CsvCell> cells) {
  const std::size_t row = rows_.size();
  if (cells.size() != columns_.size()) {
    throw ReportError("csv: row " + std::to_string(row) + " has " + std::to_string(cells.size()) +
                      " cells, the header has " + std::to_string(columns_.size()));
  }
  for (std::size_t c = 0; c < cells.size(); ++c) {
    if (const auto* number = std::get_if<double>(&cells[c]); number && !std::isfinite(*number)) {
      throw ReportError("csv: row " + std::to_string(row) + ", column '" + columns_[c] +
                        "': value is not finite (" + format_double(*number) +
                        "); use an empty cell for a missing value");
    }
  }
  rows_.push_back(std::move(cells));
}

void CsvTable::add_columns(const std::vector<std::vector<double>>& columns) {
  if (columns.size() != columns_.size()) {
    throw ReportError("csv: got " + std::to_string(columns.size()) + " columns, the header has " +
                      std::to_string(columns_.size()));
  }
  for (std::size_t c = 1; c < columns.size(); ++c) {
    if (columns[c].size() != columns[0].size()) {
      throw ReportError("csv: column '" + columns_[c] + "' has " +
                        std::to_string(columns[c].size()) + " values, column '" + columns_[0] +
                        "' has " + std::to_string(columns[0].size()));
    }
  }
  for (std::size_t r = 0; r < columns[0].size(); ++r) {
    std::vector<CsvCell> row;
    row.reserve(columns.size());
    for (const auto& column : columns) row.emplace_back(column[r]);
    add_row(std::move(row));
  }
}

std::string CsvTable::to_string() const {
  std::string text;
  for (std::size_t c = 0; c < columns_.size(); ++c) {
    if (c > 0) text += ',';
    text += csv_quote(columns_[c]);
  }
  text += "\r\n";
  for (const auto& row : rows_) {
    for (std::size_t c = 0; c < row.size(); ++c) {
      if (c > 0) text += ',';
      text += cell_text(row[c]);
    }
    text += "\r\n";
  }
  return text;
}

void CsvTable::write(const std::filesystem::path& file) const {
  if (file.has_parent_path()) {
    std::error_code ignored;
    std::filesystem::create_directories(file.parent_path(), ignored);
  }
  std::ofstream out(file, std::ios::binary);
  const std::string text = to_string();
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
  if (!out) throw ReportError("csv: cannot write '" + file.string() + "'");
}

std::vector<std::vector<std::string>> parse_csv(std::string_view text) {
  std::vector<std::vector<std::string>> rows;
  std::vector<std::string> row;
  std::string field;
  std::size_t k = 0;
  std::size_t line = 1;
  bool row_open = false;
  while (k < text.size()) {
    row_open = true;
    if (text[k] == '"') {
      ++k;
      const std::size_t start_line = line;
      bool closed = false;
      while (k < text.size()) {
        if (text[k] == '"') {
          if (k + 1 < text.size() && text[k + 1] == '"') {
            field += '"';
            k += 2;
            continue;
          }
          ++k;
          closed = true;
          break;
        }
        if (text[k] == '\n') ++line;
        field += text[k++];
      }
      if (!closed) {
        throw ReportError("csv: unterminated quoted field starting on line " +
                          std::to_string(start_line));
      }
      if (k < text.size() && text[k] != ',' && text[k] != '\r' && text[k] != '\n') {
        throw ReportError("csv: text after a closing quote on line " + std::to_string(line));
      }
    } else {
      while (k < text.size() && text[k] != ',' && text[k] != '\r' && text[k] != '\n') {
        field += text[k++];
      }
    }
    row.push_back(std::move(field));
    field.clear();
    if (k < text.size() && text[k] == ',') {
      ++k;
      if (k == text.size()) row.emplace_back();  // trailing comma: one more empty field
      continue;
    }
    if (k < text.size() && text[k] == '\r') ++k;
    if (k < text.size() && text[k] == '\n') ++k;
    ++line;
    rows.push_back(std::move(row));
    row.clear();
    row_open = false;
  }
  if (row_open) rows.push_back(std::move(row));
  return rows;
}

}  // namespace fl::report
