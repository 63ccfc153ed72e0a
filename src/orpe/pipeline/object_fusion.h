// Per-object fusion of single-view poses as the pipeline runs it: the pose stage's PoseEkf, started
// from a consensus of the first measurements instead of blindly from the first one.
//
// Why: a geometry-only single-view estimator now and then returns a pose flipped end over end or
// turned about a near-symmetry axis. The EKF gates measurements against its state, so a wrong first
// measurement would lock the filter; PoseEkf's restart (reinit_after_rejections consecutive, mutually
// consistent rejections) does not fire when the later measurements scatter about a near-symmetry.
// With init_views = k > 1 the first k valid measurements are buffered; the filter starts from the one
// that the most others agree with (PoseEkf's gate), then takes the others in order (its gate drops
// the outliers). Ties in support go to the smallest summed (gate-truncated) Mahalanobis distance to
// the others. If no two of the first k agree, the buffer grows (up to 2k) until some pair does.
// Until then there is no fused estimate. k = 1 is the paper's behaviour.
// The filter is a MultiHypothesisPoseEkf: with pose_ekf.hypotheses > 1 the consensus start's
// outliers (and later views no hypothesis explains) start competing hypotheses instead of being
// dropped, and the reported state is the best-supported one (docs/PIPELINE.md).
#pragma once

#include <optional>
#include <vector>

#include "orpe/pose/multi_hypothesis_ekf.h"
#include "orpe/pose/pose_ekf.h"

namespace orpe {

class ObjectPoseFusion {
 public:
  ObjectPoseFusion(const PoseEkfParams& params, const ObjectSymmetry& symmetry, int init_views = 1);

  struct Outcome {
    bool accepted = false;     ///< fused into the state (or buffered for the initialisation)
    bool initialised = false;  ///< this measurement completed the (consensus) initialisation
    bool switched = false;     ///< the report moved to another mode (M = 1: the filter restarted)
  };
  /// Adds one valid single-view measurement (`score`: its confidence, averaged into score()).
  Outcome add(const PoseMeasurement& measurement, double score);

  /// End of the sequence: starts the filter from the buffered measurements when fewer than
  /// init_views arrived (an object seen a few times still gets a fused pose).
  void flush();
  /// The world frame moved (a SLAM loop closure): the filter and the buffered views follow C.
  void apply_world_correction(const SE3& C) {
    ekf_.apply_world_correction(C);
    for (auto& b : buffer_) b.first.T_world_cam = C * b.first.T_world_cam;
  }

  bool has_estimate() const { return ekf_.initialised(); }
  const SE3& T_world_obj() const { return ekf_.T_world_obj(); }
  SE3 T_cam_obj(const SE3& T_world_cam) const { return ekf_.T_cam_obj(T_world_cam); }
  /// The filter's result; num_rejected also counts the initialisation's outliers.
  FusedObjectPose result() const;
  /// Mean score of the measurements in the current (reported) state (0 before the first).
  double score() const { return ekf_.mean_score(); }
  /// Measurements in the current (reported) state.
  int accepted() const { return ekf_.num_fused(); }
  const MultiHypothesisPoseEkf& filter() const { return ekf_; }
  int rejected() const { return rejected_; }

 private:
  bool initialise_from_buffer(bool need_support = false);

  PoseEkfParams params_;
  ObjectSymmetry symmetry_;
  int init_views_;
  MultiHypothesisPoseEkf ekf_;
  std::vector<std::pair<PoseMeasurement, double>> buffer_;
  int rejected_ = 0;
};

}  // namespace orpe
