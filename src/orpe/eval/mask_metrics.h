// Instance mask metrics: per-frame IoU of predicted vs ground-truth instance masks, per class and
// overall (used by `orpe eval masks` and the semantic stage's tests).
//
// An image's instances are a label image (0 = no instance, v > 0 = instance v) plus the class of
// each label value. Per frame, predicted instances are matched one-to-one to ground-truth instances
// of the same class, greedily by largest IoU (ties by gt label, then predicted label), a match
// needing IoU > min_match_iou (with class_agnostic_matching, instances of any class match, and an
// instance's row keeps its ground-truth class). A ground-truth instance without a match scores IoU
// 0; a predicted instance without a match is a false positive. Ground-truth instances smaller than
// min_gt_area_px take part in the matching but are not scored (too little of the object is
// visible to judge a mask). Two summaries:
//  - instance IoU: the mean over ground-truth instances of their matched IoU (per class and all),
//    with misses counted as 0, and the mean over matched instances only;
//  - pixel (semantic) IoU per class, accumulated over all frames: TP / (TP + FP + FN), where a
//  pixel
//    is TP for class c when both images give it class c. "ALL" pools the pixels of every class, and
//    the mean of the per-class values is reported as mIoU.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "orpe/core/image.h"

namespace orpe {

struct MaskMetricsParams {
  double min_match_iou = 0.0;  ///< a prediction matches a ground-truth instance only above this IoU
  bool class_agnostic_matching = false;  ///< match instances whatever their classes
  int min_gt_area_px = 0;  ///< ground-truth instances with fewer pixels are not scored

  template <class V>
  void visit(V&& v) {
    v("min_match_iou", min_match_iou,
      "Instance matching: a prediction matches a ground-truth instance of its class only if IoU > "
      "this (0 = any overlap)");
    v("class_agnostic_matching", class_agnostic_matching,
      "Instance matching ignores the classes (mask quality alone; rows keep the ground-truth "
      "class); pixel IoU stays per class");
    v("min_gt_area_px", min_gt_area_px,
      "Ground-truth instances with fewer visible pixels than this are not scored (0 = all)");
  }
  bool IsValid(std::string* why) const;
};

/// label value (> 0) -> class id.
using LabelClasses = std::map<std::int32_t, int>;

struct MaskInstanceIoU {
  int class_id = 0;
  std::int32_t gt_label = 0;
  std::int32_t pred_label = 0;  ///< 0 when missed
  double iou = 0;
  size_t gt_pixels = 0;
};

struct PixelCounts {
  size_t true_positive = 0, false_positive = 0, false_negative = 0;
  double iou() const;  ///< 0 when the class appears in neither image
};

struct MaskFrameResult {
  std::vector<MaskInstanceIoU> instances;  ///< one per scored ground-truth instance, by gt label
  size_t false_positive_instances = 0;
  std::map<int, PixelCounts> class_pixels;  ///< classes present in either image
  double mean_iou = 0;                      ///< over `instances`; 0 when there are none
};

/// Scores one frame. Throws std::invalid_argument when the images differ in size or a non-zero
/// label value has no class.
MaskFrameResult evaluate_instance_masks(const LabelImage& gt_labels, const LabelClasses& gt_classes,
                                        const LabelImage& pred_labels,
                                        const LabelClasses& pred_classes,
                                        const MaskMetricsParams& params = {});

struct MaskClassSummary {
  int class_id = 0;  ///< -1 for "ALL"
  std::string name;
  size_t gt_instances = 0;
  size_t matched = 0;
  double mean_instance_iou = 0;  ///< over gt instances, misses count 0
  double mean_matched_iou = 0;   ///< over matched gt instances only (0 when none matched)
  PixelCounts pixels;
  double pixel_iou = 0;
};

struct MaskEvaluation {
  size_t frames = 0;
  size_t false_positive_instances = 0;
  std::vector<MaskClassSummary> classes;  ///< by class id, classes with gt instances or predictions
  MaskClassSummary all;
  double mean_class_pixel_iou = 0;  ///< mIoU over `classes`
  std::vector<double> frame_mean_iou;

  std::string report() const;
  std::string to_json() const;
};

/// Accumulates frames into per-class and overall figures.
class MaskEvaluator {
 public:
  explicit MaskEvaluator(const MaskMetricsParams& params = {});
  const MaskFrameResult& add_frame(const LabelImage& gt_labels, const LabelClasses& gt_classes,
                                   const LabelImage& pred_labels, const LabelClasses& pred_classes);
  const std::vector<MaskFrameResult>& frames() const { return frames_; }
  MaskEvaluation summary(const std::map<int, std::string>& class_names = {}) const;

 private:
  MaskMetricsParams params_;
  std::vector<MaskFrameResult> frames_;
};

}  // namespace orpe
