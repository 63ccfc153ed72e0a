// BOP 2019-2023 average recall (AR) of 6D pose estimates, as bop_toolkit's eval_bop19_pose.py
// computes it (docs/EVALUATION.md, "BOP metrics"):
//  - targets: per image and object, the instances at least min_visible_fraction visible
//    (visib_fract of scene_gt_info.json; BOP: 10 %), or the counts of a test_targets_bop19.json;
//  - per image and object, the inst_count highest-scoring estimates are kept; each is matched
//    greedily (by decreasing score) to the not yet matched target of its object with the smallest
//    error below the threshold (strictly);
//  - recall = matched targets / targets; AR_VSD = mean recall over tau in {0.05..0.5} x diameter
//  and
//    thresholds {0.05..0.5}; AR_MSSD over thresholds {0.05..0.5} x diameter; AR_MSPD over
//    {5..50} x width / 640 pixels; AR = (AR_VSD + AR_MSSD + AR_MSPD) / 3.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "orpe/core/camera.h"
#include "orpe/core/image.h"
#include "orpe/core/se3.h"
#include "orpe/eval/pose_metrics.h"
#include "orpe/io/bop_results.h"

namespace orpe {

struct BopPoseMetricsParams {
  double vsd_delta_m = 0.015;         ///< BOP: 15 mm (5 mm for ITODD)
  double min_visible_fraction = 0.1;  ///< BOP: 0.1
  double max_sym_disc_step = 0.01;    ///< BOP: 0.01
  int threads = 0;                    ///< 0 = OpenMP default

  template <class V>
  void visit(V&& v) {
    v("vsd_delta_m", vsd_delta_m, "VSD visibility tolerance (m); BOP: 0.015 (0.005 for ITODD)");
    v("min_visible_fraction", min_visible_fraction,
      "Targets are instances at least this visible (visib_fract); BOP: 0.1");
    v("max_sym_disc_step", max_sym_disc_step,
      "Continuous symmetries discretised so that points move at most this fraction of the "
      "diameter per step; BOP: 0.01");
    v("threads", threads, "Threads computing the errors; 0 = OpenMP default");
  }
  bool IsValid(std::string* why) const;
};

/// BOP19's thresholds: VSD taus and every correctness threshold as fractions (of the diameter; MSPD
/// in pixels at width 640).
const std::vector<double>& bop_vsd_taus();
const std::vector<double>& bop_fraction_thresholds();  ///< VSD and MSSD: 0.05, 0.10, ..., 0.50
const std::vector<double>& bop_mspd_thresholds_px();   ///< 5, 10, ..., 50

/// Errors of one estimate against one ground-truth instance of its object in its image.
struct BopPoseErrors {
  std::vector<double> vsd;  ///< per tau of bop_vsd_taus()
  double mssd_m = 0;
  double mspd_px = 0;
};

/// One estimate kept for matching and its errors against the image's instances of its object.
struct BopEstimate {
  int scene_id = 0, im_id = 0, obj_id = 0;
  double score = 0;
  std::map<int, BopPoseErrors> errors;  ///< ground-truth index in the image -> errors
};

/// One ground-truth instance (index `gt_index` within its image's list).
struct BopTarget {
  int scene_id = 0, im_id = 0, obj_id = 0, gt_index = 0;
  bool valid = true;  ///< a target (visible enough); invalid instances cannot be matched
};

struct BopRecalls {
  std::vector<double> vsd;   ///< per (tau, threshold), tau-major
  std::vector<double> mssd;  ///< per threshold
  std::vector<double> mspd;  ///< per threshold
  double ar_vsd = 0, ar_mssd = 0, ar_mspd = 0, ar = 0;
};

struct BopPoseEvaluation {
  BopPoseMetricsParams params;
  BopRecalls all;
  std::map<int, BopRecalls> per_object;      ///< obj_id -> recalls of its targets
  std::map<int, size_t> targets_per_object;  ///< obj_id -> targets
  std::map<int, std::string> class_names;
  size_t targets = 0;
  size_t estimates = 0;        ///< estimates kept (top inst_count per image and object)
  size_t result_rows = 0;      ///< rows read
  std::string targets_source;  ///< "visib_fract >= x" or the targets file

  std::string report() const;  ///< aligned text table (AR in percent)
  std::string to_json() const;
};

/// Recalls of already computed errors: the matching and averaging above. `image_width_px` per
/// scene id (MSPD normalisation), `diameters_m` per obj_id (VSD taus and MSSD thresholds).
BopRecalls bop_recalls(const std::vector<BopTarget>& targets,
                       const std::vector<BopEstimate>& estimates,
                       const std::map<int, double>& diameters_m,
                       const std::map<int, int>& image_width_px);

/// The whole evaluation on datasets in BOP layout (models_info.json beside the models; test depth
/// for VSD from the frames). Rows match (scene_id, im_id, obj_id). A test_targets_bop19.json in the
/// dataset root (or one or two levels above a scene folder) replaces the visibility rule. Throws
/// IoError naming the file for a dataset without models_info.json, a malformed file or a class
/// without a model.
BopPoseEvaluation evaluate_bop_pose_results(const std::vector<const DatasetReader*>& readers,
                                            const std::vector<PoseResultRow>& rows,
                                            const BopPoseMetricsParams& params,
                                            const FrameSet* only_frames = nullptr);

}  // namespace orpe
