#include "orpe/report/run_charts.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <utility>

#include "orpe/report/svg_plot.h"

namespace orpe::report {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
const char* const kAxisNames[] = {"x", "y", "z"};

/// The two axes (of 0, 1, 2) along which `points` spread most, in axis order.
std::array<int, 2> widest_axes(const std::vector<Vec3>& points) {
  Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
  for (const auto& p : points) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  const Vec3 span = points.empty() ? Vec3(1, 0, 1) : Vec3(hi - lo);
  int narrow = 0;
  for (int a = 1; a < 3; ++a)
    if (span[a] < span[narrow]) narrow = a;
  std::array<int, 2> axes{};
  for (int a = 0, k = 0; a < 3; ++a)
    if (a != narrow) axes[k++] = a;
  return axes;
}

PlotSeries path_series(const std::vector<Vec3>& points, const std::array<int, 2>& axes,
                       std::string name, Rgb8 colour, bool dashed) {
  PlotSeries s;
  s.name = std::move(name);
  s.colour = colour;
  s.dashed = dashed;
  for (const auto& p : points) s.x.push_back(p[axes[0]]), s.y.push_back(p[axes[1]]);
  return s;
}

/// One series per selected field of the frame records, x = frame number.
PlotSeries frame_series(const std::vector<FrameLogRecord>& frames, std::string name, int colour,
                        const std::function<double(const FrameLogRecord&)>& field) {
  PlotSeries s;
  s.name = std::move(name);
  s.colour = series_colour(colour);
  for (const auto& f : frames) s.x.push_back(f.frame), s.y.push_back(field(f));
  return s;
}

/// Options of a chart over the frames: x = frame number, y from 0.
PlotOptions over_frames(std::string title, std::string y_label, int width_px) {
  PlotOptions o;
  o.title = std::move(title);
  o.x_label = "frame";
  o.y_label = std::move(y_label);
  o.y_min = 0;
  o.width_px = width_px;
  return o;
}

}  // namespace

std::string trajectory_top_view_svg(const std::vector<StampedPose>& gt,
                                    const std::vector<StampedPose>& est,
                                    const TrajectoryEvaluation* ev) {
  std::vector<Vec3> g, e;
  for (const auto& p : gt) g.push_back(p.T_world_cam.translation());
  for (const auto& p : est)
    e.push_back(ev ? ev->ate.alignment.apply(p.T_world_cam.translation())
                   : Vec3(p.T_world_cam.translation()));
  const auto axes = widest_axes(g.empty() ? e : g);
  // The ground truth last, dashed, so that it stays visible where the estimate lies on it.
  std::vector<PlotSeries> series;
  series.push_back(
      path_series(e, axes, ev ? "estimate (aligned)" : "estimate", series_colour(0), false));
  if (!g.empty()) series.push_back(path_series(g, axes, "ground truth", {40, 40, 40}, true));
  PlotOptions o;
  o.title = "Camera path, top view";
  o.x_label = fmt::format("{} (m)", kAxisNames[axes[0]]);
  o.y_label = fmt::format("{} (m)", kAxisNames[axes[1]]);
  o.equal_aspect = true;
  o.width_px = 520, o.height_px = 420;
  return svg_plot(series, o);
}

std::string trajectory_error_svg(const std::vector<StampedPose>& gt,
                                 const std::vector<StampedPose>& est,
                                 const TrajectoryEvaluation& ev) {
  std::vector<PlotSeries> series(4);
  for (int a = 0; a < 4; ++a) {
    series[a].name = a < 3 ? std::string("error ") + kAxisNames[a] : "|error|";
    series[a].colour = a < 3 ? series_colour(a) : Rgb8{0, 0, 0};
  }
  const double t0 = ev.matches.empty() ? 0 : gt[ev.matches.front().gt_index].timestamp_s;
  for (const auto& m : ev.matches) {
    const Vec3 d = ev.ate.alignment.apply(est[m.est_index].T_world_cam.translation()) -
                   gt[m.gt_index].T_world_cam.translation();
    const double t = gt[m.gt_index].timestamp_s - t0;
    for (int a = 0; a < 4; ++a)
      series[a].x.push_back(t), series[a].y.push_back(a < 3 ? d[a] : d.norm());
  }
  PlotOptions o;
  o.title = "Camera position error per axis (aligned estimate - ground truth)";
  o.x_label = "time (s)";
  o.y_label = "error (m)";
  return svg_plot(series, o);
}

