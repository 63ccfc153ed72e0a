#include "orpe/semantic/instance_render.h"

#include <algorithm>
#include <cmath>

namespace orpe {
namespace {

/// Copies a window-sized image into the full-size one at (u0, v0).
template <class T>
void paste(const Image<T>& window, int u0, int v0, Image<T>& full) {
  for (int v = 0; v < window.height(); ++v)
    std::copy_n(&window.at(0, v), window.width(), &full.at(u0, v0 + v));
}

}  // namespace

std::array<int, 4> InstanceRenderer::gather_labelled(const slam::SurfelMap& map,
                                                     const SE3& T_world_cam,
                                                     const PinholeIntrinsics& K,
                                                     float max_splat_radius_px,
                                                     float splat_radius_scale) {
  // Gather the labelled surfels (only the arrays the renderer reads; the others stay default).
  selected_.clear();
  for (size_t i = 0; i < map.size(); ++i)
    if (map.instance_id[i] > 0) selected_.push_back(static_cast<std::uint32_t>(i));
  labelled_.resize(selected_.size());
  const long n = static_cast<long>(selected_.size());
  const SE3 T_cam_world = T_world_cam.inverse();
  const Eigen::Matrix3f R = T_cam_world.rotation().cast<float>();
  const Eigen::Vector3f t = T_cam_world.translation().cast<float>();
  const float fx = static_cast<float>(K.fx), fy = static_cast<float>(K.fy);
  const float cx = static_cast<float>(K.cx), cy = static_cast<float>(K.cy);
  const float f_max = std::max(fx, fy);
  int u0 = K.width, v0 = K.height, u1 = -1, v1 = -1;
#pragma omp parallel for schedule(static) reduction(min : u0, v0) reduction(max : u1, v1)
  for (long k = 0; k < n; ++k) {
    const std::uint32_t i = selected_[k];
    labelled_.position_world[k] = map.position_world[i];
    labelled_.normal_world[k] = map.normal_world[i];
    labelled_.color[k] = map.color[i];
    labelled_.radius_m[k] = map.radius_m[i];
    labelled_.confidence[k] = map.confidence[i];
    labelled_.last_seen_time[k] = map.last_seen_time[i];
    labelled_.always_active[k] = map.always_active[i];
    labelled_.instance_id[k] = map.instance_id[i];
    // The splat's pixel footprint, as the renderer bounds it (conservatively: one pixel more).
    const Eigen::Vector3f p = R * map.position_world[i] + t;
    if (!(p.z() > 1e-3f)) continue;
    const float u = fx * p.x() / p.z() + cx, v = fy * p.y() / p.z() + cy;
    const float r =
        std::min(map.radius_m[i] * splat_radius_scale * f_max / p.z(), max_splat_radius_px) + 1.0f;
    if (!std::isfinite(u) || !std::isfinite(v)) continue;
    u0 = std::min(u0, static_cast<int>(std::floor(std::max(u - r, -1.0f))));
    v0 = std::min(v0, static_cast<int>(std::floor(std::max(v - r, -1.0f))));
    u1 = std::max(u1, static_cast<int>(std::ceil(std::min(u + r, static_cast<float>(K.width)))));
    v1 = std::max(v1, static_cast<int>(std::ceil(std::min(v + r, static_cast<float>(K.height)))));
  }
  return {std::max(u0, 0), std::max(v0, 0), std::min(u1, K.width - 1), std::min(v1, K.height - 1)};
}

void InstanceRenderer::render(const slam::SurfelMap& map, const SE3& T_world_cam,
                              const PinholeIntrinsics& K, float max_splat_radius_px,
                              float splat_radius_scale, double depth_tolerance_m, bool want_color,
                              InstanceImages* out) {
  InstanceRenderOptions o;
  o.max_splat_radius_px = max_splat_radius_px;
  o.splat_radius_scale = splat_radius_scale;
  o.depth_tolerance_m = depth_tolerance_m;
  o.want_color = want_color;
  render(map, T_world_cam, K, o, out);
}

void InstanceRenderer::render(const slam::SurfelMap& map, const SE3& T_world_cam,
                              const PinholeIntrinsics& K, const InstanceRenderOptions& o,
                              InstanceImages* out) {
  auto [u0, v0, u1, v1] =
      gather_labelled(map, T_world_cam, K, o.max_splat_radius_px, o.splat_radius_scale);
  const bool want_scene = o.scene_margin_px >= 0;
  if (want_scene && u1 >= u0 && v1 >= v0) {
    u0 = std::max(0, u0 - o.scene_margin_px), v0 = std::max(0, v0 - o.scene_margin_px);
    u1 = std::min(K.width - 1, u1 + o.scene_margin_px);
    v1 = std::min(K.height - 1, v1 + o.scene_margin_px);
  }
  const int W = K.width, H = K.height;
  out->instance_id = LabelImage(W, H, 0);
  out->depth = DepthImage(W, H, 0.0f);
  out->color = o.want_color ? ColorImage(W, H, Rgb8{}) : ColorImage();
  out->scene_depth = want_scene ? DepthImage(W, H, 0.0f) : DepthImage();
  out->scene_color = want_scene ? ColorImage(W, H, Rgb8{}) : ColorImage();
  out->window_u_min = u0, out->window_v_min = v0, out->window_u_max = u1, out->window_v_max = v1;
  if (u1 < u0 || v1 < v0) return;  // no labelled surfel in view

  PinholeIntrinsics Kw = K;  // the window: intrinsics cropped to it
  Kw.cx -= u0, Kw.cy -= v0;
  Kw.width = u1 - u0 + 1, Kw.height = v1 - v0 + 1;
  slam::RenderOptions options;
  options.max_splat_radius_px = o.max_splat_radius_px;
  options.radius_scale = o.splat_radius_scale;
  options.want_vertex = options.want_normal = false;
  options.want_color = want_scene;
  options.want_instance = false;
  renderer_.render(map, T_world_cam, Kw, options, &all_);
  options.want_instance = true;
  options.want_color = o.want_color;
  renderer_.render(labelled_, T_world_cam, Kw, options, &objects_);

  const float tolerance = static_cast<float>(o.depth_tolerance_m);
  for (int v = 0; v < Kw.height; ++v)
    for (int u = 0; u < Kw.width; ++u) {
      const size_t k = static_cast<size_t>(v) * Kw.width + u;
      if (objects_.surfel_index[k] < 0) continue;
      const float z = objects_.depth[k];
      if (z > all_.depth[k] + tolerance) continue;  // something else is in front
      out->instance_id.at(u0 + u, v0 + v) = objects_.instance_id[k];
      out->depth.at(u0 + u, v0 + v) = z;
      if (o.want_color) out->color.at(u0 + u, v0 + v) = objects_.color[k];
    }
  if (want_scene) {
    paste(all_.depth, u0, v0, out->scene_depth);
    paste(all_.color, u0, v0, out->scene_color);
  }
}

}  // namespace orpe
