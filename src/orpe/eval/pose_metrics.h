// 6D object pose metrics as in the YCB-Video toolbox (PoseCNN) and DenseFusion's tables.
//
// With ground truth (R, t) = T_cam_obj_gt, estimate (R', t') = T_cam_obj_est and the model points x
// (YCB: points.xyz, metres, in the object frame):
//   ADD   = mean_x || (R' x + t') - (R x + t) ||
//   ADD-S = mean_x min_y || (R x + t) - (R' y + t') ||     (closest estimated point per true point)
//   ADD(-S) = ADD-S for symmetric classes, ADD otherwise.
// AUC (YCB-Video toolbox VOCap, max distance 0.1 m): one distance per ground-truth instance, a
// missed instance is +inf; distances above the maximum become +inf; sort; accuracy_k = k / n over
// all n instances; mrec = [0; d_finite; max], mpre = [0; acc; acc_last], running max of mpre, area
// sum_i (mrec_i - mrec_{i-1}) mpre_i over the points where mrec changes, divided by max, x100.
// Closed form (derived in docs/EVALUATION.md, checked in tests):
//   AUC = (100 / n) [ sum_{d_k <= max} (1 - d_k / max) + d_largest_finite / max ].
// "< 2 cm" = fraction of instances with d < 0.02 m.
#pragma once

#include <map>
#include <memory>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "orpe/core/se3.h"
#include "orpe/io/bop_results.h"

namespace orpe {

class DatasetReader;

struct PoseMetricsParams {
  double auc_max_distance_m = 0.1;     ///< YCB-Video: 0.1
  double accuracy_threshold_m = 0.02;  ///< the "< 2 cm" column
  double min_visible_fraction = 0.0;   ///< skip ground-truth instances less visible than this

  template <class V>
  void visit(V&& v) {
    v("auc_max_distance_m", auc_max_distance_m,
      "AUC of the accuracy-threshold curve up to this distance (m); YCB-Video toolbox: 0.1");
    v("accuracy_threshold_m", accuracy_threshold_m,
      "Report the fraction of instances with distance below this (m); YCB-Video: 0.02");
    v("min_visible_fraction", min_visible_fraction,
      "Evaluate only ground-truth instances at least this visible (BOP: 0.1; instances of unknown "
      "visibility are always kept); 0 = all, also objects outside the view");
  }
  bool IsValid(std::string* why) const;
};

/// Model points with a kd-tree for the closest-point queries of ADD-S. Built once per class.
class ModelPoints {
 public:
  /// Throws std::invalid_argument for an empty point set.
  explicit ModelPoints(std::vector<Vec3> points_obj);
  ~ModelPoints();
  ModelPoints(ModelPoints&&) noexcept;
  ModelPoints& operator=(ModelPoints&&) noexcept;

  const std::vector<Vec3>& points() const { return points_obj_; }
  /// Distance (m) from q (object frame) to the closest model point.
  double closest_distance(const Vec3& q_obj) const;

