// The "Camera trajectory" and "Over time" sections.
#include <fmt/format.h>

#include <map>

#include "orpe/eval/trajectory_metrics.h"
#include "orpe/report/html.h"
#include "orpe/report/report_context.h"
#include "orpe/report/run_charts.h"

namespace orpe::report {
namespace {

std::string error_stats_row(const std::string& name, const ErrorStats& e, double scale) {
  return fmt::format(
      "<tr><td>{}</td><td class=\"num\">{:.2f}</td><td class=\"num\">{:.2f}</td>"
      "<td class=\"num\">{:.2f}</td><td class=\"num\">{:.2f}</td><td class=\"num\">{}</td></tr>\n",
      html_escape(name), e.rmse * scale, e.mean * scale, e.median * scale, e.max * scale, e.count);
}

std::string trajectory_table(const TrajectoryEvaluation& ev) {
  std::string s =
      "<table><caption>Against the ground truth (rigid alignment, TUM association; "
      "docs/EVALUATION.md)</caption>\n<tr><th></th><th>RMSE</th><th>mean</th><th>median</th>"
      "<th>max</th><th>pairs</th></tr>\n";
  s += error_stats_row("ATE (mm)", ev.ate.translation_m, 1000);
  s += error_stats_row(fmt::format("RPE over {} frame (mm)", ev.rpe.delta_frames),
                       ev.rpe.translation_m, 1000);
  s += error_stats_row(fmt::format("RPE over {} frame (deg)", ev.rpe.delta_frames),
                       ev.rpe.rotation_deg, 1);
  return s + "</table>\n";
}

/// Runs of frames with the same non-OK state: "LOST 12-18 (7 frames)".
std::vector<std::vector<std::string>> state_intervals(const std::vector<FrameLogRecord>& frames) {
  std::vector<std::vector<std::string>> rows;
  for (size_t i = 0; i < frames.size();) {
    size_t j = i;
    while (j + 1 < frames.size() && frames[j + 1].status == frames[i].status) ++j;
    if (frames[i].status != "OK")
      rows.push_back({frames[i].status, std::to_string(frames[i].frame),
                      std::to_string(frames[j].frame), std::to_string(j - i + 1)});
    i = j + 1;
  }
  return rows;
}

}  // namespace

std::string trajectory_section(ReportContext& c) {
  const std::vector<StampedPose> gt =
      c.reader ? c.reader->ground_truth_trajectory() : std::vector<StampedPose>{};
  if (gt.empty()) {
    return trajectory_top_view_svg({}, c.run.trajectory, nullptr) +
           note_html("no ground-truth camera trajectory in the dataset: the estimate alone");
  }
  const TrajectoryEvaluation ev =
      evaluate_trajectory(gt, c.run.trajectory, c.config.eval_trajectory);
  if (ev.matches.empty())
    return trajectory_top_view_svg(gt, c.run.trajectory, nullptr) +
           note_html("no estimated pose is associated with a ground-truth pose (timestamps)");
  return "<div class=\"row\">" + trajectory_top_view_svg(gt, c.run.trajectory, &ev) +
         trajectory_error_svg(gt, c.run.trajectory, ev) + "</div>\n" + trajectory_table(ev);
}

std::string timeline_section(ReportContext& c) {
  const auto& f = c.run.frames;
  if (f.empty())
    return note_html(
        "the run has no frames.csv (runs made before orpe run wrote it): nothing to plot over "
        "time");
  std::string s = stage_time_svg(f) + "<div class=\"row\">" + surfel_count_svg(f) + memory_svg(f) +
                  "</div>\n" + tracking_state_svg(f);
  std::map<std::string, int> counts{{"OK", 0}, {"DEGRADED", 0}, {"LOST", 0}};
  for (const auto& r : f) ++counts[r.status];
  HtmlTable t;
  t.caption = "Tracking states (docs/SLAM.md)";
  t.header = {"state", "frames"};
  for (const auto& [state, n] : counts) t.rows.push_back({state, std::to_string(n)});
  s += t.html();
  HtmlTable runs;
  runs.caption = "Frames not tracked normally";
  runs.header = {"state", "first frame", "last frame", "frames"};
  runs.rows = state_intervals(f);
  if (!runs.rows.empty()) s += runs.html();
  return s;
}

}  // namespace orpe::report
