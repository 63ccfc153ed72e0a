// Per-object EKF on SE(3) (the paper, sec. III-B): fuses single-view poses over frames.
//
// State: T_world_obj with a 6x6 covariance P on the body-frame tangent space, ordered [rho; phi]
// (translation m, rotation rad): the true pose is T_world_obj * Exp(xi), xi ~ N(0, P).
// Static model: predict leaves the state unchanged (P += Q, Q = 0 by default as in the paper).
// Measurement: z = T_world_cam * T_cam_obj (the single-view pose moved to the world by the tracked
// camera), noise R = mu I in the paper (mu = the estimator's mean model distance); here
//   R = diag(r_translation_scale * mu^r_mu_exponent I3, r_rotation_scale * mu^r_mu_exponent I3),
// defaults 1, 1, 1 = the paper's R = mu I.
// Update: innovation nu = Log(T_world_obj^-1 z) (so +179 deg and -179 deg about one axis are 2 deg
// apart), K = P (R + P)^-1, T_world_obj <- T_world_obj Exp(K nu), P <- (I - K) P.
// Gating: a measurement with nu^T (P + R)^-1 nu > gate_chi2 is rejected. Recovery: when
// `reinit_after_rejections` consecutive rejected measurements agree with each other (pairwise test
// with the same threshold), the filter restarts from them.
// Symmetry: before the innovation, z is replaced by its equivalent z * S under the object's
// symmetry group that is closest to the state (Mahalanobis), so equivalent poses do not fight.
#pragma once

#include <string>
#include <vector>

#include "orpe/core/se3.h"
#include "orpe/pose/object_model.h"

namespace orpe {

struct PoseEkfParams {
  double r_translation_scale = 1.0;
  double r_rotation_scale = 1.0;
  double r_mu_exponent = 1.0;
  double min_mu_m = 1e-4;
  double process_noise_translation_m2 = 0.0;
  double process_noise_rotation_rad2 = 0.0;
  double gate_chi2 = 22.46;
  int reinit_after_rejections = 5;
  bool use_symmetry = true;
  bool reinit_interleaved = false;
  // Multi-hypothesis fusion (MultiHypothesisPoseEkf); 1 = the single filter above. Default 3:
  // docs/RESULTS.md, "Several hypotheses per object", has the measurements behind it.
  int hypotheses = 3;
  std::string hypothesis_evidence = "kernel";
  double hypothesis_evidence_decay = 0.95;
  double hypothesis_switch_margin = 1.0;
  double colour_evidence_gain = 4.0;

  template <class V>
  void visit(V&& v) {
    v("r_translation_scale", r_translation_scale,
      "Measurement noise, translation block: scale * mu^exponent (paper: 1)");
    v("r_rotation_scale", r_rotation_scale,
      "Measurement noise, rotation block: scale * mu^exponent (paper: 1)");
    v("r_mu_exponent", r_mu_exponent,
      "Exponent of mu in R (paper: 1, R = mu I; 2 treats mu as a std)");
    v("min_mu_m", min_mu_m, "Floor on mu (m) so that a perfect fit does not freeze the filter");
    v("process_noise_translation_m2", process_noise_translation_m2,
      "Added to the translation variances at each predict (m^2); paper: 0 (static objects)");
    v("process_noise_rotation_rad2", process_noise_rotation_rad2,
      "Added to the rotation variances at each predict (rad^2); paper: 0");
    v("gate_chi2", gate_chi2,
      "Mahalanobis gate on the innovation (chi-square, 6 dof; 22.46 = p 0.999); <= 0 disables "
      "gating");
    v("reinit_after_rejections", reinit_after_rejections,
      "Restart the filter from this many consecutive rejected but mutually consistent "
      "measurements; 0 = never");
    v("reinit_interleaved", reinit_interleaved,
      "Restart count survives accepted measurements while they do not outnumber the consistent "
      "rejections (false, default: only consecutive rejections restart)");
    v("use_symmetry", use_symmetry,
      "Replace each measurement by its symmetry-equivalent closest to the state before the update");
    v("hypotheses", hypotheses,
      "Competing filters per object (MultiHypothesisPoseEkf): a measurement that passes no "
      "hypothesis's gate starts a new one instead of being dropped; 1 = one filter with the "
      "restart above");
    v("hypothesis_evidence", hypothesis_evidence,
      "What a view that passes a hypothesis's gate adds to its evidence: `count` 1, `kernel` "
      "1 - d2 / gate_chi2 (Epanechnikov weight of its Mahalanobis distance d2: a view at the "
      "edge of the gate adds almost nothing)");
    v("hypothesis_evidence_decay", hypothesis_evidence_decay,
      "Every view first multiplies all hypotheses' evidence by this factor (1 = no forgetting)");
    v("hypothesis_switch_margin", hypothesis_switch_margin,
      "The reported hypothesis changes only when another one's evidence exceeds its own by more "
      "than this (views; hysteresis against flipping between equally supported modes)");
    v("colour_evidence_gain", colour_evidence_gain,
      "Colour in the competition of modes: a view whose colour singled out its pose (colour "
      "lead L over the confusable poses, pose_registration.colour_*) adds 1 + gain * L times the "
      "evidence of a geometry-only view; 0 = colour ignored");
  }
  bool IsValid(std::string* why) const;
};

/// One single-view measurement of an object.
struct PoseMeasurement {
  int frame_index = 0;
  SE3 T_world_cam;  ///< tracked camera pose of the frame
  SE3 T_cam_obj;    ///< single-view estimate
  double mu_m = 0;  ///< the estimator's mean model distance (m)
  /// Evidence factor of this view for its mode (MultiHypothesisPoseEkf): 1 = a geometry-only view;
  /// the pipeline passes mode_weight_from_colour() (> 1 when colour singled the pose out).
  double mode_weight = 1.0;
};

/// 1 + gain * max(0, colour lead): the mode weight of a view with colour evidence.
inline double mode_weight_from_colour(double colour_margin, double gain) {
  return 1.0 + gain * (colour_margin > 0 ? colour_margin : 0.0);
}

/// What one update did, and the per-frame record kept in the history.
struct PoseEkfStep {
  int frame_index = 0;
  SE3 T_cam_obj_measured;    ///< as given
  SE3 T_world_obj_measured;  ///< z after the symmetry snap
  SE3 T_cam_obj_fused;       ///< the state after this step, moved into this frame's camera
  double mu_m = 0;
  double mahalanobis_sq = 0;  ///< of the innovation (0 for the first measurement)
  bool accepted = false;
  bool initialised = false;    ///< this measurement started the filter
  bool reinitialised = false;  ///< this measurement completed a restart
};

struct FusedObjectPose {
  SE3 T_world_obj;
  Mat6 covariance = Mat6::Zero();
  int num_fused = 0;  ///< measurements in the current state (since the last (re)initialisation)
  int num_rejected = 0;
  int num_reinitialisations = 0;
  std::vector<PoseEkfStep> history;
  std::string report() const;
};

class PoseEkf {
 public:
  /// Throws ConfigError for invalid params.
  explicit PoseEkf(const PoseEkfParams& params = {}, const ObjectSymmetry& symmetry = {});

