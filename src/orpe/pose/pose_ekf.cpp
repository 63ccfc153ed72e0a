#include "orpe/pose/pose_ekf.h"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <cmath>
#include <limits>
#include <sstream>

#include "orpe/core/error.h"

namespace orpe {

bool PoseEkfParams::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (!(r_translation_scale > 0) || !(r_rotation_scale > 0)) return fail("R scales must be > 0");
  if (!(r_mu_exponent > 0) || r_mu_exponent > 4) return fail("r_mu_exponent must be in (0, 4]");
  if (!(min_mu_m > 0)) return fail("min_mu_m must be > 0");
  if (process_noise_translation_m2 < 0 || process_noise_rotation_rad2 < 0)
    return fail("process noise must be >= 0");
  if (reinit_after_rejections < 0) return fail("reinit_after_rejections must be >= 0");
  if (!std::isfinite(gate_chi2)) return fail("gate_chi2 must be finite");
  if (hypotheses < 1 || hypotheses > 16) return fail("hypotheses must be in [1, 16]");
  if (hypotheses > 1 && !(gate_chi2 > 0))
    return fail("hypotheses > 1 needs a gate (gate_chi2 > 0) to tell the hypotheses apart");
  if (hypothesis_evidence != "count" && hypothesis_evidence != "kernel")
    return fail("hypothesis_evidence must be count or kernel, not '" + hypothesis_evidence + "'");
  if (!(colour_evidence_gain >= 0) || colour_evidence_gain > 100)
    return fail("colour_evidence_gain must be in [0, 100]");
  if (!(hypothesis_evidence_decay > 0) || hypothesis_evidence_decay > 1)
    return fail("hypothesis_evidence_decay must be in (0, 1]");
  if (!(hypothesis_switch_margin >= 0) || !std::isfinite(hypothesis_switch_margin))
    return fail("hypothesis_switch_margin must be finite and >= 0");
  return true;
}

std::string FusedObjectPose::report() const {
  std::ostringstream os;
  os.precision(4);
  const Vec3 t = T_world_obj.translation();
  os << "T_world_obj t = (" << t.x() << ", " << t.y() << ", " << t.z() << ") m, rot "
     << T_world_obj.rotation_angle_deg() << " deg; fused " << num_fused << ", rejected "
     << num_rejected << ", restarts " << num_reinitialisations << "; sigma t "
     << std::sqrt(covariance.diagonal().head<3>().mean()) << " m, sigma r "
     << std::sqrt(covariance.diagonal().tail<3>().mean()) << " rad";
  return os.str();
}

PoseEkf::PoseEkf(const PoseEkfParams& params, const ObjectSymmetry& symmetry)
    : params_(params), symmetry_(symmetry) {
  std::string why;
  if (!params_.IsValid(&why)) throw ConfigError("pose_ekf: " + why);
  if (symmetry_.continuous) {
    if (!(symmetry_.axis_obj.norm() > 1e-9)) throw ConfigError("pose_ekf: zero symmetry axis");
    symmetry_.axis_obj.normalize();
  }
}

Mat6 PoseEkf::measurement_covariance(double mu_m) const {
  const double mu = std::max(std::isfinite(mu_m) ? mu_m : 0.0, params_.min_mu_m);
  const double s = std::pow(mu, params_.r_mu_exponent);
  Mat6 R = Mat6::Zero();
  R.diagonal().head<3>().setConstant(params_.r_translation_scale * s);
  R.diagonal().tail<3>().setConstant(params_.r_rotation_scale * s);
  return R;
}

Vec6 PoseEkf::innovation(const SE3& z) const {
  return (T_world_obj_.inverse() * z).log();
}

SE3 PoseEkf::snap_to(const SE3& reference, const Mat6& S_inv, const SE3& z, double* d2) const {
  if (params_.use_symmetry) return closest_equivalent_to(reference, S_inv, z, symmetry_, d2);
  const Vec6 nu = (reference.inverse() * z).log();
  *d2 = nu.dot(S_inv * nu);
  return z;
}

double PoseEkf::gate_distance_sq(const PoseMeasurement& m) const {
  if (!initialised_) return 0;
  const Mat6 S_inv = (P_ + measurement_covariance(m.mu_m)).inverse();
  double d2 = 0;
  snap_to(T_world_obj_, S_inv, m.T_world_cam * m.T_cam_obj, &d2);
  return d2;
}

double PoseEkf::state_distance_sq(const PoseEkf& other) const {
  if (!initialised_ || !other.initialised_) return std::numeric_limits<double>::infinity();
  double d2 = 0;
  snap_to(T_world_obj_, (P_ + other.P_).inverse(), other.T_world_obj_, &d2);
  return d2;
}

void PoseEkf::predict() {
  if (!initialised_) return;
  P_.diagonal().head<3>().array() += params_.process_noise_translation_m2;
  P_.diagonal().tail<3>().array() += params_.process_noise_rotation_rad2;
}

