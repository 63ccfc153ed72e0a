// The per-frame instance masks of a run and their evaluation (`orpe eval masks`): the paper's Fig.
// 2 claim, measured — are the masks projected from the map better than the detections that built
// it?
//
// Files (written by `orpe run --write-masks`, semantic/mask_output.h), in a folder OUT/masks/:
//   index.json                 {"format": "orpe-masks-1", "dataset": {"path", "format", "scene"},
//                               "mask_threshold": 0.5, "frames": [{"frame": 12, "name": "...",
//                               "input": {"file": "000012_input.png", "classes": {"1": 5, ...}},
//                               "projected": {"file": "000012_projected.png", "classes": {...}}}]}
//   NNNNNN_input.png           16-bit label image of the frame's detections (value d + 1 = the d-th
//                              detection, where its probability >= mask_threshold and is the
//                              highest)
//   NNNNNN_projected.png       16-bit label image of the map's confirmed instances rendered at the
//                              frame's tracked pose after the frame was fused (value = instance id)
// "classes" maps each label value to its class: the detection's class, or the instance's argmax
// class at that frame. Frames are the segmented keyframes; "frame" is the dataset's frame number
// (RgbdFrame::index).
//
// Evaluation: per frame, both label images against the dataset's ground-truth labels (YCB-Video
// label.png, BOP mask_visib) with MaskEvaluator (eval/mask_metrics.h), per class and overall.
// With the run's final instance table (instances.json), also the instance checks: each surviving
// instance is owned by the ground-truth object it overlaps most in the projected images (summed
// over frames; background counts as an owner, and an instance owned by background is spurious);
// every object should own exactly one instance, whose final argmax class is the object's class.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "orpe/eval/mask_metrics.h"

namespace orpe {

class DatasetReader;

struct MaskRunImage {
  std::string file;      ///< relative to the masks folder
  LabelClasses classes;  ///< label value -> class
};

struct MaskRunFrame {
  int frame_index = 0;  ///< the dataset's frame number
  std::string name;     ///< the frame's name, for messages
  MaskRunImage input, projected;
};

struct MaskRunIndex {
  std::string dataset_path, dataset_format, dataset_scene;
  double mask_threshold = 0.5;
  std::vector<MaskRunFrame> frames;
};

/// index.json text / file (atomic). Throws IoError naming the file on a write error.
std::string mask_run_index_json(const MaskRunIndex& index);
void write_mask_run_index(const std::string& path, const MaskRunIndex& index);
/// Reads index.json. Throws IoError naming the file and the problem (missing, not JSON, wrong
/// format tag, a field missing or of the wrong type).
MaskRunIndex read_mask_run_index(const std::string& path);

/// instance id -> final argmax class, from a run's instances.json. Throws IoError.
std::map<int, int> read_instance_classes(const std::string& instances_json_path);

struct MaskObjectRow {
  int object_instance_id = 0;  ///< ObjectGroundTruth::instance_id
  int class_id = 0;
  std::vector<int> instances;  ///< surviving map instances it owns, most overlapping first
  int argmax_class = 0;        ///< final class of its largest owned instance (0 if none)
};

struct MaskInstanceChecks {
  std::vector<MaskObjectRow> objects;   ///< every ground-truth object of the evaluated frames
  std::vector<int> spurious_instances;  ///< surviving instances owned by background
  std::vector<int> unseen_instances;    ///< surviving instances never in a projected image
  int objects_with_exactly_one_instance = 0;
  int objects_with_correct_class = 0;  ///< exactly one instance, right argmax class
};

struct MaskRunEvaluation {
  MaskEvaluation input;      ///< the detections (all runs pooled)
  MaskEvaluation projected;  ///< the map's projected masks (all runs pooled)
  /// Per run with an instance table: (run name, checks). Object ids are per run.
  std::vector<std::pair<std::string, MaskInstanceChecks>> instances;
  MaskMetricsParams params;
  /// Totals of `instances` over the runs.
  int objects() const;
  int objects_with_exactly_one_instance() const;
  int objects_with_correct_class() const;
  int spurious_instances() const;

  std::string report() const;
  std::string to_json() const;
};

/// Pools the frames of one or more runs (e.g. one per video) into one evaluation.
class MaskRunEvaluator {
 public:
  /// Throws ConfigError for invalid params.
  explicit MaskRunEvaluator(const MaskMetricsParams& params = {});
  /// Scores every frame of `index` (files under `masks_dir`) against `reader`'s ground truth
  /// (frames found by their frame number). `final_instance_classes`: the run's final instances
  /// (instance checks of this run), or nullptr. `name` labels the run in the report. Throws IoError
  /// naming the file for a missing / unreadable / wrong-size image, a label value without a class,
  /// or a frame the dataset does not have or has no labels for; nothing is added then.
  void add_run(const DatasetReader& reader, const std::string& masks_dir, const MaskRunIndex& index,
               const std::map<int, int>* final_instance_classes = nullptr,
               const std::string& name = "");
  MaskRunEvaluation result() const;

 private:
  MaskMetricsParams params_;
  MaskEvaluator input_, projected_;
  std::map<int, std::string> class_names_;
  std::vector<std::pair<std::string, MaskInstanceChecks>> checks_;
};

/// One run: MaskRunEvaluator with a single add_run.
MaskRunEvaluation evaluate_mask_run(const DatasetReader& reader, const std::string& masks_dir,
                                    const MaskRunIndex& index, const MaskMetricsParams& params,
                                    const std::map<int, int>* final_instance_classes = nullptr);

/// The instance checks alone, from per-frame (ground-truth labels, object instance id of each gt
/// label, projected labels). Exposed for tests; evaluate_mask_run accumulates the same.
class MaskInstanceOwnership {
 public:
  /// `gt_objects`: gt label value -> ObjectGroundTruth::instance_id; `gt_classes`: -> class.
  void add_frame(const LabelImage& gt_labels, const std::map<std::int32_t, int>& gt_objects,
                 const LabelClasses& gt_classes, const LabelImage& projected);
  MaskInstanceChecks result(const std::map<int, int>& final_instance_classes) const;

 private:
  std::map<int, int> object_class_;                      // object instance id -> class
  std::map<int, std::map<int, long>> instance_overlap_;  // instance -> object (0 = bg) -> px
};

}  // namespace orpe