  bool initialised() const { return initialised_; }
  /// Static model: state unchanged, P += Q.
  void predict();
  /// The world frame moved (a SLAM loop closure): new = C * old for the state and the pending
  /// measurements. The covariance (body-frame tangent) is unchanged.
  void apply_world_correction(const SE3& C);
  /// Fuses one measurement (R from mu). Returns the step (also appended to the history).
  PoseEkfStep update(const PoseMeasurement& measurement);

  /// The measurement covariance the filter uses for a given mu.
  Mat6 measurement_covariance(double mu_m) const;
  /// The element of z's symmetry class closest to the state (Mahalanobis with P + R). Returns z
  /// unchanged before initialisation or without symmetry.
  SE3 closest_equivalent(const SE3& T_world_obj_z, const Mat6& R) const;
  /// Innovation Log(T_world_obj^-1 z) in [rho; phi].
  Vec6 innovation(const SE3& T_world_obj_z) const;
  /// The squared Mahalanobis distance the gate of update() would see for this measurement (after
  /// the symmetry snap); 0 before initialisation.
  double gate_distance_sq(const PoseMeasurement& measurement) const;
  /// Squared Mahalanobis distance between two initialised filters' states (covariance P1 + P2,
  /// after the symmetry snap of the other's state).
  double state_distance_sq(const PoseEkf& other) const;
  int num_fused() const { return initialised_ ? num_fused_ : 0; }
  int num_reinitialisations() const { return num_reinit_; }

  const SE3& T_world_obj() const { return T_world_obj_; }
  const Mat6& covariance() const { return P_; }
  /// The fused pose in a camera: T_world_cam^-1 * T_world_obj.
  SE3 T_cam_obj(const SE3& T_world_cam) const { return T_world_cam.inverse() * T_world_obj_; }
  FusedObjectPose result() const;

 private:
  struct Pending {
    SE3 z;
    Mat6 R;
  };
  void initialise(const SE3& z, const Mat6& R);
  void fuse(const SE3& z, const Mat6& R);
  static SE3 closest_equivalent_to(const SE3& reference, const Mat6& S_inv, const SE3& z,
                                   const ObjectSymmetry& symmetry, double* d2);
  /// z's symmetry-equivalent closest to `reference` (z itself without use_symmetry) and its squared
  /// Mahalanobis distance to `reference` under S_inv: the gate's measure, everywhere it is taken.
  SE3 snap_to(const SE3& reference, const Mat6& S_inv, const SE3& z, double* d2) const;

  PoseEkfParams params_;
  ObjectSymmetry symmetry_;
  bool initialised_ = false;
  SE3 T_world_obj_;
  Mat6 P_ = Mat6::Zero();
  int num_fused_ = 0;
  int num_rejected_ = 0;
  int num_reinit_ = 0;
  std::vector<Pending>
      pending_;  ///< rejected, mutually consistent measurements (see reinit_interleaved)
  int accepted_since_pending_ = 0;
  std::vector<PoseEkfStep> history_;
};

}  // namespace orpe
