#include "orpe/semantic/semantic_mapper.h"

#include <chrono>
#include <fmt/format.h>

namespace orpe {

std::vector<InstanceView> render_instance_views(const slam::SurfelMap& map,
                                                const std::map<int, InstanceInfo>& instances,
                                                const SE3& T_world_cam, const PinholeIntrinsics& K,
                                                slam::MapRenderer& renderer, int min_area_px,
                                                float max_splat_radius_px) {
  slam::RenderOptions options;
  options.max_splat_radius_px = max_splat_radius_px;
  options.want_vertex = options.want_normal = false;
  options.want_color = options.want_instance = true;
  slam::RenderedView view;
  renderer.render(map, T_world_cam, K, options, &view);
  const int W = view.depth.width(), H = view.depth.height();
  std::map<int, int> area;
  for (const auto id : view.instance_id)
    if (id > 0) ++area[id];
  std::vector<InstanceView> out;
  for (const auto& [id, pixels] : area) {
    const auto it = instances.find(id);
    if (it == instances.end() || pixels < min_area_px) continue;
    InstanceView iv;
    iv.instance_id = id;
    iv.class_id = it->second.argmax_class();
    iv.class_probability = it->second.argmax_probability();
    iv.area_px = pixels;
    iv.projected_mask = MaskImage(W, H, 0);
    iv.projected_depth = DepthImage(W, H, 0.0f);
    iv.projected_color = ColorImage(W, H, Rgb8{});
    for (int v = 0; v < H; ++v)
      for (int u = 0; u < W; ++u) {
        if (view.instance_id.at(u, v) != id) continue;
        iv.projected_mask.at(u, v) = 1;
        iv.projected_depth.at(u, v) = view.depth.at(u, v);
        iv.projected_color.at(u, v) = view.color.at(u, v);
        iv.box.include(u, v);
      }
    out.push_back(std::move(iv));
  }
  return out;
}

LabelImage render_instance_labels(const slam::SurfelMap& map, const SE3& T_world_cam,
                                  const PinholeIntrinsics& K, slam::MapRenderer& renderer,
                                  float max_splat_radius_px) {
  slam::RenderOptions options;
  options.max_splat_radius_px = max_splat_radius_px;
  options.want_vertex = options.want_normal = options.want_color = false;
  options.want_instance = true;
  slam::RenderedView view;
  renderer.render(map, T_world_cam, K, options, &view);
  return std::move(view.instance_id);
}

SemanticMapper::SemanticMapper(const SegmentationParams& segmentation, const SemanticParams& semantic,
                               std::vector<int> class_ids)
    : SemanticMapper(make_segmenter(segmentation, std::move(class_ids)), segmentation, semantic) {}

SemanticMapper::SemanticMapper(std::unique_ptr<Segmenter> segmenter,
                               const SegmentationParams& segmentation, const SemanticParams& semantic)
    : segmenter_(std::move(segmenter)), keyframe_selector_(segmentation), fusion_(semantic) {}

const SemanticStep& SemanticMapper::process(const RgbdFrame& frame, const SE3& T_world_cam,
                                            slam::SurfelMap& map, const slam::IndexImage* pixel_surfel) {
  ++frames_;
  step_ = SemanticStep{};
  step_.keyframe = keyframe_selector_.is_keyframe(T_world_cam);
  if (!step_.keyframe) return step_;
  ++keyframes_;
  const auto t0 = std::chrono::steady_clock::now();
  step_.detections = segmenter_->detect(frame);
  segment_ms_ += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  detections_ += static_cast<int>(step_.detections.size());
  step_.report = fusion_.integrate(frame, step_.detections, T_world_cam, map, pixel_surfel);
  fuse_ms_ += step_.report.total_ms;
  return step_;
}

std::vector<InstanceView> SemanticMapper::render_instance_views(const slam::SurfelMap& map,
                                                                const SE3& T_world_cam,
                                                                const PinholeIntrinsics& K,
                                                                int min_area_px) {
  return orpe::render_instance_views(map, fusion_.instances(), T_world_cam, K, renderer_, min_area_px,
                                     static_cast<float>(fusion_.params().mask_splat_radius_px));
}

LabelImage SemanticMapper::render_instance_labels(const slam::SurfelMap& map, const SE3& T_world_cam,
                                                  const PinholeIntrinsics& K) {
  return orpe::render_instance_labels(map, T_world_cam, K, renderer_,
                                      static_cast<float>(fusion_.params().mask_splat_radius_px));
}

std::string SemanticMapper::summary() const {
  return fmt::format(
      "semantic: {} frames, {} keyframes ({} back-end), {} detections, {} instances; "
      "segmentation {:.1f} ms/keyframe, fusion {:.1f} ms/keyframe",
      frames_, keyframes_, segmenter_->name(), detections_, fusion_.instances().size(),
      keyframes_ ? segment_ms_ / keyframes_ : 0.0, keyframes_ ? fuse_ms_ / keyframes_ : 0.0);
}

}  // namespace orpe
