#include "orpe/semantic/instance_render.h"

namespace orpe {

void InstanceRenderer::render(const slam::SurfelMap& map, const SE3& T_world_cam,
                              const PinholeIntrinsics& K, float max_splat_radius_px,
                              float splat_radius_scale, double depth_tolerance_m, bool want_color,
                              InstanceImages* out) {
  // Gather the labelled surfels (only the arrays the renderer reads; the others stay default).
  selected_.clear();
  for (size_t i = 0; i < map.size(); ++i)
    if (map.instance_id[i] > 0) selected_.push_back(static_cast<std::uint32_t>(i));
  labelled_.resize(selected_.size());
  const long n = static_cast<long>(selected_.size());
#pragma omp parallel for schedule(static)
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
  }

  slam::RenderOptions options;
  options.max_splat_radius_px = max_splat_radius_px;
  options.radius_scale = splat_radius_scale;
  options.want_vertex = options.want_normal = options.want_color = false;
  options.want_instance = false;
  renderer_.render(map, T_world_cam, K, options, &all_);
  options.want_instance = true;
  options.want_color = want_color;
  renderer_.render(labelled_, T_world_cam, K, options, &objects_);

  const int W = K.width, H = K.height;
  out->instance_id = LabelImage(W, H, 0);
  out->depth = DepthImage(W, H, 0.0f);
  out->color = want_color ? ColorImage(W, H, Rgb8{}) : ColorImage();
  const float tolerance = static_cast<float>(depth_tolerance_m);
  for (size_t k = 0; k < out->instance_id.size(); ++k) {
    if (objects_.surfel_index[k] < 0) continue;
    const float z = objects_.depth[k];
    if (z > all_.depth[k] + tolerance) continue;  // something else is in front
    out->instance_id[k] = objects_.instance_id[k];
    out->depth[k] = z;
    if (want_color) out->color[k] = objects_.color[k];
  }
}

}  // namespace orpe
