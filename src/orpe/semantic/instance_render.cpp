#include "orpe/semantic/instance_render.h"

#include <algorithm>
#include <cmath>

namespace orpe {
bool SceneRender::matches(const slam::SurfelMap& m, const SE3& T, const PinholeIntrinsics& k,
                          float max_splat_px, float radius_scale, int wu0, int wv0, int wu1,
                          int wv1) const {
  return map == &m && map_size == m.size() && T.matrix() == T_world_cam.matrix() &&
         k.fx == K.fx && k.fy == K.fy && k.cx == K.cx && k.cy == K.cy && k.width == K.width &&
         k.height == K.height && max_splat_px == max_splat_radius_px &&
         radius_scale == splat_radius_scale && wu0 >= u0 && wv0 >= v0 &&
         wu1 < u0 + depth.width() && wv1 < v0 + depth.height();
}

namespace {

/// The window the labelled surfels' splats reach (inclusive bounds u0, v0, u1, v1; u1 < u0 when
/// none is in view).
std::array<int, 4> labelled_window(const slam::SurfelMap& map, const SE3& T_world_cam,
                                   const PinholeIntrinsics& K, float max_splat_radius_px,
                                   float splat_radius_scale) {
  const long n = static_cast<long>(map.size());
  const SE3 T_cam_world = T_world_cam.inverse();
  const Eigen::Matrix3f R = T_cam_world.rotation().cast<float>();
  const Eigen::Vector3f t = T_cam_world.translation().cast<float>();
  const float fx = static_cast<float>(K.fx), fy = static_cast<float>(K.fy);
  const float cx = static_cast<float>(K.cx), cy = static_cast<float>(K.cy);
  const float f_max = std::max(fx, fy);
  int u0 = K.width, v0 = K.height, u1 = -1, v1 = -1;
#pragma omp parallel for schedule(static) reduction(min : u0, v0) reduction(max : u1, v1)
  for (long i = 0; i < n; ++i) {
    if (map.instance_id[i] <= 0) continue;
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

}  // namespace

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
  if (o.keep_scene) o.keep_scene->clear();
  auto [u0, v0, u1, v1] =
      labelled_window(map, T_world_cam, K, o.max_splat_radius_px, o.splat_radius_scale);
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
  out->scene_reused = false;
  out->map_passes = 0;
  if (u1 < u0 || v1 < v0) return;  // no labelled surfel in view
  const Renders r = render_window(map, T_world_cam, K, o, {u0, v0, u1, v1}, out);
  compose(r, o, {u0, v0, u1, v1}, want_scene, out);
}

InstanceRenderer::Renders InstanceRenderer::render_window(
    const slam::SurfelMap& map, const SE3& T_world_cam, const PinholeIntrinsics& K,
    const InstanceRenderOptions& o, const std::array<int, 4>& window, InstanceImages* out) {
  const auto [u0, v0, u1, v1] = window;
  slam::RenderOptions options;
  options.max_splat_radius_px = o.max_splat_radius_px;
  options.radius_scale = o.splat_radius_scale;
  options.want_vertex = options.want_normal = false;
  options.want_instance = false;
  slam::RenderOptions labelled = options;  // the labelled view's outputs (and filter, alone)
  labelled.want_instance = true;
  labelled.want_color = o.want_color;
  labelled.only_labelled = true;
  const auto set_window = [&options, &labelled](int wu0, int wv0, int wu1, int wv1) {
    for (slam::RenderOptions* ro : {&options, &labelled}) {
      ro->window_u0 = wu0, ro->window_v0 = wv0;
      ro->window_width = wu1 - wu0 + 1, ro->window_height = wv1 - wv0 + 1;
    }
  };
  Renders r;
  if (o.reuse_scene && o.reuse_scene->matches(map, T_world_cam, K, o.max_splat_radius_px,
                                              o.splat_radius_scale, u0, v0, u1, v1)) {
    // The render of every surfel is the kept one: the labelled surfels only, over the window.
    r.scene_depth = &o.reuse_scene->depth, r.scene_color = &o.reuse_scene->color;
    r.sx = u0 - o.reuse_scene->u0, r.sy = v0 - o.reuse_scene->v0;
    out->scene_reused = true;
    set_window(u0, v0, u1, v1);
    renderer_.render(map, T_world_cam, K, labelled, &objects_);
    out->map_passes = 1;
    return r;
  }
  // Both views (in one pass over the map unless one_pass is off): over the kept window (this one
  // grown by keep_margin_px: a later render's window may be larger) or over this window only.
  const int m = o.keep_scene ? std::max(0, o.keep_margin_px) : 0;
  const int ku0 = std::max(0, u0 - m), kv0 = std::max(0, v0 - m);
  set_window(ku0, kv0, std::min(K.width - 1, u1 + m), std::min(K.height - 1, v1 + m));
  options.want_color = o.keep_scene || o.scene_margin_px >= 0;
  if (o.one_pass) {
    renderer_.render_with_labelled(map, T_world_cam, K, options, labelled, &all_, &objects_);
    out->map_passes = 1;
  } else {
    renderer_.render(map, T_world_cam, K, options, &all_);
    renderer_.render(map, T_world_cam, K, labelled, &objects_);
    out->map_passes = 2;
  }
  r.sx = r.ox = u0 - ku0, r.sy = r.oy = v0 - kv0;
  if (o.keep_scene) {
    SceneRender& kept = *o.keep_scene;
    kept.map = &map, kept.map_size = map.size(), kept.T_world_cam = T_world_cam, kept.K = K;
    kept.max_splat_radius_px = o.max_splat_radius_px, kept.splat_radius_scale = o.splat_radius_scale;
    kept.u0 = ku0, kept.v0 = kv0;
    kept.depth = all_.depth, kept.color = all_.color;
  }
  return r;
}

void InstanceRenderer::compose(const Renders& r, const InstanceRenderOptions& o,
                               const std::array<int, 4>& window, bool want_scene,
                               InstanceImages* out) const {
  const auto [u0, v0, u1, v1] = window;
  const int ww = u1 - u0 + 1, wh = v1 - v0 + 1;  // the window's size
  const DepthImage& scene_depth = r.scene_depth ? *r.scene_depth : all_.depth;
  const ColorImage& scene_color = r.scene_color ? *r.scene_color : all_.color;
  const float tolerance = static_cast<float>(o.depth_tolerance_m);
  for (int v = 0; v < wh; ++v)
    for (int u = 0; u < ww; ++u) {
      const int ou = r.ox + u, ov = r.oy + v;  // in the labelled view
      if (objects_.surfel_index.at(ou, ov) < 0) continue;
      const float z = objects_.depth.at(ou, ov);
      if (z > scene_depth.at(r.sx + u, r.sy + v) + tolerance) continue;  // something else in front
      out->instance_id.at(u0 + u, v0 + v) = objects_.instance_id.at(ou, ov);
      out->depth.at(u0 + u, v0 + v) = z;
      if (o.want_color) out->color.at(u0 + u, v0 + v) = objects_.color.at(ou, ov);
    }
  if (want_scene) {
    for (int v = 0; v < wh; ++v) {
      std::copy_n(&scene_depth.at(r.sx, r.sy + v), ww, &out->scene_depth.at(u0, v0 + v));
      std::copy_n(&scene_color.at(r.sx, r.sy + v), ww, &out->scene_color.at(u0, v0 + v));
    }
  }
}

}  // namespace orpe