SE3 PoseEkf::closest_equivalent_to(const SE3& reference, const Mat6& S_inv, const SE3& z,
                                   const ObjectSymmetry& symmetry, double* d2_out) {
  const SE3 ref_inv = reference.inverse();
  double best_d2 = std::numeric_limits<double>::infinity();
  SE3 best = z;
  auto consider = [&](const SE3& D) {
    SE3 candidate = z * D;
    if (symmetry.continuous) {
      // The rotation C(theta) about the axis a closest to M = R_c^T R_ref maximises
      // tr(C^T M) = cos(theta) (tr M - a^T M a) + sin(theta) a . vee(M - M^T) + const.
      const Mat3 M = candidate.rotation().transpose() * reference.rotation();
      const Vec3& a = symmetry.axis_obj;
      const Vec3 w(M(2, 1) - M(1, 2), M(0, 2) - M(2, 0), M(1, 0) - M(0, 1));
      const double theta = std::atan2(a.dot(w), M.trace() - a.dot(M * a));
      candidate = candidate * symmetry.continuous_element(theta);
    }
    const Vec6 nu = (ref_inv * candidate).log();
    const double d2 = nu.dot(S_inv * nu);
    if (d2 < best_d2) {
      best_d2 = d2;
      best = candidate;
    }
  };
  consider(SE3());
  for (const auto& D : symmetry.discrete) consider(D);
  if (d2_out) *d2_out = best_d2;
  return best;
}

SE3 PoseEkf::closest_equivalent(const SE3& z, const Mat6& R) const {
  if (!initialised_) return z;
  const Mat6 S_inv = (P_ + R).inverse();
  if (!params_.use_symmetry) return z;
  return closest_equivalent_to(T_world_obj_, S_inv, z, symmetry_, nullptr);
}

void PoseEkf::initialise(const SE3& z, const Mat6& R) {
  T_world_obj_ = z;
  P_ = R;
  initialised_ = true;
  num_fused_ = 1;
}

void PoseEkf::fuse(const SE3& z, const Mat6& R) {
  const Vec6 nu = innovation(z);
  const Mat6 K = P_ * (P_ + R).inverse();
  T_world_obj_ = T_world_obj_ * SE3::exp(K * nu);
  T_world_obj_.rotation() = orthonormalize(T_world_obj_.rotation());
  P_ = (Mat6::Identity() - K) * P_;
  P_ = 0.5 * (P_ + P_.transpose());
  ++num_fused_;
}

PoseEkfStep PoseEkf::update(const PoseMeasurement& m) {
  PoseEkfStep step;
  step.frame_index = m.frame_index;
  step.T_cam_obj_measured = m.T_cam_obj;
  step.mu_m = m.mu_m;
  const Mat6 R = measurement_covariance(m.mu_m);
  SE3 z = m.T_world_cam * m.T_cam_obj;

  if (!initialised_) {
    initialise(z, R);
    step.accepted = true;
    step.initialised = true;
  } else {
    double d2 = 0;
    z = snap_to(T_world_obj_, (P_ + R).inverse(), z, &d2);
    step.mahalanobis_sq = d2;
    if (params_.gate_chi2 <= 0 || d2 <= params_.gate_chi2) {
      fuse(z, R);
      step.accepted = true;
      // Interleaved restart: a consistent run of rejections survives accepted measurements while it
      // is not outnumbered by them, so a competing mode seen in most recent views (a near-symmetric
      // object flipping between two poses) can still restart the filter.
      ++accepted_since_pending_;
      if (!params_.reinit_interleaved ||
          accepted_since_pending_ > static_cast<int>(pending_.size()))
        pending_.clear();
    } else {
      ++num_rejected_;
      if (params_.reinit_after_rejections > 0) {
        if (!pending_.empty()) {
          // Consistent with the first pending measurement? (Aligned to it under the symmetry.)
          const Pending& first = pending_.front();
          double d2p = 0;
          const SE3 aligned = snap_to(first.z, (first.R + R).inverse(), z, &d2p);
          if (params_.gate_chi2 > 0 && d2p > params_.gate_chi2) {
            pending_.clear();
            accepted_since_pending_ = 0;
          } else
            z = aligned;
        }
        if (pending_.empty()) accepted_since_pending_ = 0;
        pending_.push_back({z, R});
        if (static_cast<int>(pending_.size()) >= params_.reinit_after_rejections) {
          initialise(pending_[0].z, pending_[0].R);
          for (size_t i = 1; i < pending_.size(); ++i) fuse(pending_[i].z, pending_[i].R);
          ++num_reinit_;
          pending_.clear();
          step.accepted = true;
          step.reinitialised = true;
        }
      }
    }
  }
  step.T_world_obj_measured = z;
  step.T_cam_obj_fused = T_cam_obj(m.T_world_cam);
  history_.push_back(step);
  return step;
}

FusedObjectPose PoseEkf::result() const {
  FusedObjectPose r;
  r.T_world_obj = T_world_obj_;
  r.covariance = P_;
  r.num_fused = initialised_ ? num_fused_ : 0;
  r.num_rejected = num_rejected_;
  r.num_reinitialisations = num_reinit_;
  r.history = history_;
  return r;
}

void PoseEkf::apply_world_correction(const SE3& C) {
  T_world_obj_ = C * T_world_obj_;
  for (auto& q : pending_) q.z = C * q.z;
}

}  // namespace orpe
