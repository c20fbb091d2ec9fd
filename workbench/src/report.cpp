#include "fl/workbench/report.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "fl/report/svg_plot.hpp"
#include "text.hpp"

namespace fl::workbench {
namespace {

// Beyond this many noise sigmas (or this share of the signal when the noise is unknown) a
// cell is a failure, between 1 and it a doubt.
constexpr double kFailScore = 3.0;
constexpr double kFailShareNoNoise = 0.10;
constexpr std::size_t kRankedCellsShown = 15;

const char* verdict(const ErrorCell& cell) {
  const double fail = cell.noise_si > 0.0 ? kFailScore : kFailShareNoNoise;
  const double doubt = cell.noise_si > 0.0 ? 1.0 : kFailShareNoNoise / 3.0;
  if (cell.score > fail) return "fail";
  return cell.score > doubt ? "doubt" : "ok";
}

std::string score_text(const ErrorCell& cell) {
  return cell.noise_si > 0.0 ? detail::significant(cell.score, 3) + " &sigma;"
                             : detail::significant(100.0 * cell.score, 3) + " %";
}

}  // namespace

std::string report_json(const CompareReport& report) {
  nlohmann::json json;
  json["dataset"] = report.dataset;
  json["experiment"] = std::string(to_string(report.experiment));
  json["model"] = report.model;
  json["failed_trials"] = report.failed_trials;
  nlohmann::json cells = nlohmann::json::array();
  for (const ErrorCell& cell : report.cells) {
    cells.push_back({{"channel", cell.channel},
                     {"group", cell.group},
                     {"trial", cell.trial},
                     {"phase", cell.phase},
                     {"samples", cell.samples},
                     {"rmse_si", cell.rmse_si},
                     {"bias_si", cell.bias_si},
                     {"max_abs_si", cell.max_abs_si},
                     {"max_abs_at", cell.max_abs_time_s},
                     {"noise_si", cell.noise_si},
                     {"model_spread_si", cell.model_spread_si},
                     {"score", cell.score},
                     {"verdict", verdict(cell)}});
  }
  json["cells"] = cells;
  nlohmann::json traces = nlohmann::json::array();
  for (const TrialTrace& trace : report.traces) {
    nlohmann::json t{{"trial", trace.trial},
                     {"time_s", trace.time_s},
                     {"x_label", trace.x_label},
                     {"phase", trace.phase}};
    for (const ChannelTrace& c : trace.channels) {
      t["channels"][c.channel] = {{"unit", std::string(c.unit.symbol)},
                                  {"measured_si", c.measured_si},
                                  {"model_si", c.model_si}};
      if (!c.model_spread_si.empty()) {
        t["channels"][c.channel]["model_spread_si"] = c.model_spread_si;
      }
    }
    traces.push_back(t);
  }
  json["traces"] = traces;
  return json.dump(1);
}

std::string report_html(const CompareReport& report) {
  std::ostringstream html;
  html << "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>compare: "
       << report::xml_escape(report.dataset) << "</title>\n<style>"
       << "body{font-family:sans-serif;margin:2em;max-width:1100px}"
       << "table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:3px 8px;"
          "text-align:right}th{background:#eee}td.l{text-align:left}"
       << "tr.fail{background:#f8d0d0}tr.doubt{background:#fbeec8}tr.ok{background:#dff0d8}"
       << "</style></head><body>\n";
  html << "<h1>Model against measurement: " << report::xml_escape(report.dataset) << "</h1>\n";
  html << "<p>Experiment <b>" << to_string(report.experiment)
       << "</b>; model: " << report::xml_escape(report.model) << "</p>\n";
  if (!report.failed_trials.empty()) {
    html << "<p><b>Trials not run:</b></p><ul>";
    for (const std::string& failure : report.failed_trials) {
      html << "<li>" << report::xml_escape(failure);
    }
    html << "</ul>\n";
  }
  html << "<h2>Where it fails</h2>\n<p>Error per channel and group, worst first. Score: RMS "
          "error in noise sigmas where the dataset gives the noise, with the model's own spread "
          "added to the noise where it runs an ensemble (fail above "
       << kFailScore << "), else in % of the RMS signal (fail above " << 100.0 * kFailShareNoNoise
       << " %).</p>\n<table><tr><th>channel</th><th>group</th><th>samples</th><th>RMS "
          "error</th><th>bias</th><th>largest</th><th>at</th><th>score</th></tr>\n";
  std::size_t shown = 0;
  for (const ErrorCell& cell : report.cells) {
    if (shown++ == kRankedCellsShown) break;
    Unit unit{};
    for (const TrialTrace& trace : report.traces) {
      for (const ChannelTrace& c : trace.channels) {
        if (c.channel == cell.channel) unit = c.unit;
      }
    }
    const double to_unit = unit.to_si > 0.0 ? 1.0 / unit.to_si : 1.0;
    const std::string symbol(unit.symbol);
    html << "<tr class=\"" << verdict(cell) << "\"><td class=l>" << report::xml_escape(cell.channel)
         << "</td><td class=l>" << report::xml_escape(cell.group) << "</td><td>" << cell.samples
         << "</td><td>" << detail::significant(cell.rmse_si * to_unit, 3) << " " << symbol
         << "</td><td>" << detail::significant(cell.bias_si * to_unit, 3) << " " << symbol
         << "</td><td>" << detail::significant(cell.max_abs_si * to_unit, 3) << " " << symbol
         << "</td><td>" << detail::significant(cell.max_abs_time_s, 3) << "</td><td>"
         << score_text(cell) << "</td></tr>\n";
  }
  html << "</table>\n";

  for (const TrialTrace& trace : report.traces) {
    html << "<h2>Trial " << report::xml_escape(trace.trial) << "</h2>\n";
    for (const ChannelTrace& c : trace.channels) {
      const double to_unit = 1.0 / c.unit.to_si;
      std::vector<double> measured, model, residual;
      for (std::size_t k = 0; k < c.measured_si.size(); ++k) {
        measured.push_back(c.measured_si[k] * to_unit);
        model.push_back(c.model_si[k] * to_unit);
        residual.push_back((c.model_si[k] - c.measured_si[k]) * to_unit);
      }
      const std::string y_label = c.channel + " (" + std::string(c.unit.symbol) + ")";
      // Rows of several tracks interleaved in time (line tracks: every fillet at each frame)
      // are drawn as points; a line through them would zigzag from fillet to fillet.
      const bool one_track =
          std::is_sorted(trace.time_s.begin(), trace.time_s.end()) &&
          std::adjacent_find(trace.time_s.begin(), trace.time_s.end()) == trace.time_s.end();
      report::Plot overlay;
      overlay.title = trace.trial + ": " + c.channel;
      overlay.x.label = trace.x_label;
      overlay.y.label = y_label;
      overlay.series.push_back(
          {"measured", trace.time_s, measured, report::SeriesStyle::kScatter, "#444"});
      overlay.series.push_back(
          {"model", trace.time_s, model,
           one_track ? report::SeriesStyle::kLine : report::SeriesStyle::kScatter, "#d62"});
      report::Plot residuals;
      residuals.title = trace.trial + ": " + c.channel + " residual (model - measured)";
      residuals.x.label = trace.x_label;
      residuals.y.label = y_label;
      residuals.series.push_back(
          {"residual", trace.time_s, residual,
           one_track ? report::SeriesStyle::kLineAndMarkers : report::SeriesStyle::kScatter,
           "#36c"});
      if (!c.model_spread_si.empty()) {
        // An ensemble's sigma at each row, noise and spread together: where the residuals of a
        // right model would mostly lie.
        const double noise_si = report.overall(c.channel).noise_si;
        std::vector<double> low, high;
        for (std::size_t k = 0; k < residual.size(); ++k) {
          const double sigma = std::hypot(noise_si, c.model_spread_si[k]) * to_unit;
          low.push_back(-sigma);
          high.push_back(sigma);
        }
        residuals.series.push_back({"\u00b1 sigma: noise, spread", trace.time_s, high,
                                    report::SeriesStyle::kScatter, "#f9a"});
        residuals.series.push_back({"", trace.time_s, low, report::SeriesStyle::kScatter, "#f9a"});
      }
      residuals.references.push_back({false, 0.0, ""});
      // The phase changes, so a reader sees which part of the test the error belongs to. Not
      // for interleaved tracks: each fillet reaches a belt at its own time, and the cells say
      // where each one failed.
      for (std::size_t k = 1; one_track && k < trace.phase.size(); ++k) {
        if (trace.phase[k] != trace.phase[k - 1]) {
          residuals.references.push_back({true, trace.time_s[k], trace.phase[k]});
        }
      }
      try {
        html << report::render_svg(overlay) << "\n" << report::render_svg(residuals) << "\n";
      } catch (const report::ReportError& error) {
        html << "<p>plot not drawn: " << report::xml_escape(error.what()) << "</p>\n";
      }
    }
  }
  html << "</body></html>\n";
  return html.str();
}

void write_report(const CompareReport& report, const std::filesystem::path& folder) {
  std::error_code error;
  std::filesystem::create_directories(folder, error);
  const auto write = [](const std::filesystem::path& file, const std::string& text) {
    std::ofstream out(file, std::ios::binary);
    out << text;
    if (!out) throw std::runtime_error("cannot write " + file.string());
  };
  write(folder / "report.json", report_json(report));
  write(folder / "report.html", report_html(report));
}

}  // namespace fl::workbench
