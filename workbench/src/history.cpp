#include "fl/workbench/history.hpp"

#include <spdlog/spdlog.h>

#include <charconv>
#include <fstream>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "csv_reader.hpp"
#include "fl/report/csv.hpp"
#include "fl/report/svg_plot.hpp"

namespace fl::workbench {
namespace {

constexpr const char* kHeader = "run_utc,dataset,channel,rmse_si,score,model,effects";
// The header before the effects column (histories written before 2026-12-06).
constexpr std::string_view kHeaderWithoutEffects = "run_utc,dataset,channel,rmse_si,score,model";

// Gives a history of the older layout the effects column, empty on its lines, so that the file
// stays one table.
void add_effects_column(const std::filesystem::path& csv) {
  std::vector<std::string> lines;
  {
    std::ifstream in(csv, std::ios::binary);
    std::string line;
    while (std::getline(in, line)) lines.push_back(line);
  }
  if (lines.empty() || lines.front() != kHeaderWithoutEffects) return;
  std::ofstream out(csv, std::ios::binary | std::ios::trunc);
  out << kHeader << '\n';
  for (std::size_t k = 1; k < lines.size(); ++k) {
    if (!lines[k].empty()) out << lines[k] << ",\n";
  }
  if (!out) throw std::runtime_error("cannot rewrite " + csv.string());
}

bool parse_number(const std::string& text, double& value) {
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  return error == std::errc{} && end == text.data() + text.size();
}

}  // namespace

void append_history(const std::filesystem::path& csv, const CompareReport& report,
                    const std::string& run_utc, const std::string& effects) {
  const bool fresh = !std::filesystem::exists(csv);
  if (!fresh) add_effects_column(csv);
  std::ofstream out(csv, std::ios::app | std::ios::binary);
  if (fresh) out << kHeader << '\n';
  for (const ErrorCell& cell : report.cells) {
    if (cell.group != "all") continue;
    // RFC 4180 as report::CsvTable writes it: the model description holds commas.
    out << report::csv_quote(run_utc) << ',' << report::csv_quote(report.dataset) << ','
        << report::csv_quote(cell.channel) << ',' << report::format_double(cell.rmse_si) << ','
        << report::format_double(cell.score) << ',' << report::csv_quote(report.model) << ','
        << report::csv_quote(effects) << '\n';
  }
  if (!out) throw std::runtime_error("cannot append to " + csv.string());
}

std::vector<HistoryEntry> read_history(const std::filesystem::path& csv) {
  std::vector<detail::CsvRow> rows;
  std::vector<detail::CsvIssue> issues;
  std::vector<HistoryEntry> history;
  if (!detail::read_csv(csv, rows, issues)) return history;
  for (const detail::CsvIssue& issue : issues) {
    spdlog::warn("{}:{}: {}, line skipped", csv.string(), issue.line, issue.message);
  }
  for (std::size_t k = 1; k < rows.size(); ++k) {
    const detail::CsvRow& row = rows[k];
    HistoryEntry entry;
    const std::size_t fields = row.fields.size();
    if ((fields != 6 && fields != 7) || !parse_number(row.fields[3], entry.rmse_si) ||
        !parse_number(row.fields[4], entry.score)) {
      spdlog::warn("{}:{}: not a history line ({}), skipped", csv.string(), row.line, kHeader);
      continue;
    }
    entry.run_utc = row.fields[0];
    entry.dataset = row.fields[1];
    entry.channel = row.fields[2];
    entry.model = row.fields[5];
    if (fields == 7) entry.effects = row.fields[6];
    history.push_back(std::move(entry));
  }
  return history;
}

void plot_history(const std::vector<HistoryEntry>& history, const std::filesystem::path& svg) {
  std::map<std::string, std::vector<double>> scores;
  for (const HistoryEntry& entry : history) scores[entry.channel].push_back(entry.score);
  report::Plot plot;
  plot.title = "Error across model iterations";
  plot.x.label = "run";
  plot.y.label = "score (noise sigmas, or share of the signal)";
  for (const auto& [channel, values] : scores) {
    report::Series series;
    series.label = channel;
    series.style = report::SeriesStyle::kLineAndMarkers;
    for (std::size_t k = 0; k < values.size(); ++k) {
      series.x.push_back(static_cast<double>(k + 1));
      series.y.push_back(values[k]);
    }
    plot.series.push_back(std::move(series));
  }
  if (!plot.series.empty()) report::write_svg(plot, svg);
}

}  // namespace fl::workbench
