// Per-object fusion with a few competing EKF hypotheses (pose_ekf.hypotheses = M > 1).
//
// Why: a geometry-only single-view estimator returns, for some objects, two modes of the pose
// (a mug with its handle hidden turned about its axis, a textureless box flipped). One PoseEkf
// keeps the mode it started in: its gate drops the other mode's views, and its restart needs
// `reinit_after_rejections` *consecutive* consistent rejections, which never come when the modes
// interleave. Here each hypothesis is the paper's EKF (PoseEkf: R = mu I, SE(3) update, gate,
// symmetry snap); a measurement updates every hypothesis whose gate it passes, and one that passes
// none starts a new hypothesis (evicting the one with the least evidence, never the reported one,
// when M exist). Hypotheses whose states pass each other's gate are merged (the one with more
// evidence stays), so one mode is one hypothesis.
//
// Evidence of a hypothesis: the views that passed its gate, each weighted (`kernel`, default) by
// 1 - d2 / gate_chi2 of its Mahalanobis distance d2 (an Epanechnikov kernel: a tight cluster of
// views is a mode, views scattered to the edge of the gate are weak support), or 1 each (`count`);
// each view first multiplies every hypothesis's evidence by `hypothesis_evidence_decay`. A view's
// contribution is multiplied by its PoseMeasurement::mode_weight: views whose colour singled out
// their pose among the confusable ones (pose_ekf.colour_evidence_gain) count more than views whose
// geometry alone could not tell the modes apart. The
// reported state is the hypothesis with the most evidence, but the report moves only when another
// hypothesis leads the reported one by more than `hypothesis_switch_margin` views: with two modes
// supported equally (alternating views) the lead is below one view at any decay (1 / (1 + decay)),
// so a margin >= 1 keeps the report where it is instead of flipping each frame.
//
// hypotheses = 1 is exactly PoseEkf (with its restart).
#pragma once

#include <vector>

#include "orpe/pose/pose_ekf.h"

namespace orpe {

class MultiHypothesisPoseEkf {
 public:
  /// Throws ConfigError for invalid params.
  explicit MultiHypothesisPoseEkf(const PoseEkfParams& params = {},
                                  const ObjectSymmetry& symmetry = {});

  bool initialised() const { return reported_ >= 0; }
  /// Every hypothesis follows a correction of the world frame (PoseEkf::apply_world_correction).
  void apply_world_correction(const SE3& C) {
    for (auto& h : hypotheses_) h.ekf.apply_world_correction(C);
  }
  /// Static model on every hypothesis.
  void predict();
  /// Fuses one measurement; `score` (the estimator's confidence) is averaged per hypothesis.
  /// The step's `accepted`: the measurement is in the reported hypothesis after this step;
  /// `reinitialised`: the report moved to another hypothesis (or, M = 1, the filter restarted).
  PoseEkfStep update(const PoseMeasurement& measurement, double score = 1.0);

  /// The reported hypothesis (undefined before the first measurement).
  const SE3& T_world_obj() const { return reported().ekf.T_world_obj(); }
  const Mat6& covariance() const { return reported().ekf.covariance(); }
  SE3 T_cam_obj(const SE3& T_world_cam) const { return reported().ekf.T_cam_obj(T_world_cam); }
  /// Views in the reported hypothesis and the mean of their scores (0 before the first).
  int num_fused() const { return initialised() ? reported().views : 0; }
  double mean_score() const {
    return initialised() && reported().views > 0 ? reported().score_sum / reported().views : 0.0;
  }
  /// The reported hypothesis's state; num_rejected = measurements that are not in it,
  /// num_reinitialisations = report switches (M = 1: restarts); history = one step per update.
  FusedObjectPose result() const;

  struct HypothesisSummary {
    SE3 T_world_obj;
    double evidence = 0;
    int views = 0;
    bool reported = false;
  };
  std::vector<HypothesisSummary> hypotheses() const;
  int num_hypotheses() const { return static_cast<int>(hypotheses_.size()); }

 private:
  struct Hypothesis {
    PoseEkf ekf;
    double evidence = 0;
    double score_sum = 0;
    int views = 0;
    int last_measurement = 0;  ///< number of the last measurement that joined it (1-based)
  };
  const Hypothesis& reported() const { return hypotheses_[static_cast<size_t>(reported_)]; }
  PoseEkfStep update_single(const PoseMeasurement& measurement, double score);
  void merge_duplicates();

  PoseEkfParams params_;
  PoseEkfParams
      hypothesis_params_;  ///< params_ without the restart (M > 1: a new hypothesis instead)
  ObjectSymmetry symmetry_;
  std::vector<Hypothesis> hypotheses_;
  int reported_ = -1;
  int num_measurements_ = 0;
  int num_switches_ = 0;
  std::vector<PoseEkfStep> history_;
};

}  // namespace orpe
