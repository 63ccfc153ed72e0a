// 2D instance segmentation back-ends: a frame in, a list of detections (class, score, box, soft
// mask) out. The paper runs Mask R-CNN on keyframes; here the back-ends are
//   - "gt":    the frame's ground-truth labels (labels_gt / objects_gt), optionally degraded by a
//              seeded model of a real detector's errors (boundary erosion/dilation with soft edges
//              just below 0.5, missed detections, wrong classes, spurious blobs);
//   - "files": precomputed detections of any external detector (docs/SEMANTIC.md, "files format");
//   - "model": recognition of the dataset's object models from geometry alone (src/orpe/recognition;
//              built by the pipeline, which has the models: make_segmenter() cannot create it);
//   - "maskrcnn": a torchvision Mask R-CNN exported to TorchScript, run in LibTorch (src/orpe/nets;
//              built by the pipeline, which has the dataset's classes; docs/NETWORKS.md).
// A back-end is deterministic: the same frame (and seed) always gives the same detections.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "orpe/core/frame.h"
#include "orpe/core/se3.h"
#include "orpe/semantic/detection.h"

namespace orpe::slam {
class SurfelMap;
}

namespace orpe {

struct SegmentationParams {
  std::string backend = "gt";   ///< gt | files | model | maskrcnn
  std::string files_dir;        ///< files back-end: folder of <frame index:06d>.json + mask images
  /// model back-end: comma-separated class names or ids to look for; empty = every model of the
  /// dataset.
  std::string model_classes;
  double mask_threshold = 0.5;  ///< soft mask -> binary mask (Mask R-CNN: 0.5)
  double min_score = 0.5;       ///< detections below this score are dropped (every back-end)
  int min_mask_area_px = 30;    ///< detections with fewer mask pixels are dropped (every back-end)

  // maskrcnn back-end (src/orpe/nets, docs/NETWORKS.md).
  std::string maskrcnn_model;        ///< TorchScript file of scripts/nets/maskrcnn_export.py
  std::string maskrcnn_class_map;    ///< label -> class file; empty = <model>.classes.txt
  int maskrcnn_threads = 0;          ///< LibTorch intra-op threads (process-wide); 0 = default
  int maskrcnn_min_size_px = 0;      ///< network input shorter side; 0 = as exported
  int maskrcnn_max_size_px = 0;      ///< network input longer side at most; 0 = as exported
  int maskrcnn_input_width_px = 0;   ///< frames must be this wide; 0 = any
  int maskrcnn_input_height_px = 0;  ///< frames must be this high; 0 = any

  // Keyframe policy: a frame is a keyframe when either enabled rule fires; the first frame always
  // is.
  int keyframe_every_n_frames = 1;  ///< every n-th frame; 0 disables the rule
  double keyframe_min_translation_m =
      0;  ///< camera moved this far since the last keyframe; 0 = off
  double keyframe_min_rotation_deg =
      0;  ///< camera turned this much since the last keyframe; 0 = off

  // gt back-end degradation (deterministic per (seed, frame index, object)).
  bool gt_degrade = true;       ///< false = exact ground-truth masks (probability 1 / 0)
  int seed = 7;                 ///< seed of every random choice of the degradation
  int gt_min_visible_px = 100;  ///< objects with fewer visible pixels are never detected
  /// Boundary shift of an object's masks: a per-object base, uniform integer in [min, max] and the
  /// same in every frame (a detector errs systematically on an object's outline), plus a per-frame
  /// jitter, uniform integer in [-jitter, jitter]. > 0 erodes (object edge pixels fall just below
  /// 0.5), < 0 dilates.
  int gt_boundary_shift_min_px = 0;
  int gt_boundary_shift_max_px = 3;
  int gt_boundary_jitter_px = 1;
  double gt_band_min_probability =
      0.42;  ///< eroded object pixels get [this, 0.5): "slightly below 0.5"
  double gt_core_probability = 0.95;  ///< probability deep inside the mask
  double gt_core_ramp_px = 3;         ///< distance over which 0.5 rises to the core probability
  double gt_background_edge_probability = 0.3;  ///< background next to the mask (far below 0.5)
  double gt_background_decay_px = 2;   ///< e-folding distance of the background probability
  double gt_probability_noise = 0.0;   ///< std of per-pixel Gaussian noise added to the soft mask
  double gt_miss_rate = 0.1;           ///< probability that a visible object is not detected
  double gt_wrong_class_rate = 0.05;   ///< probability that a detection gets another class
  double gt_spurious_per_frame = 0.2;  ///< mean number of spurious blobs per frame (Poisson)
  int gt_spurious_min_radius_px = 8;   ///< spurious blob (ellipse) semi-axis range
  int gt_spurious_max_radius_px = 30;