 private:
  struct Tree;
  std::vector<Vec3> points_obj_;
  std::unique_ptr<Tree> tree_;
};

double add_distance(const std::vector<Vec3>& points_obj, const SE3& T_cam_obj_gt,
                    const SE3& T_cam_obj_est);
double adds_distance(const ModelPoints& model, const SE3& T_cam_obj_gt, const SE3& T_cam_obj_est);
/// Brute-force ADD-S (O(N^2)), the kd-tree's reference in tests.
double adds_distance_brute_force(const std::vector<Vec3>& points_obj, const SE3& T_cam_obj_gt,
                                 const SE3& T_cam_obj_est);

/// The YCB-Video toolbox's VOCap area, in percent (0..100). `distances`: one per ground-truth
/// instance, +inf (or NaN) for a miss. 0 when there are no instances or no finite distance.
double ycb_auc_percent(const std::vector<double>& distances_m, double max_distance_m = 0.1);
/// Fraction (0..1) of the distances strictly below `threshold_m`; 0 for an empty list.
double fraction_below(const std::vector<double>& distances_m, double threshold_m);

/// The score of one ground-truth instance.
struct PoseInstanceScore {
  int scene_id = 0;
  int im_id = 0;
  int class_id = 0;
  bool estimated = false;  ///< false: missed (the distances are +inf)
  double score = 0;        ///< the estimate's confidence
  double add_m = 0;
  double adds_m = 0;
  bool symmetric = false;
  double add_or_adds_m() const { return symmetric ? adds_m : add_m; }
};

/// Figures of one class (or of all instances pooled).
struct PoseClassSummary {
  int class_id = 0;  ///< -1 for the pooled "ALL" row
  std::string name;
  bool symmetric = false;
  size_t instances = 0;
  size_t estimated = 0;
  double adds_auc = 0;     ///< percent
  double add_s_auc = 0;    ///< ADD(-S), percent
  double add_auc = 0;      ///< plain ADD for every class, percent
  double adds_below = 0;   ///< fraction of instances with ADD-S < accuracy_threshold_m
  double add_s_below = 0;  ///< same with ADD(-S)
  double adds_mean_m = 0;  ///< mean ADD-S over the estimated instances (0 if none)
};

struct PoseEvaluation {
  PoseMetricsParams params;
  std::vector<PoseClassSummary> classes;  ///< sorted by class id
  PoseClassSummary all;
  std::vector<PoseInstanceScore> instances;
  size_t result_rows = 0;       ///< rows read
  size_t unmatched_rows = 0;    ///< rows with no ground-truth instance (ignored, as the toolbox)
  size_t other_scene_rows = 0;  ///< rows whose scene_id is not an evaluated scene

  std::string report() const;    ///< aligned text table
  std::string markdown() const;  ///< Markdown table
  std::string to_json() const;
};

/// Per-class and pooled summaries of instance scores. `class_names` may omit classes (the id is
/// used).
PoseEvaluation summarize_pose_scores(std::vector<PoseInstanceScore> instances,
                                     const std::map<int, std::string>& class_names,
                                     const PoseMetricsParams& params);

/// One ground-truth instance to score.
struct PoseGroundTruthInstance {
  int scene_id = 0;
  int im_id = 0;
  int class_id = 0;
  SE3 T_cam_obj;
};

/// Scores results against ground truth. Rows match instances by (scene_id, im_id, obj_id = class
/// id). When an image holds k instances of a class, the k highest-scoring rows of that class are
/// matched one-to-one, greedily by smallest ADD-S (k = 1: the highest-scoring row). Instances
/// without a row are misses. `models` must hold every class that has a ground-truth instance
/// (std::invalid_argument otherwise).
PoseEvaluation evaluate_pose_results(const std::vector<PoseGroundTruthInstance>& ground_truth,
                                     const std::vector<PoseResultRow>& rows,
                                     const std::map<int, ModelPoints>& models,
                                     const std::vector<int>& symmetric_classes,
                                     const std::map<int, std::string>& class_names,
                                     const PoseMetricsParams& params);

/// (scene_id, im_id) pairs to evaluate, e.g. the YCB-Video test keyframes.
using FrameSet = std::set<std::pair<int, int>>;

/// Reads a YCB-Video keyframe list (`keyframe.txt`: one `SSSS/NNNNNN` per line, video and frame
/// number). Throws IoError naming the file and line for a malformed line or an empty list.
FrameSet read_keyframe_list(const std::string& path);

/// Reads the objects_gt of every frame of every reader (scene_id from DatasetInfo, im_id =
/// frame.index), keeping only the frames in `only_frames` when it is given, loads the model points
/// of the classes present (DatasetInfo.model_points_paths: .xyz text or PLY vertices, divided by
/// model_units_per_m; class
/// names and symmetric classes from the first reader that has them), and scores `rows`.
/// Throws IoError naming the file for an unreadable frame or model, a class without model points,
/// or a dataset without object models.
PoseEvaluation evaluate_pose_results(const std::vector<const DatasetReader*>& readers,
                                     const std::vector<PoseResultRow>& rows,
                                     const PoseMetricsParams& params,
                                     const FrameSet* only_frames = nullptr);
PoseEvaluation evaluate_pose_results(const DatasetReader& reader,
                                     const std::vector<PoseResultRow>& rows,
                                     const PoseMetricsParams& params,
                                     const FrameSet* only_frames = nullptr);

}  // namespace orpe
