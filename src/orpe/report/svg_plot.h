// Charts as SVG text, written from C++ for `orpe report` (docs/REPORT.md): line, step and point
// series on linear axes with "nice" ticks, a legend, optional equal aspect (trajectory top views)
// and named y ticks (tracking states). The SVG is inlined in the HTML page, so a report needs no
// plotting library, no script and no network to be drawn, and the figures are exactly the numbers
// the report's tables hold.
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "orpe/core/image.h"

namespace orpe::report {

enum class SeriesStyle { kLine, kStep, kPoints };

/// One series. A NaN y (or x) breaks a line into separate pieces.
struct PlotSeries {
  std::string name;  ///< legend entry; empty = not in the legend
  std::vector<double> x, y;
  Rgb8 colour{31, 119, 180};
  SeriesStyle style = SeriesStyle::kLine;
  bool dashed = false;
  double width_px = 1.6;  ///< line width, or point radius for kPoints
};

struct PlotOptions {
  std::string title;
  std::string x_label, y_label;
  int width_px = 640, height_px = 340;
  bool equal_aspect = false;  ///< one unit on x is as long as one on y (maps, top views)
  std::optional<double> x_min, x_max, y_min, y_max;  ///< fixed limits; else from the data
  /// Replaces the numeric y ticks by these (value, label) pairs, e.g. {0, "OK"}, {2, "LOST"}.
  std::vector<std::pair<double, std::string>> y_ticks;
};

/// The chart as an <svg> element (no XML prolog), width_px x height_px. Series without points are
/// listed in the legend only. A chart with no finite point says so in its plot area.
std::string svg_plot(const std::vector<PlotSeries>& series, const PlotOptions& options);

/// About `count` round tick values covering [lo, hi] (steps of 1, 2 or 5 x 10^k).
std::vector<double> nice_ticks(double lo, double hi, int count = 6);

/// A colour of a fixed qualitative palette (10 entries, repeating), for series i.
Rgb8 series_colour(int i);

/// "#rrggbb".
std::string css_colour(Rgb8 c);

}  // namespace orpe::report
