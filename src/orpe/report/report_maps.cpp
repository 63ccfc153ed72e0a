// The "Maps" section: the surfel map and the semantic map, framed on the scene, with the camera
// path and class names drawn over them.
#include <fmt/format.h>

#include <map>

#include "orpe/io/point_cloud_io.h"
#include "orpe/pipeline/reconstruction_error.h"
#include "orpe/report/html.h"
#include "orpe/report/report_context.h"
#include "orpe/report/scene_views.h"
#include "orpe/report/svg_plot.h"

namespace orpe::report {
namespace {

/// Each instance's label at the centroid of its surfels: "class #id".
std::vector<WorldLabel> instance_labels(const PointCloudData& cloud, const ReportContext& c) {
  std::map<int, std::pair<Vec3, int>> sums;  // instance -> (sum, count)
  std::map<int, int> classes;
  for (size_t i = 0; i < cloud.size(); ++i) {
    const int id = cloud.instance_ids[i];
    if (id <= 0) continue;
    auto& [sum, n] = sums[id];
    if (n == 0) sum.setZero();
    sum += cloud.positions_m[i].cast<double>();
    ++n;
    if (!cloud.class_ids.empty()) classes[id] = cloud.class_ids[i];
  }
  std::vector<WorldLabel> labels;
  for (const auto& [id, sn] : sums)
    labels.push_back(
        {sn.first / sn.second,
         fmt::format("{} #{}", classes.count(id) ? c.class_name(classes[id]) : "?", id),
         label_color(id)});
  return labels;
}

/// Two views of one map (from the first camera's side and from higher up), with the path drawn.
std::string map_views(ReportContext& c, const slam::SurfelMap& map, const std::string& name,
                      const std::string& what, const std::vector<WorldLabel>& labels,
                      bool include_path) {
  const SE3 first = c.run.trajectory.front().T_world_cam;
  std::vector<Vec3> cameras;
  if (include_path)
    for (const auto& p : c.run.trajectory) cameras.push_back(p.T_world_cam.translation());
  std::string s = "<div class=\"row\">\n";
  const std::pair<double, const char*> views[] = {{25, "side"}, {65, "high"}};
  for (const auto& [elevation, tag] : views) {
    // The high view also holds the camera path; the side view is the closest view of the map.
    const SceneView view =
        framing_view(map, first, elevation, c.options.view_width_px, c.options.view_height_px,
                     elevation > 45 ? cameras : std::vector<Vec3>{});
    const std::string src =
        c.save_image(fmt::format("{}_{}.png", name, tag), render_scene(map, view));
    std::string svg = camera_path_svg(c.run.trajectory, view);
    svg += labels_svg(labels, view);
    s += overlaid_image_html(
        src, svg, view,
        fmt::format("{} seen from {} ({} deg above the first camera's view "
                    "direction{}); camera path in blue, start green, end red",
                    what, tag == std::string("side") ? "the first camera's side" : "higher up",
                    elevation,
                    include_path && elevation > 45 ? ", framing the camera path too" : ""));
  }
  return s + "</div>\n";
}

}  // namespace

std::string maps_section(ReportContext& c) {
  std::string s;
  if (!c.run.has("map.ply")) return note_html("the run has no map.ply");
  const PointCloudData cloud = read_point_cloud_ply(c.run.file("map.ply"));
  if (cloud.size() == 0) return note_html("map.ply holds no surfel");
  s += map_views(c, surfel_map_from_cloud(cloud, false), "map", "Surfel map (map.ply)", {}, true);
  if (!c.run.has("semantic_map.ply")) return s + note_html("no semantic map (mode slam)");
  const PointCloudData sem = read_semantic_map_ply(c.run.file("semantic_map.ply"));
  slam::SurfelMap smap = surfel_map_from_cloud(sem, true);
  colour_by_instance(smap);
  s += map_views(c, smap, "semantic",
                 "Semantic map (semantic_map.ply), each instance in its own colour, framed on the "
                 "objects",
                 instance_labels(sem, c), false);
  return s;
}

}  // namespace orpe::report