std::string accuracy_curves_svg(const PoseEvaluation& ev, bool add_or_adds, double max_m,
                                const std::map<int, Rgb8>& colours) {
  std::vector<PlotSeries> series;
  auto curve = [&](int class_id, const std::string& name, Rgb8 colour) {
    std::vector<double> d;
    for (const auto& s : ev.instances)
      if (class_id < 0 || s.class_id == class_id)
        d.push_back(!s.estimated ? kNaN : add_or_adds ? s.add_or_adds_m() : s.adds_m);
    PlotSeries p;
    p.name = name;
    p.colour = colour;
    p.style = SeriesStyle::kStep;
    for (int k = 0; k <= 200; ++k) {
      const double th = max_m * k / 200.0;
      p.x.push_back(th * 100), p.y.push_back(100.0 * fraction_below(d, th));
    }
    series.push_back(p);
  };
  for (const auto& cls : ev.classes) {
    const auto it = colours.find(cls.class_id);
    curve(cls.class_id, cls.name, it != colours.end() ? it->second : Rgb8{128, 128, 128});
  }
  curve(-1, "ALL", {0, 0, 0});
  series.back().width_px = 2.6;
  PlotOptions o;
  o.title = add_or_adds ? "ADD(-S) accuracy-threshold curve" : "ADD-S accuracy-threshold curve";
  o.x_label = "threshold (cm)";
  o.y_label = "instances below (%)";
  o.x_min = 0, o.x_max = max_m * 100, o.y_min = 0, o.y_max = 100;
  o.width_px = 520, o.height_px = 380;
  return svg_plot(series, o);
}

std::string stage_time_svg(const std::vector<FrameLogRecord>& frames) {
  using R = FrameLogRecord;
  std::vector<PlotSeries> s = {
      frame_series(frames, "read", 7, [](const R& f) { return f.read_ms; }),
      frame_series(frames, "slam", 0, [](const R& f) { return f.slam_ms; }),
      frame_series(frames, "semantic", 1, [](const R& f) { return f.semantic_ms; }),
      frame_series(frames, "render views", 2, [](const R& f) { return f.render_ms; }),
      frame_series(frames, "single view", 3, [](const R& f) { return f.single_view_ms; }),
      frame_series(frames, "ekf", 4, [](const R& f) { return f.ekf_ms; }),
      frame_series(frames, "pipeline total", 5, [](const R& f) { return f.total_ms; })};
  return svg_plot(s, over_frames("Time per stage per frame (wall clock)", "ms", 800));
}

std::string surfel_count_svg(const std::vector<FrameLogRecord>& frames) {
  return svg_plot(
      {frame_series(frames, "", 0,
                    [](const FrameLogRecord& f) { return static_cast<double>(f.surfels); })},
      over_frames("Surfels in the map", "surfels", 520));
}

std::string memory_svg(const std::vector<FrameLogRecord>& frames) {
  return svg_plot(
      {frame_series(frames, "surfel map", 0, [](const FrameLogRecord& f) { return f.map_mb; }),
       frame_series(frames, "process resident", 3,
                    [](const FrameLogRecord& f) { return f.rss_mb; })},
      over_frames("Memory", "MB", 520));
}

std::string tracking_state_svg(const std::vector<FrameLogRecord>& frames) {
  PlotSeries s = frame_series(frames, "", 3, [](const FrameLogRecord& f) {
    return f.status == "OK" ? 0.0 : f.status == "DEGRADED" ? 1.0 : 2.0;
  });
  s.style = SeriesStyle::kStep;
  s.width_px = 2.5;
  PlotOptions o;
  o.title = "Tracking state";
  o.x_label = "frame";
  o.height_px = 170;
  o.y_min = -0.3, o.y_max = 2.3;
  o.y_ticks = {{0, "OK"}, {1, "DEGRADED"}, {2, "LOST"}};
  return svg_plot({s}, o);
}

}  // namespace orpe::report