  template <class V>
  void visit(V&& v) {
    v("backend", backend,
      "Segmentation back-end: gt (ground-truth labels, optionally degraded) | files | model "
      "(recognise the dataset's object models from geometry, no ground truth; section "
      "recognition)");
    v("files_dir", files_dir,
      "files back-end: folder of <frame index:06d>.json + masks (docs/SEMANTIC.md)");
    v("model_classes", model_classes,
      "model back-end: comma-separated class names or ids to look for (empty = every model of "
      "the dataset)");
    v("mask_threshold", mask_threshold, "Soft mask -> binary mask threshold (Mask R-CNN: 0.5)");
    v("min_score", min_score, "Detections with a lower score are dropped, in [0, 1]");
    v("min_mask_area_px", min_mask_area_px, "Detections with fewer mask pixels are dropped");
    v("maskrcnn_model", maskrcnn_model,
      "maskrcnn back-end: TorchScript file from scripts/nets/maskrcnn_export.py "
      "(docs/NETWORKS.md)");
    v("maskrcnn_class_map", maskrcnn_class_map,
      "maskrcnn back-end: network label -> dataset class file; empty = <model>.classes.txt");
    v("maskrcnn_threads", maskrcnn_threads,
      "maskrcnn back-end: LibTorch intra-op threads (process-wide); 0 = LibTorch's default");
    v("maskrcnn_min_size_px", maskrcnn_min_size_px,
      "maskrcnn back-end: network input shorter side (px); 0 = as exported");
    v("maskrcnn_max_size_px", maskrcnn_max_size_px,
      "maskrcnn back-end: network input longer side at most (px); 0 = as exported");
    v("maskrcnn_input_width_px", maskrcnn_input_width_px,
      "maskrcnn back-end: frames of another width are an error; 0 = any");
    v("maskrcnn_input_height_px", maskrcnn_input_height_px,
      "maskrcnn back-end: frames of another height are an error; 0 = any");
    v("keyframe_every_n_frames", keyframe_every_n_frames,
      "Segment every n-th frame; 0 disables the rule (the first frame is always a keyframe)");
    v("keyframe_min_translation_m", keyframe_min_translation_m,
      "Also a keyframe when the camera moved this far (m) since the last one; 0 = off");
    v("keyframe_min_rotation_deg", keyframe_min_rotation_deg,
      "Also a keyframe when the camera turned this much (deg) since the last one; 0 = off");
    v("gt_degrade", gt_degrade,
      "gt back-end: degrade the masks like a real detector (false = exact)");
    v("seed", seed,
      "gt back-end: seed of the degradation (deterministic per seed and frame index)");
    v("gt_min_visible_px", gt_min_visible_px,
      "gt back-end: objects with fewer visible pixels are missed");
    v("gt_boundary_shift_min_px", gt_boundary_shift_min_px,
      "gt back-end: per-object boundary shift (same in every frame), lower bound (px; < 0 "
      "dilates)");
    v("gt_boundary_shift_max_px", gt_boundary_shift_max_px,
      "gt back-end: per-object boundary shift (same in every frame), upper bound (px; > 0 erodes)");
    v("gt_boundary_jitter_px", gt_boundary_jitter_px,
      "gt back-end: per-frame jitter added to the boundary shift, uniform in [-jitter, jitter] "
      "(px)");
    v("gt_band_min_probability", gt_band_min_probability,
      "gt back-end: eroded object pixels get probabilities in [this, 0.5)");
    v("gt_core_probability", gt_core_probability, "gt back-end: probability deep inside a mask");
    v("gt_core_ramp_px", gt_core_ramp_px,
      "gt back-end: distance (px) over which 0.5 rises to the core");
    v("gt_background_edge_probability", gt_background_edge_probability,
      "gt back-end: probability of the background pixels next to a mask");
    v("gt_background_decay_px", gt_background_decay_px,
      "gt back-end: e-folding distance (px) of the background probability");
    v("gt_probability_noise", gt_probability_noise,
      "gt back-end: std of per-pixel Gaussian noise on the soft mask (0 = none)");
    v("gt_miss_rate", gt_miss_rate, "gt back-end: probability that a visible object is missed");
    v("gt_wrong_class_rate", gt_wrong_class_rate, "gt back-end: probability of a wrong class");
    v("gt_spurious_per_frame", gt_spurious_per_frame,
      "gt back-end: mean number of spurious blobs per frame (Poisson)");
    v("gt_spurious_min_radius_px", gt_spurious_min_radius_px,
      "gt back-end: spurious blob min semi-axis (px)");
    v("gt_spurious_max_radius_px", gt_spurious_max_radius_px,
      "gt back-end: spurious blob max semi-axis (px)");
  }
  bool IsValid(std::string* why) const;
};

/// What a back-end may use besides the frame (never ground truth): the tracked camera pose and the
/// map as fused up to this frame.
struct SegmentationContext {
  SE3 T_world_cam;
  const slam::SurfelMap* map = nullptr;  ///< may be null
};

class Segmenter {
 public:
  virtual ~Segmenter() = default;
  virtual std::string name() const = 0;
  /// Detections of one frame, already filtered by min_score and min_mask_area_px. Throws IoError
  /// (naming the file) for unreadable detector output, never returns half a frame.
  virtual std::vector<Detection> detect(const RgbdFrame& frame) const = 0;
  /// The call of SemanticMapper on each keyframe, in order. Back-ends that carry state across
  /// keyframes (the model back-end refines the objects it already knows) override it; the default
  /// is detect(frame).
  virtual std::vector<Detection> detect_in_context(const RgbdFrame& frame,
                                                   const SegmentationContext& context) {
    (void)context;
    return detect(frame);
  }
};

/// Creates the back-end named by params.backend. `class_ids` are the dataset's classes (the pool of
/// wrong classes for the gt degradation); empty = 1..21 (YCB-Video). Throws ConfigError.
std::unique_ptr<Segmenter> make_segmenter(const SegmentationParams& params,
                                          std::vector<int> class_ids = {});

/// The gt back-end. Needs frame.labels_gt and frame.objects_gt; a frame without them gives no
/// detections (and a warning, once).
class GroundTruthSegmenter : public Segmenter {
 public:
  GroundTruthSegmenter(const SegmentationParams& params, std::vector<int> class_ids);
  std::string name() const override { return "gt"; }
  std::vector<Detection> detect(const RgbdFrame& frame) const override;

