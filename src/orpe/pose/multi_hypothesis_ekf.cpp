#include "orpe/pose/multi_hypothesis_ekf.h"

#include <algorithm>
#include <limits>

#include "orpe/core/error.h"

namespace orpe {

MultiHypothesisPoseEkf::MultiHypothesisPoseEkf(const PoseEkfParams& params,
                                               const ObjectSymmetry& symmetry)
    : params_(params), hypothesis_params_(params), symmetry_(symmetry) {
  std::string why;
  if (!params_.IsValid(&why)) throw ConfigError("pose_ekf: " + why);
  if (params_.hypotheses > 1) {
    hypothesis_params_.reinit_after_rejections = 0;
    hypothesis_params_.reinit_interleaved = false;
  }
  PoseEkf probe(hypothesis_params_, symmetry_);  // validates the symmetry once, here
}

void MultiHypothesisPoseEkf::predict() {
  for (auto& h : hypotheses_) h.ekf.predict();
}

PoseEkfStep MultiHypothesisPoseEkf::update_single(const PoseMeasurement& m, double score) {
  if (hypotheses_.empty()) {
    hypotheses_.push_back({PoseEkf(hypothesis_params_, symmetry_), 0, 0, 0, 0});
    reported_ = 0;
  }
  Hypothesis& h = hypotheses_.front();
  PoseEkfStep step = h.ekf.update(m);
  if (step.reinitialised) {  // the state restarted from the pending measurements
    h.score_sum = 0;
    h.views = 0;
    ++num_switches_;
  }
  if (step.accepted) {
    h.score_sum += score;
    ++h.views;
    h.evidence = h.views;
  }
  return step;
}

PoseEkfStep MultiHypothesisPoseEkf::update(const PoseMeasurement& m, double score) {
  ++num_measurements_;
  // One filter keeps its own history (result() returns it).
  if (params_.hypotheses == 1) return update_single(m, score);

  for (auto& h : hypotheses_) h.evidence *= params_.hypothesis_evidence_decay;
  PoseEkfStep step;
  step.frame_index = m.frame_index;
  step.T_cam_obj_measured = m.T_cam_obj;
  step.T_world_obj_measured = m.T_world_cam * m.T_cam_obj;
  step.mu_m = m.mu_m;

  // Gate against every hypothesis first (an update must not change another's decision).
  std::vector<double> d2(hypotheses_.size());
  for (size_t i = 0; i < hypotheses_.size(); ++i) d2[i] = hypotheses_[i].ekf.gate_distance_sq(m);
  bool joined_any = false;
  double best_d2 = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < hypotheses_.size(); ++i) {
    best_d2 = std::min(best_d2, d2[i]);
    if (d2[i] > params_.gate_chi2) continue;
    Hypothesis& h = hypotheses_[i];
    const PoseEkfStep s = h.ekf.update(m);
    if (!s.accepted) continue;  // cannot happen (same gate), but never count a rejected view
    joined_any = true;
    h.evidence += m.mode_weight *
                  (params_.hypothesis_evidence == "kernel" ? 1.0 - d2[i] / params_.gate_chi2 : 1.0);
    h.score_sum += score;
    ++h.views;
    h.last_measurement = num_measurements_;
    if (static_cast<int>(i) == reported_) step.T_world_obj_measured = s.T_world_obj_measured;
  }
  step.mahalanobis_sq = hypotheses_.empty() ? 0.0 : best_d2;

  if (!joined_any) {
    // A mode no hypothesis explains: a new hypothesis, in place of the weakest one when full.
    Hypothesis fresh{PoseEkf(hypothesis_params_, symmetry_), m.mode_weight, score, 1,
                     num_measurements_};
    fresh.ekf.update(m);
    if (static_cast<int>(hypotheses_.size()) < params_.hypotheses) {
      hypotheses_.push_back(std::move(fresh));
    } else {
      int weakest = -1;
      for (int i = 0; i < static_cast<int>(hypotheses_.size()); ++i) {
        if (i == reported_) continue;
        if (weakest < 0 || hypotheses_[i].evidence < hypotheses_[weakest].evidence) weakest = i;
      }
      hypotheses_[static_cast<size_t>(weakest)] = std::move(fresh);
    }
    if (reported_ < 0) {
      reported_ = 0;
      step.initialised = true;
    }
  }
  merge_duplicates();

  // Report: the most evidence, with hysteresis.
  int best = reported_;
  for (int i = 0; i < static_cast<int>(hypotheses_.size()); ++i)
    if (hypotheses_[i].evidence > hypotheses_[best].evidence) best = i;
  if (best != reported_ && hypotheses_[best].evidence >
                               hypotheses_[reported_].evidence + params_.hypothesis_switch_margin) {
    reported_ = best;
    ++num_switches_;
    step.reinitialised = true;
  }
  step.accepted = reported().last_measurement == num_measurements_;
  step.T_cam_obj_fused = T_cam_obj(m.T_world_cam);
  history_.push_back(step);
  return step;
}

void MultiHypothesisPoseEkf::merge_duplicates() {
  // Two hypotheses whose states pass the gate against each other describe one mode (a new one
  // was started before the other had converged): keep the one with more evidence.
  for (size_t i = 0; i < hypotheses_.size(); ++i) {
    for (size_t j = i + 1; j < hypotheses_.size();) {
      if (hypotheses_[i].ekf.state_distance_sq(hypotheses_[j].ekf) > params_.gate_chi2) {
        ++j;
        continue;
      }
      const bool keep_j = hypotheses_[j].evidence > hypotheses_[i].evidence;
      if (keep_j) std::swap(hypotheses_[i], hypotheses_[j]);
      hypotheses_[i].last_measurement =
          std::max(hypotheses_[i].last_measurement, hypotheses_[j].last_measurement);
      // The reported index follows its mode: if either was reported, the survivor (i) is.
      if (reported_ == static_cast<int>(i) || reported_ == static_cast<int>(j))
        reported_ = static_cast<int>(i);
      hypotheses_.erase(hypotheses_.begin() + static_cast<std::ptrdiff_t>(j));
      if (reported_ > static_cast<int>(j)) --reported_;
    }
  }
}

FusedObjectPose MultiHypothesisPoseEkf::result() const {
  FusedObjectPose r;
  if (!initialised()) {
    r.history = history_;
    return r;
  }
  if (params_.hypotheses == 1) {
    r = reported().ekf.result();
    return r;
  }
  const Hypothesis& h = reported();
  r.T_world_obj = h.ekf.T_world_obj();
  r.covariance = h.ekf.covariance();
  r.num_fused = h.views;
  r.num_rejected = num_measurements_ - h.views;
  r.num_reinitialisations = num_switches_;
  r.history = history_;
  return r;
}

std::vector<MultiHypothesisPoseEkf::HypothesisSummary> MultiHypothesisPoseEkf::hypotheses() const {
  std::vector<HypothesisSummary> out;
  for (size_t i = 0; i < hypotheses_.size(); ++i)
    out.push_back({hypotheses_[i].ekf.T_world_obj(), hypotheses_[i].evidence, hypotheses_[i].views,
                   static_cast<int>(i) == reported_});
  return out;
}

}  // namespace orpe
