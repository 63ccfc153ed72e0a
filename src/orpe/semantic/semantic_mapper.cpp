#include "orpe/semantic/semantic_mapper.h"

#include <fmt/format.h>
#include <chrono>

namespace orpe {

std::vector<InstanceView> split_instance_views(const InstanceImages& images,
                                               const std::map<int, InstanceInfo>& instances,
                                               int min_area_px) {
  const int W = images.instance_id.width(), H = images.instance_id.height();
  const bool have_color = images.color.width() == W && images.color.height() == H;
  std::map<int, int> area;
  for (const auto id : images.instance_id)
    if (id > 0) ++area[id];
  std::vector<InstanceView> out;
  std::map<int, size_t> view_of;  // instance id -> its view in `out`
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
    view_of[id] = out.size();
    out.push_back(std::move(iv));
  }
  // One pass over the image fills every view.
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      const int id = images.instance_id.at(u, v);
      if (id <= 0) continue;
      const auto it = view_of.find(id);
      if (it == view_of.end()) continue;
      InstanceView& iv = out[it->second];
      iv.projected_mask.at(u, v) = 1;
      iv.projected_depth.at(u, v) = images.depth.at(u, v);
      if (have_color) iv.projected_color.at(u, v) = images.color.at(u, v);
      iv.box.include(u, v);
    }
  return out;
}

SemanticMapper::SemanticMapper(const SegmentationParams& segmentation,
                               const SemanticParams& semantic, std::vector<int> class_ids)
    : SemanticMapper(make_segmenter(segmentation, std::move(class_ids)), segmentation, semantic) {}

SemanticMapper::SemanticMapper(std::unique_ptr<Segmenter> segmenter,
                               const SegmentationParams& segmentation,
                               const SemanticParams& semantic)
    : segmenter_(std::move(segmenter)), keyframe_selector_(segmentation), fusion_(semantic) {}

const SemanticStep& SemanticMapper::process(const RgbdFrame& frame, const SE3& T_world_cam,
                                            slam::SurfelMap& map,
                                            const slam::IndexImage* pixel_surfel) {
  if (!next_frame(T_world_cam)) {
    step_ = SemanticStep{};
    return step_;
  }
  SegmentationContext context;
  context.T_world_cam = T_world_cam;
  context.map = &map;
  double segment_ms = 0;
  std::vector<Detection> detections = detect(frame, context, &segment_ms);
  return integrate(frame, T_world_cam, std::move(detections), map, pixel_surfel, segment_ms);
}

bool SemanticMapper::next_frame(const SE3& T_world_cam) {
  ++frames_;
  return keyframe_selector_.is_keyframe(T_world_cam);
}

std::vector<Detection> SemanticMapper::detect(const RgbdFrame& frame,
                                              const SegmentationContext& context,
                                              double* segment_ms) {
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<Detection> detections = segmenter_->detect_in_context(frame, context);
  if (segment_ms)
    *segment_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return detections;
}

const SemanticStep& SemanticMapper::integrate(const RgbdFrame& frame, const SE3& T_world_cam,
                                              std::vector<Detection> detections,
                                              slam::SurfelMap& map,
                                              const slam::IndexImage* pixel_surfel,
                                              double segment_ms) {
  step_ = SemanticStep{};
  step_.keyframe = true;
  step_.segment_ms = segment_ms;
  ++keyframes_;
  segment_ms_ += segment_ms;
  step_.detections = std::move(detections);
  detections_ += static_cast<int>(step_.detections.size());
  step_.report = fusion_.integrate(frame, step_.detections, T_world_cam, map, pixel_surfel);
  fuse_ms_ += step_.report.total_ms;
  return step_;
}

std::vector<InstanceView> SemanticMapper::render_instance_views(const slam::SurfelMap& map,
                                                                const SE3& T_world_cam,
                                                                const PinholeIntrinsics& K,
                                                                int min_area_px) {
  InstanceImages images;
  fusion_.render_instances(map, T_world_cam, K, true, &images);
  return split_instance_views(images, fusion_.confirmed_instances(), min_area_px);
}

LabelImage SemanticMapper::render_instance_labels(const slam::SurfelMap& map,
                                                  const SE3& T_world_cam,
                                                  const PinholeIntrinsics& K) {
  InstanceImages images;
  fusion_.render_instances(map, T_world_cam, K, false, &images);
  const auto confirmed = fusion_.confirmed_instances();
  for (auto& id : images.instance_id)
    if (id > 0 && !confirmed.count(id)) id = 0;
  return std::move(images.instance_id);
}

std::string SemanticMapper::summary() const {
  return fmt::format(
      "semantic: {} frames, {} keyframes ({} back-end), {} detections, {} instances; "
      "segmentation {:.1f} ms/keyframe, fusion {:.1f} ms/keyframe",
      frames_, keyframes_, segmenter_->name(), detections_, fusion_.instances().size(),
      keyframes_ ? segment_ms_ / keyframes_ : 0.0, keyframes_ ? fuse_ms_ / keyframes_ : 0.0);
}

}  // namespace orpe
