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
// With start_at_majority the buffer stops early, as soon as one buffered view has a strict majority
// of the k views behind it (itself and floor(k / 2) others passing the gate against it) and every
// buffered view was decisive (its estimator singled its pose out among the near-symmetric modes):
// the later views of the k could no longer outvote them, so the start's mode is decided; they are
// fused as any later view (the gate, the competing hypotheses). With k = 5: three agreeing decisive
// views start the filter; the pipeline then estimates the object's next views from the fused pose
// (the prior fast path) instead of two more global searches. Views that could not tell the modes
// apart (an untextured, nearly symmetric box) are votes of chance: all k of them are collected.
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
  ObjectPoseFusion(const PoseEkfParams& params, const ObjectSymmetry& symmetry, int init_views = 1,
                   bool start_at_majority = false);

  struct Outcome {
    bool accepted = false;     ///< fused into the state (or buffered for the initialisation)
    bool initialised = false;  ///< this measurement completed the (consensus) initialisation
    bool switched = false;     ///< the report moved to another mode (M = 1: the filter restarted)
  };
  /// Adds one valid single-view measurement (`score`: its confidence, averaged into score();
  /// `decisive`: the estimator singled this pose out among the object's confusable modes).
  Outcome add(const PoseMeasurement& measurement, double score, bool decisive = true);

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
  /// The buffered view the most others agree with (ties: smallest truncated Mahalanobis sum).
  struct Consensus {
    size_t best = 0;
    int support = -1;  ///< how many other buffered views pass the gate against it
  };
  Consensus consensus() const;
  bool initialise_from_buffer(bool need_support = false);
  void start_from(size_t best);

  PoseEkfParams params_;
  ObjectSymmetry symmetry_;
  int init_views_;
  bool start_at_majority_;
  MultiHypothesisPoseEkf ekf_;
  std::vector<std::pair<PoseMeasurement, double>> buffer_;
  bool buffer_decisive_ = true;  ///< every buffered view was decisive
  int rejected_ = 0;
};

}  // namespace orpe
