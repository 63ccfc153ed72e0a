#include "orpe/semantic/segmenter.h"

#include <cmath>

#include "orpe/core/error.h"

namespace orpe {

bool SegmentationParams::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (backend != "gt" && backend != "files" && backend != "model" && backend != "maskrcnn")
    return fail("backend must be gt, files, model or maskrcnn (got '" + backend + "')");
  if (backend == "files" && files_dir.empty()) return fail("backend files needs files_dir");
  if (backend == "maskrcnn" && maskrcnn_model.empty())
    return fail("backend maskrcnn needs maskrcnn_model (a TorchScript file)");
  for (int v : {maskrcnn_threads, maskrcnn_min_size_px, maskrcnn_max_size_px,
                maskrcnn_input_width_px, maskrcnn_input_height_px})
    if (v < 0) return fail("maskrcnn_threads and maskrcnn_*_px must be >= 0");
  if (!(mask_threshold > 0 && mask_threshold < 1)) return fail("mask_threshold must be in (0, 1)");
  if (!(min_score >= 0 && min_score <= 1)) return fail("min_score must be in [0, 1]");
  if (min_mask_area_px < 0) return fail("min_mask_area_px must be >= 0");
  if (keyframe_every_n_frames < 0) return fail("keyframe_every_n_frames must be >= 0");
  if (!(keyframe_min_translation_m >= 0)) return fail("keyframe_min_translation_m must be >= 0");
  if (!(keyframe_min_rotation_deg >= 0)) return fail("keyframe_min_rotation_deg must be >= 0");
  if (keyframe_every_n_frames == 0 && keyframe_min_translation_m == 0 &&
      keyframe_min_rotation_deg == 0)
    return fail(
        "every keyframe rule is disabled: set keyframe_every_n_frames or a motion threshold");
  if (gt_min_visible_px < 0) return fail("gt_min_visible_px must be >= 0");
  if (gt_boundary_shift_min_px > gt_boundary_shift_max_px)
    return fail("gt_boundary_shift_min_px must be <= gt_boundary_shift_max_px");
  if (std::abs(gt_boundary_shift_min_px) > 50 || std::abs(gt_boundary_shift_max_px) > 50)
    return fail("gt_boundary_shift_*_px must be within [-50, 50]");
  if (gt_boundary_jitter_px < 0 || gt_boundary_jitter_px > 20)
    return fail("gt_boundary_jitter_px must be in [0, 20]");
  if (!(gt_band_min_probability > 0 && gt_band_min_probability < mask_threshold))
    return fail("gt_band_min_probability must be in (0, mask_threshold)");
  if (!(gt_core_probability > mask_threshold && gt_core_probability <= 1))
    return fail("gt_core_probability must be in (mask_threshold, 1]");
  if (!(gt_core_ramp_px > 0)) return fail("gt_core_ramp_px must be > 0");
  if (!(gt_background_edge_probability >= 0 && gt_background_edge_probability < mask_threshold))
    return fail("gt_background_edge_probability must be in [0, mask_threshold)");
  if (!(gt_background_decay_px > 0)) return fail("gt_background_decay_px must be > 0");
  if (!(gt_probability_noise >= 0 && gt_probability_noise <= 0.5))
    return fail("gt_probability_noise must be in [0, 0.5]");
  for (double rate : {gt_miss_rate, gt_wrong_class_rate})
    if (!(rate >= 0 && rate <= 1))
      return fail("gt_miss_rate and gt_wrong_class_rate must be in [0, 1]");
  if (!(gt_spurious_per_frame >= 0 && gt_spurious_per_frame <= 20))
    return fail("gt_spurious_per_frame must be in [0, 20]");
  if (gt_spurious_min_radius_px < 1 || gt_spurious_max_radius_px < gt_spurious_min_radius_px)
    return fail("need 1 <= gt_spurious_min_radius_px <= gt_spurious_max_radius_px");
  return true;
}

std::unique_ptr<Segmenter> make_segmenter(const SegmentationParams& params,
                                          std::vector<int> class_ids) {
  std::string why;
  if (!params.IsValid(&why)) throw ConfigError("segmentation: " + why);
  if (params.backend == "gt")
    return std::make_unique<GroundTruthSegmenter>(params, std::move(class_ids));
  if (params.backend == "model")
    throw ConfigError(
        "segmentation: the model back-end needs the dataset's object models; construct "
        "ModelRecognizer (orpe/recognition) and pass it to SemanticMapper (orpe run does)");
  if (params.backend == "maskrcnn")
    throw ConfigError(
        "segmentation: the maskrcnn back-end needs the dataset's classes; construct "
        "nets::MaskRcnnSegmenter (orpe/nets) and pass it to SemanticMapper (orpe run does)");
  return std::make_unique<FileSegmenter>(params);
}

KeyframeSelector::KeyframeSelector(const SegmentationParams& params)
    : every_n_(params.keyframe_every_n_frames),
      min_translation_m_(params.keyframe_min_translation_m),
      min_rotation_rad_(params.keyframe_min_rotation_deg * M_PI / 180.0) {}

void KeyframeSelector::reset() {
  frames_since_keyframe_ = 0;
  have_keyframe_ = false;
}

bool KeyframeSelector::is_keyframe(const SE3& T_world_cam) {
  bool key = !have_keyframe_;
  ++frames_since_keyframe_;
  if (!key && every_n_ > 0 && frames_since_keyframe_ >= every_n_) key = true;
  if (!key && (min_translation_m_ > 0 || min_rotation_rad_ > 0)) {
    const SE3 T_last_cam = T_world_last_keyframe_.inverse() * T_world_cam;
    if (min_translation_m_ > 0 && T_last_cam.translation().norm() >= min_translation_m_) key = true;
    if (min_rotation_rad_ > 0 &&
        rotation_distance_rad(Mat3::Identity(), T_last_cam.rotation()) >= min_rotation_rad_)
      key = true;
  }
  if (key) {
    have_keyframe_ = true;
    frames_since_keyframe_ = 0;
    T_world_last_keyframe_ = T_world_cam;
  }
  return key;
}

}  // namespace orpe
