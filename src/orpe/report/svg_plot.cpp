#include "orpe/report/svg_plot.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "orpe/report/html.h"

namespace orpe::report {
namespace {

constexpr double kLeft = 62, kRight = 14, kTop = 30, kBottom = 44;  // margins (px)

struct Range {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  void add(double v) {
    if (!std::isfinite(v)) return;
    lo = std::min(lo, v), hi = std::max(hi, v);
  }
  bool empty() const { return !(lo <= hi); }
  double span() const { return hi - lo; }
};

/// Data range with the fixed limits applied; an empty or zero-width range is widened.
Range axis_range(const std::vector<PlotSeries>& series, bool x_axis, std::optional<double> lo,
                 std::optional<double> hi) {
  Range r;
  for (const auto& s : series) {
    const size_t n = std::min(s.x.size(), s.y.size());
    for (size_t i = 0; i < n; ++i)
      if (std::isfinite(s.x[i]) && std::isfinite(s.y[i])) r.add(x_axis ? s.x[i] : s.y[i]);
  }
  if (r.empty()) r.lo = 0, r.hi = 1;
  if (r.span() <= 0) {
    const double pad = std::max(std::abs(r.lo) * 0.05, 1e-3);
    r.lo -= pad, r.hi += pad;
  } else if (!lo || !hi) {
    const double pad = r.span() * 0.04;
    if (!lo) r.lo -= pad;
    if (!hi) r.hi += pad;
  }
  if (lo) r.lo = *lo;
  if (hi) r.hi = *hi;
  if (r.span() <= 0) r.hi = r.lo + 1;
  return r;
}

/// Widens one range so that a unit has the same length in pixels on both axes.
void equalise(Range& x, Range& y, double plot_w, double plot_h) {
  const double sx = plot_w / x.span(), sy = plot_h / y.span();
  if (sx > sy) {
    const double extra = plot_w / sy - x.span();
    x.lo -= extra / 2, x.hi += extra / 2;
  } else {
    const double extra = plot_h / sx - y.span();
    y.lo -= extra / 2, y.hi += extra / 2;
  }
}

std::string tick_label(double v, double step) {
  const int decimals = std::clamp(static_cast<int>(-std::floor(std::log10(step) + 1e-9)), 0, 6);
  if (std::abs(v) < step * 1e-6) v = 0;
  return fmt::format("{:.{}f}", v, decimals);
}

struct Frame {
  Range x, y;
  double w, h;  // plot area size (px)
  double px(double v) const { return kLeft + (v - x.lo) / x.span() * w; }
  double py(double v) const { return kTop + (y.hi - v) / y.span() * h; }
};

std::string axes_svg(const Frame& f, const PlotOptions& o) {
  std::string s;
  const auto xt = nice_ticks(f.x.lo, f.x.hi);
  const double xstep = xt.size() > 1 ? xt[1] - xt[0] : 1;
  for (double v : xt) {
    if (v < f.x.lo - 1e-12 || v > f.x.hi + 1e-12) continue;
    s += fmt::format(
        "<line x1=\"{0:.1f}\" y1=\"{1:.1f}\" x2=\"{0:.1f}\" y2=\"{2:.1f}\" class=\"grid\"/>"
        "<text x=\"{0:.1f}\" y=\"{3:.1f}\" text-anchor=\"middle\">{4}</text>\n",
        f.px(v), kTop, kTop + f.h, kTop + f.h + 14, tick_label(v, xstep));
  }
  std::vector<std::pair<double, std::string>> yt = o.y_ticks;
  if (yt.empty()) {
    const auto v = nice_ticks(f.y.lo, f.y.hi);
    const double ystep = v.size() > 1 ? v[1] - v[0] : 1;
    for (double t : v) yt.emplace_back(t, tick_label(t, ystep));
  }
  for (const auto& [v, label] : yt) {
    if (v < f.y.lo - 1e-12 || v > f.y.hi + 1e-12) continue;
    s += fmt::format(
        "<line x1=\"{0:.1f}\" y1=\"{1:.1f}\" x2=\"{2:.1f}\" y2=\"{1:.1f}\" class=\"grid\"/>"
        "<text x=\"{3:.1f}\" y=\"{4:.1f}\" text-anchor=\"end\">{5}</text>\n",
        kLeft, f.py(v), kLeft + f.w, kLeft - 5, f.py(v) + 4, html_escape(label));
  }
  s += fmt::format(
      "<rect x=\"{}\" y=\"{}\" width=\"{:.1f}\" height=\"{:.1f}\" fill=\"none\" "
      "stroke=\"#444\"/>\n",
      kLeft, kTop, f.w, f.h);
  s += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" text-anchor=\"middle\">{}</text>\n",
                   kLeft + f.w / 2, kTop + f.h + 34, html_escape(o.x_label));
  s += fmt::format(
      "<text transform=\"translate(14 {:.1f}) rotate(-90)\" text-anchor=\"middle\">{}</text>\n",
      kTop + f.h / 2, html_escape(o.y_label));
  return s;
}

/// The series as SVG elements in plot-area pixel coordinates.
std::string series_svg(const PlotSeries& s, const Frame& f) {
  const std::string colour = css_colour(s.colour);
  const size_t n = std::min(s.x.size(), s.y.size());
  std::string out;
  if (s.style == SeriesStyle::kPoints) {
    for (size_t i = 0; i < n; ++i)
      if (std::isfinite(s.x[i]) && std::isfinite(s.y[i]))
        out += fmt::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"{:.1f}\" fill=\"{}\"/>",
                           f.px(s.x[i]) - kLeft, f.py(s.y[i]) - kTop, s.width_px, colour);
    return out + "\n";
  }
  std::string points;
  auto flush = [&] {
    if (!points.empty())
      out += fmt::format(
          "<polyline points=\"{}\" fill=\"none\" stroke=\"{}\" stroke-width=\"{}\"{} "
          "stroke-linejoin=\"round\"/>\n",
          points, colour, s.width_px, s.dashed ? " stroke-dasharray=\"6 4\"" : "");
    points.clear();
  };
  double previous_y = 0;
  for (size_t i = 0; i < n; ++i) {
    if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) {
      flush();
      continue;
    }
    const double X = f.px(s.x[i]) - kLeft, Y = f.py(s.y[i]) - kTop;
    if (s.style == SeriesStyle::kStep && !points.empty())
      points += fmt::format("{:.1f},{:.1f} ", X, previous_y);  // across at the old value first
    points += fmt::format("{:.1f},{:.1f} ", X, Y);
    previous_y = Y;
  }
  flush();
  return out;
}

