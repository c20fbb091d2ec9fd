// SVG rendering (fl/report/svg_plot.hpp). Every series is one <g class="series"> so that
// tests and tools can count them; text is XML-escaped.
#include "fl/report/svg_plot.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>

namespace fl::report {
namespace {

// Colour-blind-safe palette (Okabe & Ito 2008).
constexpr std::array<const char*, 8> kPalette = {"#0072B2", "#D55E00", "#009E73", "#CC79A7",
                                                 "#E69F00", "#56B4E9", "#000000", "#F0E442"};

std::string num(double value) {  // pixel coordinates: 0.01 px is plenty
  std::array<char, 32> buffer{};
  std::snprintf(buffer.data(), buffer.size(), "%.2f", value);
  return buffer.data();
}

std::string tick_text(double value) {
  if (value == 0.0) return "0";
  std::array<char, 32> buffer{};
  const double magnitude = std::abs(value);
  if (magnitude >= 1e5 || magnitude < 1e-3) {
    std::snprintf(buffer.data(), buffer.size(), "%.3g", value);
  } else {
    std::snprintf(buffer.data(), buffer.size(), "%.6g", value);
  }
  return buffer.data();
}

void check_finite(const std::vector<double>& values, const std::string& what) {
  for (std::size_t k = 0; k < values.size(); ++k) {
    if (!std::isfinite(values[k])) {
      throw ReportError("svg: " + what + "[" + std::to_string(k) + "] is not finite");
    }
  }
}

// Data range -> axis range (padded 5% on linear axes, whole decades on log ones).
struct Scale {
  double min = 0.0;
  double max = 1.0;
  bool log = false;
  double pixel_begin = 0.0;  // where min goes
  double pixel_end = 1.0;    // where max goes
  [[nodiscard]] double t(double value) const {
    return log ? (std::log10(value) - std::log10(min)) / (std::log10(max) - std::log10(min))
               : (value - min) / (max - min);
  }
  [[nodiscard]] double px(double value) const {
    return pixel_begin + t(value) * (pixel_end - pixel_begin);
  }
};

Scale make_scale(const Axis& axis, double data_min, double data_max, const std::string& name) {
  Scale scale;
  scale.log = axis.log;
  double lo = axis.min.value_or(data_min);
  double hi = axis.max.value_or(data_max);
  if (!std::isfinite(lo) || !std::isfinite(hi)) {
    throw ReportError("svg: " + name + " axis range is not finite");
  }
  if (axis.log) {
    if (lo <= 0.0) throw ReportError("svg: " + name + " axis is log but has values <= 0");
    if (!axis.min) lo = std::pow(10.0, std::floor(std::log10(lo) + 1e-9));
    if (!axis.max) hi = std::pow(10.0, std::ceil(std::log10(hi) - 1e-9));
    if (hi <= lo) hi = lo * 10.0;
  } else {
    if (hi <= lo) {
      const double half = lo == 0.0 ? 1.0 : 0.5 * std::abs(lo);
      lo -= axis.min ? 0.0 : half;
      hi = lo + 2.0 * half;
    } else {
      const double pad = 0.05 * (hi - lo);
      if (!axis.min) lo -= pad;
      if (!axis.max) hi += pad;
    }
  }
  if (axis.min && axis.max && !(axis.max > axis.min)) {
    throw ReportError("svg: " + name + " axis max must be above min");
  }
  scale.min = lo;
  scale.max = hi;
  return scale;
}

struct Frame {
  double left = 80.0, right = 0.0, top = 50.0, bottom = 0.0;
};

void draw_axes(std::ostringstream& svg, const Frame& f, const Scale& xs, const Scale& ys,
               const Axis& xa, const Axis& ya) {
  svg << "<g class=\"axes\" font-family=\"sans-serif\" font-size=\"12\">\n";
  svg << "<rect x=\"" << num(f.left) << "\" y=\"" << num(f.top) << "\" width=\""
      << num(f.right - f.left) << "\" height=\"" << num(f.bottom - f.top)
      << "\" fill=\"none\" stroke=\"#333\"/>\n";
  for (const double v : axis_ticks(xs.min, xs.max, xs.log)) {
    const double x = xs.px(v);
    svg << "<line x1=\"" << num(x) << "\" y1=\"" << num(f.top) << "\" x2=\"" << num(x) << "\" y2=\""
        << num(f.bottom) << "\" stroke=\"#ddd\"/>";
    svg << "<line x1=\"" << num(x) << "\" y1=\"" << num(f.bottom) << "\" x2=\"" << num(x)
        << "\" y2=\"" << num(f.bottom + 5) << "\" stroke=\"#333\"/>";
    svg << "<text x=\"" << num(x) << "\" y=\"" << num(f.bottom + 18) << "\" text-anchor=\"middle\">"
        << xml_escape(tick_text(v)) << "</text>\n";
  }
  for (const double v : axis_ticks(ys.min, ys.max, ys.log)) {
    const double y = ys.px(v);
    svg << "<line x1=\"" << num(f.left) << "\" y1=\"" << num(y) << "\" x2=\"" << num(f.right)
        << "\" y2=\"" << num(y) << "\" stroke=\"#ddd\"/>";
    svg << "<line x1=\"" << num(f.left - 5) << "\" y1=\"" << num(y) << "\" x2=\"" << num(f.left)
        << "\" y2=\"" << num(y) << "\" stroke=\"#333\"/>";
    svg << "<text x=\"" << num(f.left - 8) << "\" y=\"" << num(y + 4) << "\" text-anchor=\"end\">"
        << xml_escape(tick_text(v)) << "</text>\n";
  }
  svg << "<text class=\"x-label\" x=\"" << num(0.5 * (f.left + f.right)) << "\" y=\""
      << num(f.bottom + 40) << "\" text-anchor=\"middle\" font-size=\"14\">" << xml_escape(xa.label)
      << "</text>\n";
  const double yc = 0.5 * (f.top + f.bottom);
  svg << "<text class=\"y-label\" x=\"20\" y=\"" << num(yc) << "\" transform=\"rotate(-90 20 "
      << num(yc) << ")\" text-anchor=\"middle\" font-size=\"14\">" << xml_escape(ya.label)
      << "</text>\n";
  svg << "</g>\n";
}

std::string header(int width, int height, const std::string& title) {
  std::ostringstream svg;
  svg << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << width << "\" height=\"" << height
      << "\" viewBox=\"0 0 " << width << ' ' << height << "\">\n"
      << "<title>" << xml_escape(title) << "</title>\n"
      << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
      << "<text class=\"title\" x=\"" << width / 2
      << "\" y=\"28\" text-anchor=\"middle\" font-family=\"sans-serif\" font-size=\"16\" "
         "font-weight=\"bold\">"
      << xml_escape(title) << "</text>\n";
  return svg.str();
}

void write_text(const std::string& text, const std::filesystem::path& file) {
  if (file.has_parent_path()) {
    std::error_code ignored;
    std::filesystem::create_directories(file.parent_path(), ignored);
  }
  std::ofstream out(file, std::ios::binary);
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
  if (!out) throw ReportError("svg: cannot write '" + file.string() + "'");
}

// Viridis at 5 stops, linearly interpolated: perceptually ordered, readable in grey.
std::string colormap(double t) {
  constexpr std::array<std::array<double, 3>, 5> kStops = {
      {{68, 1, 84}, {59, 82, 139}, {33, 145, 140}, {94, 201, 98}, {253, 231, 37}}};
  t = std::clamp(t, 0.0, 1.0) * 4.0;
  const auto k = std::min<std::size_t>(static_cast<std::size_t>(t), 3);
  const double f = t - static_cast<double>(k);
  std::array<char, 16> buffer{};
  std::snprintf(
      buffer.data(), buffer.size(), "#%02x%02x%02x",
      static_cast<int>(std::lround(kStops[k][0] + f * (kStops[k + 1][0] - kStops[k][0]))),
      static_cast<int>(std::lround(kStops[k][1] + f * (kStops[k + 1][1] - kStops[k][1]))),
      static_cast<int>(std::lround(kStops[k][2] + f * (kStops[k + 1][2] - kStops[k][2]))));
  return buffer.data();
}

}  // namespace

std::string xml_escape(std::string_view text) {
  std::string out;
  for (const char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&apos;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::vector<double> axis_ticks(double min, double max, bool log) {
  std::vector<double> ticks;
  if (!(max > min) || !std::isfinite(min) || !std::isfinite(max)) return ticks;
  if (log) {
    const int first = static_cast<int>(std::floor(std::log10(min) - 1e-9));
    const int last = static_cast<int>(std::ceil(std::log10(max) + 1e-9));
    const bool fine = last - first < 3;
    for (int e = first; e <= last; ++e) {
      for (const double m : fine ? std::vector<double>{1, 2, 5} : std::vector<double>{1}) {
        const double v = m * std::pow(10.0, e);
        if (v >= min * (1 - 1e-9) && v <= max * (1 + 1e-9)) ticks.push_back(v);
      }
    }
    return ticks;
  }
  const double raw = (max - min) / 6.0;  // about six intervals
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  double step = magnitude;
  for (const double m : {1.0, 2.0, 5.0, 10.0}) {
    step = m * magnitude;
    if (step >= raw) break;
  }
  const double start = std::ceil(min / step - 1e-9) * step;
  for (double v = start; v <= max + 1e-9 * step; v += step) {
    ticks.push_back(std::abs(v) < 1e-12 * step ? 0.0 : v);
  }
  return ticks;
}

std::string render_svg(const Plot& plot) {
  if (plot.series.empty()) throw ReportError("svg: plot '" + plot.title + "' has no series");
  double x_min = std::numeric_limits<double>::infinity(), x_max = -x_min;
  double y_min = x_min, y_max = -x_min;
  for (std::size_t s = 0; s < plot.series.size(); ++s) {
    const Series& series = plot.series[s];
    const std::string name = "series '" + series.label + "' (" + std::to_string(s) + ")";
    if (series.x.empty()) throw ReportError("svg: " + name + " is empty");
    if (series.x.size() != series.y.size()) {
      throw ReportError("svg: " + name + " has " + std::to_string(series.x.size()) +
                        " x values but " + std::to_string(series.y.size()) + " y values");
    }
    check_finite(series.x, name + " x");
    check_finite(series.y, name + " y");
    for (std::size_t k = 0; k < series.x.size(); ++k) {
      if (plot.x.log && series.x[k] <= 0.0) {
        throw ReportError("svg: " + name + " has x <= 0 on a log axis");
      }
      if (plot.y.log && series.y[k] <= 0.0) {
        throw ReportError("svg: " + name + " has y <= 0 on a log axis");
      }
    }
    x_min = std::min(x_min, *std::min_element(series.x.begin(), series.x.end()));
    x_max = std::max(x_max, *std::max_element(series.x.begin(), series.x.end()));
    y_min = std::min(y_min, *std::min_element(series.y.begin(), series.y.end()));
    y_max = std::max(y_max, *std::max_element(series.y.begin(), series.y.end()));
  }
  for (const ReferenceLine& line : plot.references) {
    if (!std::isfinite(line.value)) throw ReportError("svg: reference line value not finite");
    if (line.vertical) {
      x_min = std::min(x_min, line.value);
      x_max = std::max(x_max, line.value);
    } else {
      y_min = std::min(y_min, line.value);
      y_max = std::max(y_max, line.value);
    }
  }
  Frame f;
  f.right = plot.width_px - 190.0;  // legend column on the right
  f.bottom = plot.height_px - 60.0;
  Scale xs = make_scale(plot.x, x_min, x_max, "x");
  Scale ys = make_scale(plot.y, y_min, y_max, "y");
  xs.pixel_begin = f.left;
  xs.pixel_end = f.right;
  ys.pixel_begin = f.bottom;
  ys.pixel_end = f.top;

  std::ostringstream svg;
  svg << header(plot.width_px, plot.height_px, plot.title);
  draw_axes(svg, f, xs, ys, plot.x, plot.y);
  svg << "<defs><clipPath id=\"plot-area\"><rect x=\"" << num(f.left) << "\" y=\"" << num(f.top)
      << "\" width=\"" << num(f.right - f.left) << "\" height=\"" << num(f.bottom - f.top)
      << "\"/></clipPath></defs>\n";
  std::size_t legend_row = 0;
  auto legend = [&](const std::string& label, const std::string& color, bool line, bool marker,
                    bool dashed) {
    if (label.empty()) return;
    const double y = f.top + 10.0 + 20.0 * static_cast<double>(legend_row++);
    const double x = f.right + 15.0;
    if (line) {
      svg << "<line x1=\"" << num(x) << "\" y1=\"" << num(y) << "\" x2=\"" << num(x + 24)
          << "\" y2=\"" << num(y) << "\" stroke=\"" << color << "\" stroke-width=\"2\""
          << (dashed ? " stroke-dasharray=\"6 4\"" : "") << "/>";
    }
    if (marker) {
      svg << "<circle cx=\"" << num(x + 12) << "\" cy=\"" << num(y) << "\" r=\"3.5\" fill=\""
          << color << "\"/>";
    }
    svg << "<text x=\"" << num(x + 30) << "\" y=\"" << num(y + 4)
        << "\" font-family=\"sans-serif\" font-size=\"12\">" << xml_escape(label) << "</text>\n";
  };
  svg << "<g class=\"legend\">\n";
  for (std::size_t s = 0; s < plot.series.size(); ++s) {
    const Series& series = plot.series[s];
    const std::string color = series.color.empty() ? kPalette[s % kPalette.size()] : series.color;
    legend(series.label, color, series.style != SeriesStyle::kScatter,
           series.style != SeriesStyle::kLine, false);
  }
  for (const ReferenceLine& line : plot.references) legend(line.label, "#555", true, false, true);
  svg << "</g>\n";
  for (std::size_t s = 0; s < plot.series.size(); ++s) {
    const Series& series = plot.series[s];
    const std::string color = series.color.empty() ? kPalette[s % kPalette.size()] : series.color;
    svg << "<g class=\"series\" clip-path=\"url(#plot-area)\">";
    if (series.style != SeriesStyle::kScatter) {
      svg << "<polyline fill=\"none\" stroke=\"" << color << "\" stroke-width=\"1.8\" points=\"";
      for (std::size_t k = 0; k < series.x.size(); ++k) {
        svg << (k > 0 ? " " : "") << num(xs.px(series.x[k])) << ',' << num(ys.px(series.y[k]));
      }
      svg << "\"/>";
    }
    if (series.style != SeriesStyle::kLine) {
      for (std::size_t k = 0; k < series.x.size(); ++k) {
        svg << "<circle cx=\"" << num(xs.px(series.x[k])) << "\" cy=\"" << num(ys.px(series.y[k]))
            << "\" r=\"3.5\" fill=\"" << color << "\"/>";
      }
    }
    svg << "</g>\n";
  }
  for (const ReferenceLine& line : plot.references) {
    svg << "<g class=\"reference\" clip-path=\"url(#plot-area)\">";
    if (line.vertical) {
      const double x = xs.px(line.value);
      svg << "<line x1=\"" << num(x) << "\" y1=\"" << num(f.top) << "\" x2=\"" << num(x)
          << "\" y2=\"" << num(f.bottom);
    } else {
      const double y = ys.px(line.value);
      svg << "<line x1=\"" << num(f.left) << "\" y1=\"" << num(y) << "\" x2=\"" << num(f.right)
          << "\" y2=\"" << num(y);
    }
    svg << "\" stroke=\"#555\" stroke-width=\"1.5\" stroke-dasharray=\"6 4\"/></g>\n";
  }
  svg << "</svg>\n";
  return svg.str();
}

std::string render_svg(const HeatMap& map) {
  const std::size_t columns = map.x_centers.size();
  const std::size_t rows = map.y_centers.size();
  if (columns == 0 || rows == 0) throw ReportError("svg: heat map '" + map.title + "' is empty");
  if (map.values.size() != columns * rows) {
    throw ReportError("svg: heat map '" + map.title + "' has " + std::to_string(map.values.size()) +
                      " values for " + std::to_string(columns) + " x " + std::to_string(rows) +
                      " cells");
  }
  check_finite(map.x_centers, "heat map x_centers");
  check_finite(map.y_centers, "heat map y_centers");
  for (const auto* centers : {&map.x_centers, &map.y_centers}) {
    for (std::size_t k = 1; k < centers->size(); ++k) {
      if (!((*centers)[k] > (*centers)[k - 1])) {
        throw ReportError("svg: heat map centres must be strictly ascending");
      }
    }
  }
  double v_min = std::numeric_limits<double>::infinity(), v_max = -v_min;
  for (std::size_t k = 0; k < map.values.size(); ++k) {
    if (!map.values[k]) continue;
    const double v = *map.values[k];
    if (!std::isfinite(v)) {
      throw ReportError("svg: heat map value " + std::to_string(k) +
                        " is not finite; leave the cell empty (nullopt) for no value");
    }
    if (map.log_values && v <= 0.0) throw ReportError("svg: heat map log values must be > 0");
    v_min = std::min(v_min, v);
    v_max = std::max(v_max, v);
  }
  if (map.value_min) v_min = *map.value_min;
  if (map.value_max) v_max = *map.value_max;
  if (!std::isfinite(v_min)) v_min = v_max = map.log_values ? 1.0 : 0.0;  // all cells empty
  auto colour_t = [&](double v) {
    if (map.log_values) {
      const double lo = std::log10(v_min), hi = std::log10(v_max);
      return hi > lo ? (std::log10(v) - lo) / (hi - lo) : 0.5;
    }
    return v_max > v_min ? (v - v_min) / (v_max - v_min) : 0.5;
  };
  // Cell edges halfway between centres (geometric mean on a log axis).
  auto edges = [](const std::vector<double>& c, bool log) {
    std::vector<double> e(c.size() + 1);
    for (std::size_t k = 1; k < c.size(); ++k) {
      e[k] = log ? std::sqrt(c[k - 1] * c[k]) : 0.5 * (c[k - 1] + c[k]);
    }
    if (c.size() == 1) {
      e[0] = log ? c[0] / 2.0 : c[0] - 0.5;
      e[1] = log ? c[0] * 2.0 : c[0] + 0.5;
    } else {
      e[0] = log ? c[0] * c[0] / e[1] : 2.0 * c[0] - e[1];
      e.back() = log ? c.back() * c.back() / e[c.size() - 1] : 2.0 * c.back() - e[c.size() - 1];
    }
    return e;
  };
  for (const auto& [centers, axis] :
       {std::pair{&map.x_centers, &map.x}, {&map.y_centers, &map.y}}) {
    if (axis->log && (*centers)[0] <= 0.0) {
      throw ReportError("svg: heat map centres must be > 0 on a log axis");
    }
  }
  const std::vector<double> xe = edges(map.x_centers, map.x.log);
  const std::vector<double> ye = edges(map.y_centers, map.y.log);
  Frame f;
  f.right = map.width_px - 150.0;
  f.bottom = map.height_px - 60.0;
  Axis xa = map.x, ya = map.y;
  xa.min = xa.min.value_or(xe.front());
  xa.max = xa.max.value_or(xe.back());
  ya.min = ya.min.value_or(ye.front());
  ya.max = ya.max.value_or(ye.back());
  Scale xs = make_scale(xa, xe.front(), xe.back(), "x");
  Scale ys = make_scale(ya, ye.front(), ye.back(), "y");
  xs.pixel_begin = f.left;
  xs.pixel_end = f.right;
  ys.pixel_begin = f.bottom;
  ys.pixel_end = f.top;

  std::ostringstream svg;
  svg << header(map.width_px, map.height_px, map.title);
  svg << "<defs><pattern id=\"no-value\" width=\"6\" height=\"6\" patternUnits=\"userSpaceOnUse\">"
         "<rect width=\"6\" height=\"6\" fill=\"#ccc\"/><path d=\"M0,6 L6,0\" stroke=\"#888\"/>"
         "</pattern></defs>\n";
  svg << "<g class=\"cells\">\n";
  for (std::size_t r = 0; r < rows; ++r) {
    for (std::size_t c = 0; c < columns; ++c) {
      const auto& value = map.values[r * columns + c];
      const double x0 = xs.px(xe[c]), x1 = xs.px(xe[c + 1]);
      const double y0 = ys.px(ye[r + 1]), y1 = ys.px(ye[r]);
      svg << "<rect x=\"" << num(x0) << "\" y=\"" << num(y0) << "\" width=\"" << num(x1 - x0)
          << "\" height=\"" << num(y1 - y0) << "\" fill=\""
          << (value ? colormap(colour_t(*value)) : std::string("url(#no-value)")) << "\">"
          << "<title>" << xml_escape(tick_text(map.x_centers[c])) << ", "
          << xml_escape(tick_text(map.y_centers[r])) << ": "
          << (value ? xml_escape(tick_text(*value)) : std::string("no value"))
          << "</title></rect>\n";
    }
  }
  svg << "</g>\n";
  draw_axes(svg, f, xs, ys, map.x, map.y);
  // Colour bar.
  const double bx = f.right + 20.0, bw = 20.0;
  svg << "<g class=\"colorbar\" font-family=\"sans-serif\" font-size=\"12\">\n";
  constexpr int kSteps = 64;
  for (int k = 0; k < kSteps; ++k) {
    const double t0 = static_cast<double>(k) / kSteps;
    const double y = f.bottom - (f.bottom - f.top) * (t0 + 1.0 / kSteps);
    svg << "<rect x=\"" << num(bx) << "\" y=\"" << num(y) << "\" width=\"" << num(bw)
        << "\" height=\"" << num((f.bottom - f.top) / kSteps + 0.5) << "\" fill=\""
        << colormap(t0 + 0.5 / kSteps) << "\"/>";
  }
  svg << "\n";
  Scale bar;
  bar.log = map.log_values;
  bar.min = v_min;
  bar.max = v_max > v_min ? v_max : v_min + (map.log_values ? v_min : 1.0);
  bar.pixel_begin = f.bottom;
  bar.pixel_end = f.top;
  for (const double v : axis_ticks(bar.min, bar.max, bar.log)) {
    svg << "<text x=\"" << num(bx + bw + 4) << "\" y=\"" << num(bar.px(v) + 4) << "\">"
        << xml_escape(tick_text(v)) << "</text>";
  }
  svg << "\n<text x=\"" << num(bx) << "\" y=\"" << num(f.top - 10) << "\">"
      << xml_escape(map.value_label) << "</text>\n";
  svg << "<rect x=\"" << num(bx) << "\" y=\"" << num(f.bottom + 20)
      << "\" width=\"14\" height=\"14\" fill=\"url(#no-value)\"/><text x=\"" << num(bx + 18)
      << "\" y=\"" << num(f.bottom + 32) << "\">no value</text>\n";
  svg << "</g>\n</svg>\n";
  return svg.str();
}

void write_svg(const Plot& plot, const std::filesystem::path& file) {
  write_text(render_svg(plot), file);
}
void write_svg(const HeatMap& map, const std::filesystem::path& file) {
  write_text(render_svg(map), file);
}

}  // namespace fl::report
