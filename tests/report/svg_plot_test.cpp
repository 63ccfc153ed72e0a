// The SVG charts and the HTML blocks of `orpe report`.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "orpe/report/html.h"
#include "orpe/report/svg_plot.h"

namespace orpe::report {
namespace {

size_t count(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t p = text.find(what); p != std::string::npos; p = text.find(what, p + 1)) ++n;
  return n;
}

TEST(SvgPlot, NiceTicksAreRoundStepsCoveringTheRange) {
  const auto unit = nice_ticks(0, 1, 5);
  ASSERT_EQ(unit.size(), 6u);
  for (size_t i = 0; i < unit.size(); ++i) EXPECT_NEAR(unit[i], 0.2 * i, 1e-12);
  const auto t = nice_ticks(-3.3, 47, 6);
  ASSERT_GE(t.size(), 2u);
  EXPECT_DOUBLE_EQ(t[1] - t[0], 10);
  EXPECT_DOUBLE_EQ(t.front(), 0);
  EXPECT_DOUBLE_EQ(t.back(), 40);
  EXPECT_EQ(nice_ticks(2, 2).size(), 1u) << "an empty range has one tick";
}

TEST(SvgPlot, ANanBreaksALineAndPointsAreCircles) {
  PlotSeries line{"a", {0, 1, 2, 3, 4}, {0, 1, std::nan(""), 3, 4}};
  PlotSeries points{"b", {0, 1, 2}, {1, 2, 3}};
  points.style = SeriesStyle::kPoints;
  const std::string svg = svg_plot({line, points}, PlotOptions{});
  EXPECT_EQ(count(svg, "<polyline"), 2u) << "the NaN splits the line in two";
  EXPECT_EQ(count(svg, "<circle"), 3u);
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  EXPECT_NE(svg.find(">a</text>"), std::string::npos) << "legend";
}

TEST(SvgPlot, AStepSeriesGoesAcrossBeforeItGoesUp) {
  PlotSeries s{"", {0, 1}, {0, 1}};
  s.style = SeriesStyle::kStep;
  PlotOptions o;
  o.x_min = 0, o.x_max = 1, o.y_min = 0, o.y_max = 1;
  const std::string svg = svg_plot({s}, o);
  const size_t at = svg.find("points=\"");
  ASSERT_NE(at, std::string::npos) << svg;
  std::vector<double> v;
  std::string pts = svg.substr(at + 8, svg.find('"', at + 8) - at - 8);
  for (char& c : pts)
    if (c == ',') c = ' ';
  std::stringstream ss(pts);
  for (double x; ss >> x;) v.push_back(x);
  ASSERT_EQ(v.size(), 6u) << pts;  // (x0, y0) (x1, y0) (x1, y1)
  EXPECT_DOUBLE_EQ(v[1], v[3]);
  EXPECT_DOUBLE_EQ(v[2], v[4]);
  EXPECT_LT(v[5], v[3]) << "y grows upwards on screen";
}

TEST(SvgPlot, EqualAspectGivesOneScaleOnBothAxes) {
  // A 2 x 1 m box in a square-ish chart: with equal aspect a metre is as long on both axes.
  PlotSeries s{"", {0, 2, 2, 0, 0}, {0, 0, 1, 1, 0}};
  PlotOptions o;
  o.equal_aspect = true;
  o.width_px = 400, o.height_px = 400;
  const std::string svg = svg_plot({s}, o);
  const size_t at = svg.find("points=\"");
  ASSERT_NE(at, std::string::npos) << svg;
  std::string pts = svg.substr(at + 8, svg.find('"', at + 8) - at - 8);
  for (char& c : pts)
    if (c == ',') c = ' ';
  std::stringstream ss(pts);
  std::vector<double> v;
  for (double x; ss >> x;) v.push_back(x);
  ASSERT_EQ(v.size(), 10u);
  const double w = std::abs(v[2] - v[0]), h = std::abs(v[5] - v[3]);
  EXPECT_NEAR(w / h, 2.0, 0.02);
}

TEST(SvgPlot, TextIsEscapedAndEmptyChartsSaySo) {
  PlotOptions o;
  o.title = "a < b & c";
  const std::string svg = svg_plot({PlotSeries{"x\"y", {}, {}}}, o);
  EXPECT_NE(svg.find("a &lt; b &amp; c"), std::string::npos);
  EXPECT_NE(svg.find("x&quot;y"), std::string::npos);
  EXPECT_NE(svg.find("no data"), std::string::npos);
}

TEST(Html, TablesEscapeCaptionsAndAlignNumbers) {
  HtmlTable t;
  t.caption = "<b>";
  t.header = {"name", "value"};
  t.rows = {{"mug", "12.5"}};
  const std::string html = t.html();
  EXPECT_NE(html.find("&lt;b&gt;"), std::string::npos);
  EXPECT_NE(html.find("<td class=\"num\">12.5</td>"), std::string::npos);
  EXPECT_NE(html.find("<td>mug</td>"), std::string::npos);
  HtmlPage page("t");
  page.add_section("One", "<p>x</p>");
  const std::string doc = page.html();
  EXPECT_EQ(doc.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_NE(doc.find("<a href=\"#s1\">One</a>"), std::string::npos);
  EXPECT_EQ(doc.find("<script"), std::string::npos);
}

}  // namespace
}  // namespace orpe::report
