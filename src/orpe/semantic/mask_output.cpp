#include "orpe/semantic/mask_output.h"

#include <fmt/format.h>

#include <filesystem>

#include "orpe/core/error.h"
#include "orpe/io/image_io.h"
#include "orpe/semantic/semantic_output.h"

namespace orpe {

std::string color_file_name(const std::string& label_file) {
  const std::filesystem::path p(label_file);
  return (p.parent_path() / (p.stem().string() + "_color" + p.extension().string())).string();
}

LabelImage detection_label_image(const std::vector<Detection>& detections, int width, int height,
                                 float threshold, LabelClasses* classes) {
  LabelImage labels(width, height, 0);
  ProbabilityImage best(width, height, 0.0f);
  for (size_t d = 0; d < detections.size(); ++d) {
    const std::int32_t value = static_cast<std::int32_t>(d) + 1;
    if (classes) (*classes)[value] = detections[d].class_id;
    const ProbabilityImage& p = detections[d].probability;
    if (p.width() != width || p.height() != height) continue;  // no mask of this frame's size
    for (size_t k = 0; k < labels.size(); ++k)
      if (p[k] >= threshold && (labels[k] == 0 || p[k] > best[k])) {
        best[k] = p[k];
        labels[k] = value;
      }
  }
  return labels;
}

LabelImage render_confirmed_instance_labels(InstanceRenderer& renderer, const slam::SurfelMap& map,
                                            const SemanticFusion& fusion, const SE3& T_world_cam,
                                            const PinholeIntrinsics& K, LabelClasses* classes) {
  const SemanticParams& p = fusion.params();
  InstanceImages images;
  renderer.render(map, T_world_cam, K, static_cast<float>(p.mask_splat_radius_px),
                  static_cast<float>(p.mask_splat_radius_scale), p.mask_depth_tolerance_m, false,
                  &images);
  const auto confirmed = fusion.confirmed_instances();
  for (auto& id : images.instance_id) {
    if (id <= 0) continue;
    const auto it = confirmed.find(id);
    if (it == confirmed.end())
      id = 0;
    else if (classes)
      (*classes)[id] = it->second.argmax_class();
  }
  return std::move(images.instance_id);
}

MaskRecorder::MaskRecorder(std::string dir, float mask_threshold)
    : dir_(std::move(dir)), threshold_(mask_threshold) {
  index_.mask_threshold = mask_threshold;
}

bool MaskRecorder::record(const RgbdFrame& frame, const SE3& T_world_cam,
                          const slam::SurfelMap& map, const SemanticMapper& mapper) {
  const SemanticStep& step = mapper.last_step();
  if (!step.keyframe) return false;
  namespace fs = std::filesystem;
  const int W = frame.depth.width(), H = frame.depth.height();
  MaskRunFrame f;
  f.frame_index = frame.index;
  f.name = frame.name;
  const LabelImage input =
      detection_label_image(step.detections, W, H, threshold_, &f.input.classes);
  PinholeIntrinsics K = frame.intrinsics;
  K.width = W;
  K.height = H;
  const LabelImage projected = render_confirmed_instance_labels(
      renderer_, map, mapper.fusion(), T_world_cam, K, &f.projected.classes);
  for (const auto& classes : {&f.input.classes, &f.projected.classes})
    for (const auto& [label, cls] : *classes)
      if (label > 65535)
        throw IoError((fs::path(dir_) / "index.json").string(),
                      fmt::format("label value {} does not fit a 16-bit PNG", label));
  f.input.file = fmt::format("{:06d}_input.png", frame.index);
  f.projected.file = fmt::format("{:06d}_projected.png", frame.index);
  write_label_png((fs::path(dir_) / f.input.file).string(), input);
  write_label_png((fs::path(dir_) / f.projected.file).string(), projected);
  // For people (a 16-bit label PNG looks black): detections coloured by class (they have no
  // identity across frames), the map's instances by instance id (as semantic_map_instances.ply).
  LabelImage input_by_class(W, H, 0);
  for (size_t p = 0; p < input.size(); ++p)
    if (const auto c = f.input.classes.find(input[p]); input[p] > 0 && c != f.input.classes.end())
      input_by_class[p] = c->second;
  write_color_png((fs::path(dir_) / color_file_name(f.input.file)).string(),
                  colorize_instances(input_by_class));
  write_color_png((fs::path(dir_) / color_file_name(f.projected.file)).string(),
                  colorize_instances(projected));
  index_.frames.push_back(std::move(f));
  return true;
}

void MaskRecorder::finish(const std::string& dataset_path, const std::string& dataset_format,
                          const std::string& dataset_scene) {
  index_.dataset_path = dataset_path;
  index_.dataset_format = dataset_format;
  index_.dataset_scene = dataset_scene;
  write_mask_run_index((std::filesystem::path(dir_) / "index.json").string(), index_);
}

}  // namespace orpe
