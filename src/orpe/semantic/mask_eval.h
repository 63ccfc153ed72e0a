// Mask evaluation of the semantic stage (the paper's Fig. 2 claim: masks rendered from the map beat
// the per-frame detections that built it), and instance-level checks of the final map.
//
// Per frame and ground-truth object (labels_gt / objects_gt):
//  - input IoU: IoU of the object's ground-truth mask with the detection matched to it;
//  - projected IoU: IoU with the map instance matched to it in the map's instance image rendered at
//    the frame's pose.
// Matching is one-to-one per frame, greedy by decreasing IoU (pairs with IoU > 0). An object
// without a match scores IoU 0 ("missed"); mean IoU is reported with misses (all) and over matched
// objects only. Objects with fewer than min_gt_area_px visible pixels are not scored.
//
// Instance level, over the whole run: each instance is owned by the ground-truth object it overlaps
// most in the rendered instance images (summed over frames); an instance whose pixels lie mostly on
// background (or on no object more than on background) is spurious. Every object should own exactly
// one instance whose argmax class is the object's class.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "orpe/core/frame.h"
#include "orpe/semantic/detection.h"
#include "orpe/semantic/semantic_fusion.h"

namespace orpe {

struct MaskIouRow {
  int class_id = 0;               ///< 0 for the overall row
  int samples = 0;                ///< (frame, object) pairs scored
  double input_miou = 0;          ///< mean IoU of the detections, misses count 0
  double projected_miou = 0;      ///< mean IoU of the map's projected masks, misses count 0
  double input_miou_matched = 0;  ///< mean over matched pairs only
  double projected_miou_matched = 0;
  int input_missed = 0, projected_missed = 0;
  int input_class_correct = 0, projected_class_correct = 0;  ///< matched with the right class
};

struct ObjectInstanceRow {
  int object_instance_id = 0;  ///< ObjectGroundTruth::instance_id
  int class_id = 0;
  std::vector<int> instances;  ///< map instances it owns
  int argmax_class = 0;        ///< of its largest owned instance (0 if none)
};

struct SemanticMaskResult {
  int frames = 0;
  MaskIouRow overall;
  std::vector<MaskIouRow> per_class;       ///< sorted by class id
  std::vector<ObjectInstanceRow> objects;  ///< per ground-truth object seen
  std::vector<int> spurious_instances;     ///< instances owned by no object
  int objects_with_exactly_one_instance = 0;
  int objects_with_correct_class = 0;  ///< exactly one instance and the right argmax class

  std::string report() const;
  std::string to_json() const;  ///< the same as JSON text
};

class SemanticMaskEvaluator {
 public:
  explicit SemanticMaskEvaluator(float mask_threshold = 0.5f, int min_gt_area_px = 100)
      : threshold_(mask_threshold), min_gt_area_px_(min_gt_area_px) {}

  /// Scores one frame. `projected_instances`: the map's instance image at the frame's pose
  /// (render_instance_labels); `instances`: the instance table (for projected classes). Frames
  /// without ground truth are skipped (returns false).
  bool add_frame(const RgbdFrame& frame, const std::vector<Detection>& detections,
                 const LabelImage& projected_instances,
                 const std::map<int, InstanceInfo>& instances);

  /// Results so far; instance-level rows use `final_instances` (after finalize()).
  SemanticMaskResult result(const std::map<int, InstanceInfo>& final_instances) const;

 private:
  struct Accum {
    int samples = 0, input_missed = 0, projected_missed = 0, input_correct = 0,
        projected_correct = 0;
    double input_sum = 0, projected_sum = 0;
  };
  float threshold_;
  int min_gt_area_px_;
  int frames_ = 0;
  std::map<int, Accum> per_class_;
  std::map<int, int> object_class_;                      // object instance id -> class
  std::map<int, std::map<int, long>> instance_overlap_;  // map instance -> object id (0 = bg) -> px
};

/// Greedy one-to-one matching by decreasing IoU: returns for each row (ground-truth object) the
/// matched column or -1, given intersections[r][c] and the areas of rows and columns. Pairs with
/// IoU 0 never match. Exposed for tests.
std::vector<int> match_by_iou(const std::vector<std::vector<long>>& intersections,
                              const std::vector<long>& row_areas,
                              const std::vector<long>& column_areas,
                              std::vector<double>* row_iou = nullptr);

}  // namespace orpe
