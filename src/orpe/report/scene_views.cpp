#include "orpe/report/scene_views.h"

#include <fmt/format.h>

#include <algorithm>

#include "orpe/report/html.h"
#include "orpe/report/svg_plot.h"
#include "orpe/slam/map_io.h"
#include "orpe/slam/map_renderer.h"

namespace orpe::report {
namespace {

bool project(const SceneView& view, const Eigen::Vector3d& p_world, Eigen::Vector2d* uv) {
  const Vec3 p = view.T_world_cam.inverse() * p_world;
  if (p.z() < 0.05) return false;
  *uv = view.K.project(p);
  return true;
}

}  // namespace

slam::SurfelMap surfel_map_from_cloud(const PointCloudData& cloud, bool keep_instances) {
  slam::SurfelMap map;
  map.resize(cloud.size());
  for (size_t i = 0; i < cloud.size(); ++i) {
    map.position_world[i] = cloud.positions_m[i];
    map.normal_world[i] = cloud.normals.empty() ? Eigen::Vector3f(0, 0, -1) : cloud.normals[i];
    map.color[i] = cloud.colors.empty() ? Rgb8{180, 180, 180} : cloud.colors[i];
    map.radius_m[i] = cloud.radii_m.empty() ? 0.005f : cloud.radii_m[i];
    map.confidence[i] = cloud.confidences.empty() ? 1.0f : cloud.confidences[i];
    map.instance_id[i] = keep_instances && !cloud.instance_ids.empty() ? cloud.instance_ids[i] : 0;
  }
  return map;
}

void colour_by_instance(slam::SurfelMap& map) {
  for (size_t i = 0; i < map.size(); ++i) {
    if (map.instance_id[i] > 0) {
      map.color[i] = label_color(map.instance_id[i]);
      continue;
    }
    const Rgb8 c = map.color[i];
    const auto grey = static_cast<std::uint8_t>(170 + (c.r + c.g + c.b) / 12);  // 170..233
    map.color[i] = Rgb8{grey, grey, grey};
  }
}

SceneView framing_view(const slam::SurfelMap& map, const SE3& first_camera, double elevation_deg,
                       int width_px, int height_px, const std::vector<Vec3>& also_include) {
  SceneView v;
  v.K.width = width_px, v.K.height = height_px;
  v.K.fx = v.K.fy = 0.8 * width_px;
  v.K.cx = (width_px - 1) / 2.0, v.K.cy = (height_px - 1) / 2.0;
  Eigen::AlignedBox3d box = slam::map_focus_box(map, 0.0f);
  if (!box.isEmpty())
    for (const auto& p : also_include) box.extend(p);
  v.T_world_cam = box.isEmpty() ? slam::overview_pose(map, first_camera, 0.0f, 1.5, 0.6)
                                : slam::framing_pose(box, first_camera, v.K, elevation_deg);
  return v;
}

ColorImage render_scene(const slam::SurfelMap& map, const SceneView& view) {
  slam::MapRenderer renderer;
  return slam::render_map_image(renderer, map, view.T_world_cam, view.K, 0.0f);
}

std::string camera_path_svg(const std::vector<StampedPose>& trajectory, const SceneView& view) {
  std::string s, points;
  auto flush = [&] {
    if (!points.empty())
      s += fmt::format(
          "<polyline points=\"{}\" fill=\"none\" stroke=\"#1f4fd0\" stroke-width=\"2.5\" "
          "stroke-linejoin=\"round\"/>\n",
          points);
    points.clear();
  };
  Eigen::Vector2d uv;
  for (const auto& p : trajectory) {
    if (project(view, p.T_world_cam.translation(), &uv))
      points += fmt::format("{:.1f},{:.1f} ", uv.x(), uv.y());
    else
      flush();
  }
  flush();
  const std::pair<size_t, const char*> ends[] = {{0, "#20a020"},
                                                 {trajectory.size() - 1, "#d02020"}};
  for (const auto& [i, colour] : ends)
    if (!trajectory.empty() && project(view, trajectory[i].T_world_cam.translation(), &uv))
      s += fmt::format(
          "<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"5\" fill=\"{}\" stroke=\"white\"/>\n", uv.x(),
          uv.y(), colour);
  return s;
}

std::string labels_svg(const std::vector<WorldLabel>& labels, const SceneView& view) {
  std::string s;
  Eigen::Vector2d uv;
  for (const auto& l : labels) {
    if (!project(view, l.position_world, &uv)) continue;
    s += fmt::format(
        "<text x=\"{:.1f}\" y=\"{:.1f}\" text-anchor=\"middle\" font-family=\"sans-serif\" "
        "font-size=\"13\" font-weight=\"bold\" fill=\"{}\" stroke=\"white\" stroke-width=\"3\" "
        "paint-order=\"stroke\">{}</text>\n",
        uv.x(), uv.y(), css_colour(l.colour), html_escape(l.text));
  }
  return s;
}

std::string overlaid_image_html(const std::string& image_src, const std::string& svg,
                                const SceneView& view, const std::string& caption) {
  return fmt::format(
      "<figure><div class=\"overlay\"><img src=\"{0}\" alt=\"{1}\" width=\"{2}\" height=\"{3}\">"
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{2}\" height=\"{3}\" viewBox=\"0 0 {2} "
      "{3}\">\n{4}</svg></div><figcaption>{1}</figcaption></figure>\n",
      html_escape(image_src), html_escape(caption), view.K.width, view.K.height, svg);
}

}  // namespace orpe::report
