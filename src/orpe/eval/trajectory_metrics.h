// Camera trajectory metrics: ATE and RPE, as defined by the TUM RGB-D benchmark and evo.
//
// Ground truth Q_i and estimate P_i are T_world_cam poses (camera-to-world, metres), one per
// timestamp.
//  - Association (TUM associate.py): every (gt, est) timestamp pair with |t_gt - t_est| <
//  max_difference
//    is a candidate; candidates are taken greedily by smallest difference (ties by gt stamp, then
//    est stamp), each timestamp used at most once. Matches are ordered by gt timestamp. As in TUM's
//    dict based reader, a timestamp repeated within one trajectory keeps its last pose.
//  - ATE (TUM evaluate_ate.py / evo APE translation): the estimated positions are aligned onto the
//    ground-truth positions by the least-squares rigid motion (Horn / Umeyama; optionally a
//    similarity, Umeyama's scale), and the errors are the distances ||q_i - (s R p_i + t)||.
//  - RPE (evo RPE, Sturm et al.): with a fixed frame delta d over the associated pairs,
//    E_i = (Q_i^-1 Q_{i+d})^-1 (P_i^-1 P_{i+d}); translation error ||trans(E_i)|| (m), rotation
//    error angle(rot(E_i)) (deg). Pairs (i, i+d) for every i (TUM evaluate_rpe --fixed_delta, evo
//    --all_pairs), or, with all_pairs off, (0, d), (d, 2d), ... (evo's default).
#pragma once

#include <string>
#include <vector>

#include "orpe/core/se3.h"
#include "orpe/io/dataset.h"

namespace orpe {

struct TrajectoryMetricsParams {
  double max_time_difference_s = 0.02;  ///< association window (strict <), TUM's default
  bool align_scale = false;             ///< Sim(3) alignment (monocular estimates); rigid otherwise
  int rpe_delta_frames = 1;             ///< RPE frame delta d (in associated pairs)
  bool rpe_all_pairs = true;            ///< every i (TUM); false = i = 0, d, 2d, ... (evo default)

  template <class V>
  void visit(V&& v) {
    v("max_time_difference_s", max_time_difference_s,
      "Association: max |t_gt - t_est| (s, strict), as TUM associate.py (0.02)");
    v("align_scale", align_scale,
      "ATE alignment with scale (Umeyama Sim3, for monocular estimates); false = rigid (TUM)");
    v("rpe_delta_frames", rpe_delta_frames, "RPE frame delta d over the associated pairs (>= 1)");
    v("rpe_all_pairs", rpe_all_pairs,
      "RPE over every pair (i, i+d) (TUM --fixed_delta, evo --all_pairs); false = i = 0, d, 2d, "
      "...");
  }
  bool IsValid(std::string* why) const;
};

/// One associated pair: indices into the ground-truth and the estimated input lists.
struct TimestampMatch {
  size_t gt_index = 0;
  size_t est_index = 0;
};

/// TUM associate.py (offset 0). Requires max_difference_s > 0 and finite stamps.
std::vector<TimestampMatch> associate_timestamps(const std::vector<double>& gt_stamps_s,
                                                 const std::vector<double>& est_stamps_s,
                                                 double max_difference_s);

/// q ~ scale * R * p + t, mapping estimated positions p onto ground-truth positions q.
struct SimilarityAlignment {
  Mat3 R = Mat3::Identity();
  Vec3 t = Vec3::Zero();
  double scale = 1.0;
  Vec3 apply(const Vec3& p) const { return scale * (R * p) + t; }
};

/// Least-squares alignment of `est` onto `gt` (same size, >= 1 point) by SVD of the
/// cross-covariance (Umeyama 1991; the rotation is TUM evaluate_ate.py's). Scale as Umeyama when
/// `with_scale`, else 1. Degenerate inputs (fewer than 3 non-collinear points) give one of the
/// equally good rotations; the residual norms do not depend on which.
SimilarityAlignment align_umeyama(const std::vector<Vec3>& est, const std::vector<Vec3>& gt,
                                  bool with_scale);

/// Summary statistics of a list of errors (numpy's conventions: population std, median of an even
/// count is the mean of the two middle values). All zero when `count` is 0.
struct ErrorStats {
  size_t count = 0;
  double rmse = 0, mean = 0, median = 0, std = 0, min = 0, max = 0;
};
ErrorStats compute_error_stats(const std::vector<double>& errors);

struct AteResult {
  SimilarityAlignment alignment;
  ErrorStats translation_m;
  std::vector<double> errors_m;  ///< per associated pair, in match order
};

struct RpeResult {
  int delta_frames = 1;
  bool all_pairs = true;
  ErrorStats translation_m;
  ErrorStats rotation_deg;
};

struct TrajectoryEvaluation {
  size_t gt_poses = 0;  ///< input sizes
  size_t est_poses = 0;
  std::vector<TimestampMatch> matches;
  bool scale_aligned = false;
  AteResult ate;
  RpeResult rpe;  ///< count 0 when there are not more than d pairs

  /// Multi-line human-readable summary.
  std::string report() const;
  /// JSON object with the figures (not the per-pair errors).
  std::string to_json() const;
};

/// Associates, aligns, and computes ATE and RPE. Throws ConfigError for invalid params. With no
/// associated pair the result has empty `matches` and zero counts (callers report that as an
/// error).
TrajectoryEvaluation evaluate_trajectory(const std::vector<StampedPose>& gt,
                                         const std::vector<StampedPose>& est,
                                         const TrajectoryMetricsParams& params);

}  // namespace orpe
