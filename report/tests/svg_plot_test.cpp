// SVG writer: well-formed XML (checked with a small tag counter), the expected number of
// series, log axes and heat maps, and clear errors for malformed input.
#include "fl/report/svg_plot.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace fl::report {
namespace {

// Minimal XML check: every start tag is closed in order (self-closing tags count as both),
// no stray '<' or '&' in text. Returns "" when well formed, else what is wrong.
std::string xml_problem(const std::string& xml) {
  std::vector<std::string> open;
  std::size_t k = 0;
  while (k < xml.size()) {
    if (xml[k] == '&') {
      const std::size_t end = xml.find(';', k);
      if (end == std::string::npos || end - k > 6) return "bare '&' at " + std::to_string(k);
      k = end + 1;
      continue;
    }
    if (xml[k] != '<') {
      ++k;
      continue;
    }
    const std::size_t end = xml.find('>', k);
    if (end == std::string::npos) return "unclosed tag at " + std::to_string(k);
    const std::string tag = xml.substr(k + 1, end - k - 1);
    if (tag.find('<') != std::string::npos) return "'<' inside a tag at " + std::to_string(k);
    if (tag[0] == '?' || tag[0] == '!') {
    } else if (tag[0] == '/') {
      if (open.empty() || open.back() != tag.substr(1)) {
        return "mismatched </" + tag.substr(1) + ">";
      }
      open.pop_back();
    } else if (tag.back() != '/') {
      open.push_back(tag.substr(0, tag.find_first_of(" \n")));
    }
    k = end + 1;
  }
  return open.empty() ? "" : "unclosed <" + open.back() + ">";
}

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t k = text.find(what); k != std::string::npos; k = text.find(what, k + 1)) ++n;
  return n;
}

Plot two_series() {
  Plot plot;
  plot.title = "energy <settle> & more";  // must be escaped
  plot.x.label = "time (s)";
  plot.y.label = "energy (J)";
  plot.series.push_back({"kinetic", {0, 1, 2}, {1, 0.5, 0.2}, SeriesStyle::kLine, ""});
  plot.series.push_back({"bond", {0, 1, 2}, {0.1, 0.3, 0.05}, SeriesStyle::kScatter, ""});
  plot.references.push_back({false, 0.4, "thesis"});
  return plot;
}

TEST(SvgPlot, XmlEscapeCoversTheFiveEntities) {
  EXPECT_EQ(xml_escape("a<b> & \"c\" 'd'"), "a&lt;b&gt; &amp; &quot;c&quot; &apos;d&apos;");
  EXPECT_EQ(xml_escape("plain"), "plain");
}

TEST(SvgPlot, LineAndScatterPlotIsWellFormedWithOneGroupPerSeries) {
  const std::string svg = render_svg(two_series());
  EXPECT_EQ(xml_problem(svg), "");
  EXPECT_EQ(count(svg, "class=\"series\""), 2U);
  EXPECT_EQ(count(svg, "<polyline"), 1U);     // only the line series
  EXPECT_EQ(count(svg, "<circle"), 3U + 1U);  // scatter points + its legend marker
  EXPECT_NE(svg.find("energy &lt;settle&gt; &amp; more"), std::string::npos);
  EXPECT_NE(svg.find(">thesis<"), std::string::npos);  // reference line in the legend
}

TEST(SvgPlot, LogAxisHasDecadeTicks) {
  Plot plot = two_series();
  plot.y.log = true;
  const std::string svg = render_svg(plot);
  EXPECT_EQ(xml_problem(svg), "");
  EXPECT_NE(svg.find(">0.01<"), std::string::npos);
  EXPECT_NE(svg.find(">1<"), std::string::npos);
  const auto ticks = axis_ticks(1e4, 1e8, true);
  EXPECT_EQ(ticks, (std::vector<double>{1e4, 1e5, 1e6, 1e7, 1e8}));
}

TEST(SvgPlot, LinearTicksAreNiceAndCoverTheRange) {
  const auto ticks = axis_ticks(-0.3, 9.7, false);
  ASSERT_FALSE(ticks.empty());
  EXPECT_EQ(ticks.front(), 0.0);
  EXPECT_DOUBLE_EQ(ticks[1] - ticks[0], 2.0);  // 10 / 6 rounds up to a step of 2
  EXPECT_LE(ticks.back(), 9.7);
}

TEST(SvgPlot, HeatMapDrawsEveryCellAndMarksEmptyOnes) {
  HeatMap map;
  map.title = "DOE";
  map.x = {"shear stiffness (N/m^3)", true, std::nullopt, std::nullopt};
  map.y = {"normal stiffness (N/m^3)", true, std::nullopt, std::nullopt};
  map.value_label = "intact bonds (%)";
  map.x_centers = {1e4, 1e5, 1e6};
  map.y_centers = {1e5, 1e6};
  map.values = {100.0, 90.0, std::nullopt, 50.0, 0.0, 100.0};
  const std::string svg = render_svg(map);
  EXPECT_EQ(xml_problem(svg), "");
  EXPECT_EQ(count(svg, "<title>"), 1U + 6U);  // document title + one tooltip per cell
  EXPECT_EQ(count(svg, "fill=\"url(#no-value)\">"), 1U);
}

TEST(SvgPlot, RejectsMalformedInput) {
  Plot empty;
  EXPECT_THROW((void)render_svg(empty), ReportError);
  Plot plot = two_series();
  plot.series[0].y.pop_back();  // lengths differ
  try {
    (void)render_svg(plot);
    FAIL() << "mismatched lengths must throw";
  } catch (const ReportError& e) {
    EXPECT_NE(std::string(e.what()).find("3 x values but 2 y values"), std::string::npos)
        << e.what();
  }
  plot = two_series();
  plot.series[1].y[1] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW((void)render_svg(plot), ReportError);
  plot = two_series();
  plot.series[1].x.clear();
  plot.series[1].y.clear();
  EXPECT_THROW((void)render_svg(plot), ReportError);  // empty series
  plot = two_series();
  plot.x.log = true;  // x starts at 0
  EXPECT_THROW((void)render_svg(plot), ReportError);
  HeatMap map;
  map.x_centers = {1, 2};
  map.y_centers = {1};
  map.values = {1.0};  // needs 2
  EXPECT_THROW((void)render_svg(map), ReportError);
  map.values = {1.0, std::numeric_limits<double>::infinity()};
  EXPECT_THROW((void)render_svg(map), ReportError);
}

}  // namespace
}  // namespace fl::report
