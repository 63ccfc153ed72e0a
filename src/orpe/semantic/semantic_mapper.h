// The semantic stage as a pipeline calls it: once per frame, after tracking and geometric fusion,
//
//   SemanticMapper semantic(config.segmentation, config.semantic, class_ids);
//   for each frame: slam.process(frame);  // tracking + fusion
//                   semantic.process(frame, T_world_cam, slam_map);
//                   auto views = semantic.render_instance_views(slam_map, T_world_cam, K);  // pose
//                   stage (pass slam.last_pixel_surfel() to process() when the SLAM fused the
//                   frame)
//   semantic.finalize(slam_map);
//   write_semantic_outputs(out_dir, slam_map, semantic.fusion().instances(), class_names);
//
// Keyframes (SegmentationParams keyframe_*) are segmented and fused; other frames only advance the
// keyframe policy.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "orpe/semantic/segmenter.h"
#include "orpe/semantic/semantic_fusion.h"

namespace orpe {

/// What the map shows of one instance from a pose: the pose stage's inputs (the paper feeds
/// DenseFusion the map-rendered mask, depth and colour instead of the camera's).
struct InstanceView {
  int instance_id = 0;
  int class_id = 0;              ///< the instance's argmax class
  double class_probability = 0;  ///< its averaged probability
  int area_px = 0;               ///< pixels of the projected mask
  BoxPx box;                     ///< box of the projected mask
  MaskImage projected_mask;      ///< PM: 1 where the instance's surfels are the visible surface
  DepthImage projected_depth;    ///< PD: splatted depth (m) inside the mask, 0 outside
  ColorImage projected_color;    ///< PC: splatted surfel colour inside the mask, black outside
};

/// Splits label-aware instance images (with colour) into per-instance views. Instances with fewer
/// than `min_area_px` pixels, or not in `instances`, are left out. Sorted by instance id.
std::vector<InstanceView> split_instance_views(const InstanceImages& images,
                                               const std::map<int, InstanceInfo>& instances,
                                               int min_area_px = 1);

/// One frame's semantic step.
struct SemanticStep {
  bool keyframe = false;
  std::vector<Detection> detections;  ///< this keyframe's detections (empty on other frames)
  SemanticFrameReport report;         ///< meaningful when keyframe
  double segment_ms = 0;              ///< the back-end's time on this keyframe
};

class SemanticMapper {
 public:
  SemanticMapper(const SegmentationParams& segmentation, const SemanticParams& semantic,
                 std::vector<int> class_ids = {});
  /// With a caller-provided back-end (e.g. a network); segmentation params give the keyframe
  /// policy.
  SemanticMapper(std::unique_ptr<Segmenter> segmenter, const SegmentationParams& segmentation,
                 const SemanticParams& semantic);

  /// Call once per frame, after tracking and geometric fusion of `frame` into `map`.
  /// `pixel_surfel`: optional per-pixel surfel the frame was fused into
  /// (SlamSystem::last_pixel_surfel()).
  const SemanticStep& process(const RgbdFrame& frame, const SE3& T_world_cam, slam::SurfelMap& map,
                              const slam::IndexImage* pixel_surfel = nullptr);
  /// process() in three steps, for a caller that segments elsewhere (the pipeline's asynchronous
  /// segmentation, pipeline.segmentation_delay_frames): next_frame() advances the keyframe policy
  /// (true = segment this frame); detect() runs the back-end and touches nothing else (so it may
  /// run on another thread, one call at a time, in keyframe order; `segment_ms` gets its time);
  /// integrate() fuses a keyframe's detections (`segment_ms` is added to the summary's time).
  bool next_frame(const SE3& T_world_cam);
  std::vector<Detection> detect(const RgbdFrame& frame, const SegmentationContext& context,
                                double* segment_ms = nullptr);
  const SemanticStep& integrate(const RgbdFrame& frame, const SE3& T_world_cam,
                                std::vector<Detection> detections, slam::SurfelMap& map,
                                const slam::IndexImage* pixel_surfel = nullptr,
                                double segment_ms = 0);
  /// End of the run: removes spurious instances. Returns how many were removed.
  int finalize(slam::SurfelMap& map) { return fusion_.finalize(map); }
  /// The class models' minimal widths (m) for semantic.min_height_fraction; call before finalize().
  void set_class_min_widths(std::map<int, double> widths) {
    fusion_.set_class_min_widths(std::move(widths));
  }

  /// PM / PD / PC of every confirmed instance (detected in >= min_confirmed_detections keyframes;
  /// the tentative ones may still be spurious) seen from a pose, label-aware like the association
  /// masks.
  std::vector<InstanceView> render_instance_views(const slam::SurfelMap& map,
                                                  const SE3& T_world_cam,
                                                  const PinholeIntrinsics& K, int min_area_px = 1);
  /// The map's instance image at a pose: the projected masks of the confirmed instances, 0 = none.
  LabelImage render_instance_labels(const slam::SurfelMap& map, const SE3& T_world_cam,
                                    const PinholeIntrinsics& K);

  const SemanticFusion& fusion() const { return fusion_; }
  /// SemanticFusion::set_keep_scene / drop_kept_scene.
  void set_keep_scene(int margin_px) { fusion_.set_keep_scene(margin_px); }
  void drop_kept_scene() { fusion_.drop_kept_scene(); }
  const Segmenter& segmenter() const { return *segmenter_; }
  const SemanticStep& last_step() const { return step_; }
  int keyframes() const { return keyframes_; }
  /// Totals over the run so far (keyframes, detections, instances, time).
  std::string summary() const;

 private:
  std::unique_ptr<Segmenter> segmenter_;
  KeyframeSelector keyframe_selector_;
  SemanticFusion fusion_;
  SemanticStep step_;
  int frames_ = 0, keyframes_ = 0, detections_ = 0;
  double segment_ms_ = 0, fuse_ms_ = 0;
};

}  // namespace orpe
