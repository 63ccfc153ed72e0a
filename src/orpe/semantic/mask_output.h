// Per-frame instance masks of a run, for `orpe eval masks` (format: eval/mask_run.h): on every
// segmented keyframe, the frame's detections and the map's confirmed instances rendered at the
// frame's pose, as label images with their classes.
//
//   MaskRecorder masks(OUT + "/masks", mask_threshold);
//   for each frame: ... mapper.process(frame, T_world_cam, map, ...);
//                   masks.record(frame, T_world_cam, map, mapper);  // keyframes only
//   masks.finish(dataset_path, info.format, scene);                  // index.json, last
#pragma once

#include <string>
#include <vector>

#include "orpe/eval/mask_run.h"
#include "orpe/semantic/instance_render.h"
#include "orpe/semantic/semantic_mapper.h"

namespace orpe {

/// The colour-coded copy MaskRecorder writes beside each label PNG, for looking at:
/// "000012_input.png" -> "000012_input_color.png" (io's label_color; black = no label). Input
/// masks are coloured by class, projected masks by instance id.
std::string color_file_name(const std::string& label_file);

/// The detections as one instance label image: value d + 1 where detection d's probability is
/// >= threshold and the highest of the detections there (ties: the first). `classes` (optional)
/// receives label value -> class for every detection.
LabelImage detection_label_image(const std::vector<Detection>& detections, int width, int height,
                                 float threshold, LabelClasses* classes = nullptr);

/// The map's confirmed instances at a pose (what SemanticMapper::render_instance_labels gives),
/// with a caller-owned renderer so a const mapper suffices. `classes` (optional): instance id ->
/// argmax class of each instance in the image.
LabelImage render_confirmed_instance_labels(InstanceRenderer& renderer, const slam::SurfelMap& map,
                                            const SemanticFusion& fusion, const SE3& T_world_cam,
                                            const PinholeIntrinsics& K,
                                            LabelClasses* classes = nullptr);

class MaskRecorder {
 public:
  /// Writes into `dir` (created on the first frame). `mask_threshold`: soft detection mask ->
  /// binary (SegmentationParams::mask_threshold).
  MaskRecorder(std::string dir, float mask_threshold);

  /// Call after mapper.process(frame, ...): on a keyframe (mapper.last_step().keyframe), writes the
  /// frame's two label images (atomically) and returns true; otherwise does nothing.
  bool record(const RgbdFrame& frame, const SE3& T_world_cam, const slam::SurfelMap& map,
              const SemanticMapper& mapper);
  /// Writes index.json (atomically). Throws IoError.
  void finish(const std::string& dataset_path, const std::string& dataset_format,
              const std::string& dataset_scene);
  size_t frames() const { return index_.frames.size(); }
  const std::string& dir() const { return dir_; }

 private:
  std::string dir_;
  float threshold_;
  InstanceRenderer renderer_;
  MaskRunIndex index_;
};

}  // namespace orpe