 private:
  SegmentationParams params_;
  std::vector<int> class_ids_;
};

/// The files back-end (format in docs/SEMANTIC.md). A frame without a JSON file has no detections.
class FileSegmenter : public Segmenter {
 public:
  explicit FileSegmenter(const SegmentationParams& params);
  std::string name() const override { return "files"; }
  std::vector<Detection> detect(const RgbdFrame& frame) const override;
  /// Reads the detections of one frame index from `dir` (unfiltered). Throws IoError.
  static std::vector<Detection> read(const std::string& dir, int frame_index, int width,
                                     int height);

 private:
  SegmentationParams params_;
};

/// Writes detections in the files back-end's format (JSON + 8-bit mask + 16-bit probability PNG per
/// detection), atomically, the JSON last. Lets any detector's output, or the gt back-end's, be
/// stored.
void write_detection_files(const std::string& dir, int frame_index,
                           const std::vector<Detection>& detections, float mask_threshold = 0.5f);

/// Path of the JSON file of a frame: <dir>/<frame_index:06d>.json.
std::string detection_json_path(const std::string& dir, int frame_index);

/// Keyframe policy (SegmentationParams keyframe_*): call once per frame, in order.
class KeyframeSelector {
 public:
  explicit KeyframeSelector(const SegmentationParams& params);
  /// True when this frame is a keyframe; then it becomes the reference for the motion rules.
  bool is_keyframe(const SE3& T_world_cam);
  void reset();

 private:
  int every_n_ = 1;
  double min_translation_m_ = 0, min_rotation_rad_ = 0;
  int frames_since_keyframe_ = 0;
  bool have_keyframe_ = false;
  SE3 T_world_last_keyframe_;
};

}  // namespace orpe
