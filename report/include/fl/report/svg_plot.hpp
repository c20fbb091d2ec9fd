// SVG plots a person opens in a browser: line and scatter series on linear or log axes with
// ticks, labels, legend and title; reference lines (e.g. a value from the literature); and a
// heat map for 2D grids (e.g. a design of experiments over two stiffnesses). No dependency.
//
//   fl::report::Plot plot;
//   plot.title = "Settle test";
//   plot.x.label = "time (s)";
//   plot.y = {.label = "energy (J)", .log = true};
//   plot.series.push_back({.label = "kinetic", .x = t, .y = e});
//   fl::report::write_svg(plot, "out/settle.svg");
//
// Malformed input throws fl::report::ReportError saying what is wrong: NaN or infinite
// values, an empty series, x and y of different lengths, values <= 0 on a log axis, a heat map
// whose value count is not columns x rows.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "fl/report/csv.hpp"  // ReportError

namespace fl::report {

struct Axis {
  std::string label;          // with unit: "time (s)"
  bool log = false;           // base-10; every value must be > 0
  std::optional<double> min;  // default: the data's range, padded
  std::optional<double> max;
};

enum class SeriesStyle { kLine, kScatter, kLineAndMarkers };

struct Series {
  std::string label;  // legend entry; empty: not in the legend
  std::vector<double> x;
  std::vector<double> y;
  SeriesStyle style = SeriesStyle::kLine;
  std::string color;  // CSS colour; empty: the palette's next one
};

// A horizontal (constant y) or vertical (constant x) dashed line with a label.
struct ReferenceLine {
  bool vertical = false;
  double value = 0.0;
  std::string label;
};

struct Plot {
  std::string title;
  Axis x;
  Axis y;
  std::vector<Series> series;
  std::vector<ReferenceLine> references;
  int width_px = 800;
  int height_px = 500;
};

// Cells on a grid of column centres x rows centres (ascending), values row-major
// (values[row * columns + column]); an empty cell (nullopt) is drawn hatched grey as
// "no value" (e.g. an unstable run). Axes may be log (centres > 0).
struct HeatMap {
  std::string title;
  Axis x;
  Axis y;
  std::string value_label;  // colour bar title, with unit
  std::vector<double> x_centers;
  std::vector<double> y_centers;
  std::vector<std::optional<double>> values;
  bool log_values = false;  // colour by log10(value); values must be > 0
  std::optional<double> value_min;
  std::optional<double> value_max;
  int width_px = 800;
  int height_px = 560;
};

[[nodiscard]] std::string render_svg(const Plot& plot);
[[nodiscard]] std::string render_svg(const HeatMap& map);
// Create parent folders; throw ReportError when the file cannot be written.
void write_svg(const Plot& plot, const std::filesystem::path& file);
void write_svg(const HeatMap& map, const std::filesystem::path& file);

// Text safe inside XML or HTML elements and quoted attributes: & < > " ' as entities.
[[nodiscard]] std::string xml_escape(std::string_view text);

// "Nice" tick positions (1, 2, 5 x 10^k steps) covering [min, max]; for a log axis the
// decades (and 2, 5 within them when fewer than three decades are shown).
std::vector<double> axis_ticks(double min, double max, bool log);

}  // namespace fl::report
