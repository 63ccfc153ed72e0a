// The "Object poses", "Keyframes" and "Reconstruction error" sections.
#include <fmt/format.h>

#include <map>
#include <set>

#include "orpe/io/image_io.h"
#include "orpe/io/point_cloud_io.h"
#include "orpe/pipeline/reconstruction_error.h"
#include "orpe/report/html.h"
#include "orpe/report/pose_overlays.h"
#include "orpe/report/report_context.h"
#include "orpe/report/run_charts.h"
#include "orpe/report/svg_plot.h"

namespace orpe::report {
namespace {

std::string class_table(const PoseEvaluation& ev) {
  HtmlTable t;
  t.caption =
      "poses.csv on the evaluated frames (AUC up to 10 cm as the YCB-Video toolbox; "
      "docs/EVALUATION.md)";
  t.header = {"class",       "instances",           "estimated",      "ADD-S AUC",
              "ADD(-S) AUC", "ADD-S &lt; 2 cm (%)", "mean ADD-S (mm)"};
  auto row = [&](const PoseClassSummary& s) {
    t.rows.push_back({html_escape(s.name) + (s.symmetric ? " (symmetric)" : ""),
                      std::to_string(s.instances), std::to_string(s.estimated),
                      fmt::format("{:.1f}", s.adds_auc), fmt::format("{:.1f}", s.add_s_auc),
                      fmt::format("{:.0f}", 100 * s.adds_below),
                      s.estimated ? fmt::format("{:.1f}", 1000 * s.adds_mean_m) : "-"});
  };
  for (const auto& s : ev.classes) row(s);
  row(ev.all);
  return t.html();
}

std::string objects_table(const nlohmann::json& objects, const ReportContext& c) {
  HtmlTable t;
  t.caption = "Objects (objects.json: final poses in the map)";
  t.header = {"instance", "class", "pose", "source", "views fused", "rejected", "position (m)"};
  for (const auto& o : objects.value("objects", nlohmann::json::array())) {
    std::string pos = "-";
    if (o.contains("T_world_obj") && o["T_world_obj"].is_object()) {
      const auto& tm = o["T_world_obj"]["t_m"];
      pos = fmt::format("{:.3f} {:.3f} {:.3f}", tm[0].get<double>(), tm[1].get<double>(),
                        tm[2].get<double>());
    }
    t.rows.push_back(
        {std::to_string(o.value("instance_id", 0)),
         "<span class=\"swatch\" style=\"background:" +
             css_colour(c.class_colour(o.value("class_id", 0))) + "\"></span>" +
             html_escape(o.value("class_name", std::string())),
         o.value("valid", false) ? "yes" : "no", html_escape(o.value("source", std::string())),
         std::to_string(o.value("num_views", 0)), std::to_string(o.value("num_rejected", 0)), pos});
  }
  return t.html();
}

/// Up to `n` of the evaluated frames, evenly spread.
std::vector<int> sample_frames(const std::vector<std::pair<int, int>>& evaluated, int n) {
  std::vector<int> frames;
  const int m = static_cast<int>(evaluated.size());
  const int k = std::min(n, m);
  for (int i = 0; i < k; ++i) {
    const int idx =
        k == 1 ? 0 : static_cast<int>(std::lround(static_cast<double>(i) * (m - 1) / (k - 1)));
    if (frames.empty() || frames.back() != evaluated[idx].second)
      frames.push_back(evaluated[idx].second);
  }
  return frames;
}

std::string legend_html(const std::set<int>& classes, const ReportContext& c) {
  std::string s = "<p>";
  for (int id : classes)
    s += fmt::format("<span class=\"swatch\" style=\"background:{}\"></span>{} &nbsp; ",
                     css_colour(c.class_colour(id)), html_escape(c.class_name(id)));
  return s + "</p>\n";
}

/// The estimated and the ground-truth picture of one frame (position `pos` in the reader).
std::string keyframe_pictures(ReportContext& c, ModelMeshes& meshes, size_t pos,
                              std::set<int>& classes) {
  const RgbdFrame frame = c.reader->read(pos);
  const int scene = c.reader->info().scene_id;
  std::vector<OverlayObject> est, gt;
  for (const auto& r : c.run.poses)
    if (r.im_id == frame.index && r.scene_id == scene) {
      est.push_back({meshes.get(r.obj_id), r.T_cam_obj, c.class_colour(r.obj_id)});
      classes.insert(r.obj_id);
    }
  for (const auto& o : frame.objects_gt) {
    if (o.visible_fraction == 0) continue;
    gt.push_back({meshes.get(o.class_id), o.T_cam_obj, c.class_colour(o.class_id)});
    classes.insert(o.class_id);
  }
  std::string s = "<div class=\"row\">\n";
  const std::string base = fmt::format("frame_{:06d}", frame.index);
  const int shown_width = std::max(480, frame.color.width());  // small synthetic frames enlarged
  s += html_image(
      c.save_image(base + "_estimate.png", draw_model_overlays(frame.color, frame.intrinsics, est)),
      fmt::format("frame {}: {} estimated poses (poses.csv)", frame.index, est.size()),
      shown_width);
  if (!frame.objects_gt.empty())
    s += html_image(
        c.save_image(base + "_ground_truth.png",
                     draw_model_overlays(frame.color, frame.intrinsics, gt)),
        fmt::format("frame {}: ground truth ({} objects in view)", frame.index, gt.size()),
        shown_width);
  return s + "</div>\n";
}

}  // namespace

std::string pose_section(ReportContext& c) {
  std::string s;
  if (c.run.objects.is_object()) s += objects_table(c.run.objects, c);
  if (c.run.poses.empty())
    return s + note_html("no poses.csv (mode full writes one): no pose scores");
  if (!c.reader) return s + note_html("no dataset: the poses are not scored");
  bool has_gt = false;
  for (const auto& f : c.annotations) has_gt = has_gt || !f.objects_gt.empty();
  if (!has_gt)
    return s + note_html("the dataset has no object ground truth: the poses are not scored");
  FrameSet frames;
  for (const auto& [scene, frame] : c.run.evaluated) frames.insert({scene, frame});
  try {
    c.poses = std::make_unique<PoseEvaluation>(evaluate_pose_results(
        *c.reader, c.run.poses, c.config.eval_pose, frames.empty() ? nullptr : &frames));
  } catch (const std::exception& e) {
    c.note(fmt::format("poses.csv could not be scored: {}", e.what()));
    return s;
  }
  const double max_m = c.config.eval_pose.auc_max_distance_m;
  return s + class_table(*c.poses) + "<div class=\"row\">" +
         accuracy_curves_svg(*c.poses, false, max_m, c.class_colours) +
         accuracy_curves_svg(*c.poses, true, max_m, c.class_colours) + "</div>\n";
}

std::string keyframe_section(ReportContext& c) {
  if (!c.reader) return note_html("no dataset: no keyframe pictures");
  if (c.run.evaluated.empty())
    return note_html("the run has no evaluated frames (mode full writes poses)");
  std::map<int, size_t> position;  // frame index -> reader position
  for (size_t i = 0; i < c.annotations.size(); ++i) position[c.annotations[i].index] = i;
  ModelMeshes meshes(c.reader->info());
  std::set<int> classes;
  std::string pictures;
  for (int f : sample_frames(c.run.evaluated, c.options.max_keyframes)) {
    const auto it = position.find(f);
    if (it == position.end()) {
      c.note(fmt::format("evaluated frame {} is not in the dataset's selected frames", f));
      continue;
    }
    pictures += keyframe_pictures(c, meshes, it->second, classes);
  }
  return note_html(
             fmt::format("{} of the {} evaluated frames; each model outlined (amodal silhouette) "
                         "and its visible part tinted in its class colour:",
                         std::min<size_t>(c.run.evaluated.size(), c.options.max_keyframes),
                         c.run.evaluated.size())) +
         legend_html(classes, c) + pictures;
}

std::string reconstruction_section(ReportContext& c) {
  if (!c.reader || !c.run.has("semantic_map.ply"))
    return note_html("needs a semantic map and the dataset");
  try {
    auto objects = ground_truth_objects_in_map(*c.reader, c.run.trajectory);
    if (objects.empty()) return note_html("the dataset has no object ground truth");
    std::map<int, ModelSurface> surfaces;
    std::map<int, const ModelSurface*> ptrs;
    for (const auto& o : objects)
      if (!surfaces.count(o.class_id))
        ptrs[o.class_id] =
            &surfaces.emplace(o.class_id, load_model_surface(c.reader->info(), o.class_id))
                 .first->second;
    const ReconstructionEvaluation ev =
        evaluate_reconstruction(read_semantic_map_ply(c.run.file("semantic_map.ply")), objects,
                                ptrs, c.reader->info().class_names);
    HtmlTable t;
    t.caption =
        "Surfels of each object against its model at the ground-truth pose (orpe eval recon; "
        "completeness: run orpe eval recon)";
    t.header = {"object",      "class",    "surfels",       "mean (mm)",
                "median (mm)", "RMS (mm)", "&gt; 1 cm (%)", "&gt; 2 cm (%)"};
    for (const auto& o : ev.objects)
      t.rows.push_back({std::to_string(o.object_id), html_escape(o.name), std::to_string(o.surfels),
                        o.surfels ? fmt::format("{:.1f}", 1000 * o.mean_m) : "-",
                        o.surfels ? fmt::format("{:.1f}", 1000 * o.median_m) : "-",
                        o.surfels ? fmt::format("{:.1f}", 1000 * o.rms_m) : "-",
                        fmt::format("{:.0f}", 100 * o.far_near_fraction),
                        fmt::format("{:.0f}", 100 * o.far_fraction)});
    return t.html() +
           (ev.objects_measured
                ? note_html(fmt::format("mean over the {} objects with surfels: {:.1f} mm",
                                        ev.objects_measured, 1000 * ev.mean_m))
                : std::string());
  } catch (const std::exception& e) {
    c.note(fmt::format("reconstruction error not computed: {}", e.what()));
    return note_html("not computed (see the notes)");
  }
}

}  // namespace orpe::report