std::vector<const PlotSeries*> named_series(const std::vector<PlotSeries>& series) {
  std::vector<const PlotSeries*> named;
  for (const auto& s : series)
    if (!s.name.empty()) named.push_back(&s);
  return named;
}

/// Width of the legend box (px), 0 without named series.
double legend_width(const std::vector<PlotSeries>& series) {
  size_t longest = 0;
  const auto named = named_series(series);
  for (const auto* s : named) longest = std::max(longest, s->name.size());
  return named.empty() ? 0 : 32 + 6.8 * static_cast<double>(longest);
}

/// The legend, right of the plot area (so that it never hides data).
std::string legend_svg(const std::vector<PlotSeries>& series, const Frame& f) {
  const auto named = named_series(series);
  if (named.empty()) return {};
  const double w = legend_width(series), h = 16.0 * named.size() + 6;
  const double x0 = kLeft + f.w + 8, y0 = kTop;
  std::string out = fmt::format(
      "<rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"{:.1f}\" height=\"{:.1f}\" fill=\"white\" "
      "stroke=\"#bbb\"/>\n",
      x0, y0, w, h);
  for (size_t i = 0; i < named.size(); ++i) {
    const double y = y0 + 14 + 16.0 * i;
    out += fmt::format(
        "<line x1=\"{:.1f}\" y1=\"{:.1f}\" x2=\"{:.1f}\" y2=\"{:.1f}\" stroke=\"{}\" "
        "stroke-width=\"3\"{}/><text x=\"{:.1f}\" y=\"{:.1f}\">{}</text>\n",
        x0 + 5, y - 4, x0 + 22, y - 4, css_colour(named[i]->colour),
        named[i]->dashed ? " stroke-dasharray=\"5 3\"" : "", x0 + 26, y,
        html_escape(named[i]->name));
  }
  return out;
}

