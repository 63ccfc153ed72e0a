#include "orpe/report/report.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <filesystem>
#include <set>

#include "orpe/core/atomic_file.h"
#include "orpe/core/error.h"
#include "orpe/io/image_io.h"
#include "orpe/report/html.h"
#include "orpe/report/report_context.h"
#include "orpe/report/svg_plot.h"

namespace orpe::report {
namespace fs = std::filesystem;

std::string note_html(const std::string& text) {
  return "<p class=\"note\">" + html_escape(text) + "</p>\n";
}

std::string json_number(const nlohmann::json& v, int decimals) {
  if (!v.is_number()) return "-";
  return fmt::format("{:.{}f}", v.get<double>(), decimals);
}

std::string ReportContext::save_image(const std::string& name, const ColorImage& image) {
  const std::string rel = "images/" + name;
  write_color_png((fs::path(out_dir) / rel).string(), image);
  result.images.push_back(rel);
  return rel;
}

void ReportContext::note(const std::string& text) {
  spdlog::warn("report: {}", text);
  result.notes.push_back(text);
}

std::string ReportContext::class_name(int class_id) const {
  if (reader) {
    const auto& names = reader->info().class_names;
    if (auto it = names.find(class_id); it != names.end()) return it->second;
  }
  if (run.objects.is_object())
    for (const auto& o : run.objects.value("objects", nlohmann::json::array()))
      if (o.value("class_id", -1) == class_id) return o.value("class_name", std::string());
  return std::to_string(class_id);
}

Rgb8 ReportContext::class_colour(int class_id) const {
  const auto it = class_colours.find(class_id);
  return it != class_colours.end() ? it->second : Rgb8{128, 128, 128};
}

namespace {

/// ReportContext::class_colours from every class the run or the ground truth mentions.
void assign_class_colours(ReportContext& c) {
  std::set<int> ids;
  for (const auto& r : c.run.poses) ids.insert(r.obj_id);
  for (const auto& f : c.annotations)
    for (const auto& o : f.objects_gt) ids.insert(o.class_id);
  if (c.run.objects.is_object())
    for (const auto& o : c.run.objects.value("objects", nlohmann::json::array()))
      ids.insert(o.value("class_id", 0));
  int i = 0;
  for (int id : ids) c.class_colours[id] = series_colour(i++);
}

/// Opens the run's dataset with its configuration; on failure a note, and no reader.
void open_run_dataset(ReportContext& c) {
  const std::string path = run_dataset_path(c.run, c.options.dataset);
  if (path.empty()) {
    c.note("summary.json names no dataset (give --dataset): no ground truth, no keyframe pictures");
    return;
  }
  try {
    c.reader = open_dataset(path, c.config.dataset);
    for (size_t i = 0; i < c.reader->size(); ++i)
      c.annotations.push_back(c.reader->read_annotations(i));
  } catch (const std::exception& e) {
    c.reader.reset();
    c.annotations.clear();
    c.note(
        fmt::format("the dataset could not be opened ({}); give --dataset: the sections that "
                    "need it are left out",
                    e.what()));
  }
}

std::string notes_html(const std::vector<std::string>& notes) {
  if (notes.empty()) return {};
  std::string s = "<ul>\n";
  for (const auto& n : notes) s += "<li>" + html_escape(n) + "</li>\n";
  return s + "</ul>\n";
}

}  // namespace

ReportResult write_run_report(const ReportOptions& options) {
  ReportContext c;
  c.options = options;
  c.out_dir =
      options.out_dir.empty() ? (fs::path(options.run_dir) / "report").string() : options.out_dir;
  c.run = read_run(options.run_dir);
  std::error_code ec;
  fs::create_directories(fs::path(c.out_dir) / "images", ec);
  if (ec) throw IoError(c.out_dir, "cannot create the report folder: " + ec.message());
  c.config = run_config(c.run, (fs::path(c.out_dir) / "config.json").string());
  open_run_dataset(c);
  assign_class_colours(c);
  HtmlPage page(
      fmt::format("orpe report: {}", fs::absolute(options.run_dir).lexically_normal().string()));
  // The pose scores feed the summary: sections are computed first, then laid out.
  const std::string maps = maps_section(c), trajectory = trajectory_section(c);
  const std::string poses = pose_section(c), keyframes = keyframe_section(c);
  const std::string recon = reconstruction_section(c), timeline = timeline_section(c);
  page.add_section("Summary", summary_section(c));
  page.add_section("Maps", maps);
  page.add_section("Camera trajectory", trajectory);
  page.add_section("Object poses", poses);
  page.add_section("Keyframes: models at the estimated poses", keyframes);
  page.add_section("Reconstruction error per object", recon);
  page.add_section("Over time: stages, map, memory, tracking", timeline);
  page.add_section("Provenance", provenance_section(c));
  if (!c.result.notes.empty()) page.add_section("Notes", notes_html(c.result.notes));
  c.result.index_html = (fs::path(c.out_dir) / "index.html").string();
  const std::string html = page.html();
  write_file_atomic(c.result.index_html, [&](std::ostream& os) { os << html; });
  return c.result;
}

std::string summary_section(ReportContext& c) {
  const auto v = [&](const std::string& k) { return summary_value(c.run, k); };
  HtmlTable t;
  t.header = {"", "value"};
  auto row = [&](const std::string& name, const std::string& value) {
    t.rows.push_back({html_escape(name), value});
  };
  row("mode", html_escape(c.run.mode));
  row("complete",
      v("complete").is_boolean() && !v("complete").get<bool>() ? "no (interrupted)" : "yes");
  row("frames processed / skipped",
      json_number(v("counts.frames"), 0) + " / " + json_number(v("dataset.frames_skipped"), 0));
  row("keyframes / evaluated frames",
      json_number(v("counts.keyframes"), 0) + " / " + json_number(v("counts.evaluated_frames"), 0));
  row("tracking degraded / lost frames", json_number(v("counts.tracking_degraded"), 0) + " / " +
                                             json_number(v("counts.tracking_lost"), 0));
  row("surfels", json_number(v("counts.surfels"), 0));
  row("map instances", json_number(v("counts.instances"), 0));
  row("detections", json_number(v("counts.detections"), 0));
  row("single-view estimates (valid)", json_number(v("counts.single_view_estimates"), 0) + " (" +
                                           json_number(v("counts.single_view_valid"), 0) + ")");
  row("EKF updates accepted / gated",
      json_number(v("counts.ekf_accepted"), 0) + " / " + json_number(v("counts.ekf_rejected"), 0));
  if (const nlohmann::json& ate = v("trajectory_eval.ate.translation_m.rmse"); ate.is_number())
    row("camera ATE RMSE (mm)", fmt::format("{:.1f}", ate.get<double>() * 1000));
  if (c.poses) {
    row("ADD-S AUC, all instances (poses.csv)", fmt::format("{:.1f}", c.poses->all.adds_auc));
    row("ADD(-S) AUC, all instances", fmt::format("{:.1f}", c.poses->all.add_s_auc));
  }
  row("pipeline time per frame (ms)", json_number(v("timing_ms.per_frame.pipeline"), 1));
  row("wall time (s)", v("timing_ms.total.wall").is_number()
                           ? fmt::format("{:.1f}", v("timing_ms.total.wall").get<double>() / 1000)
                           : "-");
  row("map memory (MB)", v("memory.map_bytes").is_number()
                             ? fmt::format("{:.1f}", v("memory.map_bytes").get<double>() / 1048576)
                             : "-");
  row("peak resident memory (MB)", json_number(v("memory.peak_rss_mb"), 0));
  return t.html();
}

std::string provenance_section(ReportContext& c) {
  const auto v = [&](const std::string& k) { return summary_value(c.run, k); };
  const auto text = [&](const std::string& k) {
    const nlohmann::json& j = v(k);
    return html_escape(j.is_string() ? j.get<std::string>()
                       : j.is_null() ? "(not recorded)"
                                     : j.dump());
  };
  HtmlTable t;
  t.header = {"", "value"};
  t.rows = {
      {"command", "<code>" + text("provenance.command") + "</code>"},
      {"orpe version", text("orpe_version")},
      {"dataset", text("dataset.path") + " (" + text("dataset.format") + ", scene " +
                      text("dataset.scene_id") + ", " + text("dataset.frames_selected") +
                      " frames selected)"},
      {"dataset read by this report", html_escape(c.reader ? c.reader->info().root : "(none)")},
      {"machine", text("provenance.machine.hostname") + ": " +
                      text("provenance.machine.cpu_model") + ", " +
                      text("provenance.machine.logical_cpus") + " logical CPUs, " +
                      json_number(v("provenance.machine.memory_gb"), 1) + " GB, " +
                      text("provenance.machine.os")},
      {"load average (1 min) at the end of the run",
       json_number(v("provenance.machine.load_1min_at_end"), 2)},
      {"configuration",
       "<a href=\"config.json\">config.json</a> (every parameter; <code>orpe run --config "
       "config.json</code> repeats the run)"}};
  std::string s = t.html();
  s += note_html(
      "Times are wall-clock times on that machine at that load; pose, trajectory and map "
      "figures do not depend on the load.");
  const auto cfg = c.run.summary.find("config");
  if (cfg != c.run.summary.end())
    s += "<details><summary>configuration (summary.json)</summary><pre>" +
         html_escape(cfg->dump(2)) + "</pre></details>\n";
  return s;
}

}  // namespace orpe::report