bool has_finite_point(const std::vector<PlotSeries>& series) {
  for (const auto& s : series)
    for (size_t i = 0; i < std::min(s.x.size(), s.y.size()); ++i)
      if (std::isfinite(s.x[i]) && std::isfinite(s.y[i])) return true;
  return false;
}

}  // namespace

std::vector<double> nice_ticks(double lo, double hi, int count) {
  if (!(hi > lo) || !std::isfinite(lo) || !std::isfinite(hi) || count < 1) return {lo};
  const double raw = (hi - lo) / count;
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  double step = mag;
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * mag >= raw) {
      step = m * mag;
      break;
    }
  std::vector<double> ticks;
  const double first = std::ceil(lo / step - 1e-9);
  for (double k = first; k * step <= hi + step * 1e-9; k += 1)
    ticks.push_back(k == 0 ? 0.0 : k * step);
  return ticks;
}

Rgb8 series_colour(int i) {
  static const Rgb8 kPalette[] = {{31, 119, 180},  {255, 127, 14}, {44, 160, 44},   {214, 39, 40},
                                  {148, 103, 189}, {140, 86, 75},  {227, 119, 194}, {127, 127, 127},
                                  {188, 189, 34},  {23, 190, 207}};
  return kPalette[((i % 10) + 10) % 10];
}

std::string css_colour(Rgb8 c) {
  return fmt::format("#{:02x}{:02x}{:02x}", c.r, c.g, c.b);
}

std::string svg_plot(const std::vector<PlotSeries>& series, const PlotOptions& o) {
  Frame f;
  const double legend = legend_width(series);
  f.w = std::max(40.0, o.width_px - kLeft - kRight - (legend > 0 ? legend + 8 : 0));
  f.h = std::max(40.0, o.height_px - kTop - kBottom);
  f.x = axis_range(series, true, o.x_min, o.x_max);
  f.y = axis_range(series, false, o.y_min, o.y_max);
  if (o.equal_aspect) equalise(f.x, f.y, f.w, f.h);
  std::string s = fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" class=\"plot\" width=\"{0}\" height=\"{1}\" "
      "viewBox=\"0 0 {0} {1}\" font-family=\"sans-serif\" font-size=\"11\">\n"
      "<style>.grid{{stroke:#e4e4e4;stroke-width:1}}</style>\n"
      "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
      "<text x=\"{2:.1f}\" y=\"18\" text-anchor=\"middle\" font-size=\"13\" "
      "font-weight=\"bold\">{3}</text>\n",
      o.width_px, o.height_px, kLeft + f.w / 2, html_escape(o.title));
  s += axes_svg(f, o);
  // A nested <svg> clips the series to the plot area (no clipPath ids to keep unique on a page).
  s += fmt::format("<svg x=\"{}\" y=\"{}\" width=\"{:.1f}\" height=\"{:.1f}\">\n", kLeft, kTop, f.w,
                   f.h);
  for (const auto& ser : series) s += series_svg(ser, f);
  if (!has_finite_point(series))
    s += fmt::format(
        "<text x=\"{:.1f}\" y=\"{:.1f}\" text-anchor=\"middle\" fill=\"#888\">no data</text>\n",
        f.w / 2, f.h / 2);
  s += "</svg>\n";
  s += legend_svg(series, f);
  return s + "</svg>\n";
}

}  // namespace orpe::report
