#include "orpe/pipeline/object_fusion.h"

#include <algorithm>
#include <limits>

namespace orpe {

ObjectPoseFusion::ObjectPoseFusion(const PoseEkfParams& params, const ObjectSymmetry& symmetry,
                                   int init_views, bool start_at_majority)
    : params_(params),
      symmetry_(symmetry),
      init_views_(std::max(1, init_views)),
      start_at_majority_(start_at_majority),
      ekf_(params, symmetry) {}

ObjectPoseFusion::Outcome ObjectPoseFusion::add(const PoseMeasurement& m, double score,
                                                bool decisive) {
  Outcome out;
  if (ekf_.initialised()) {
    ekf_.predict();
    const PoseEkfStep step = ekf_.update(m, score);
    out.accepted = step.accepted;
    out.switched = step.reinitialised;
    if (!step.accepted) ++rejected_;
    return out;
  }
  buffer_.emplace_back(m, score);
  buffer_decisive_ = buffer_decisive_ && decisive;
  out.accepted = true;
  const int n = static_cast<int>(buffer_.size());
  if (n < init_views_) {
    const int majority = init_views_ / 2 + 1;
    if (!start_at_majority_ || !buffer_decisive_ || n < majority) return out;
    const Consensus c = consensus();
    if (c.support + 1 < majority) return out;
    start_from(c.best);
    out.initialised = true;
    return out;
  }
  if (!initialise_from_buffer(n < 2 * init_views_)) return out;
  out.initialised = true;
  return out;
}

void ObjectPoseFusion::flush() {
  if (!ekf_.initialised() && !buffer_.empty()) initialise_from_buffer();
}

ObjectPoseFusion::Consensus ObjectPoseFusion::consensus() const {
  // Consensus: the buffered measurement the most others pass the gate against; ties (common for
  // near-symmetric objects, whose views scatter about the axis so that few pairs pass the tight
  // rotation gate) go to the one with the smallest summed Mahalanobis distance to the others,
  // each truncated at the gate (a robust medoid in the filter's own metric), so that an isolated
  // first view no longer wins a tie by its position in the buffer.
  const double cap = params_.gate_chi2 > 0 ? params_.gate_chi2 : std::numeric_limits<double>::max();
  Consensus c;
  double best_cost = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < buffer_.size(); ++i) {
    PoseEkf probe(params_, symmetry_);
    probe.update(buffer_[i].first);
    int support = 0;
    double cost = 0;
    for (size_t j = 0; j < buffer_.size(); ++j) {
      if (j == i) continue;
      PoseEkf copy = probe;
      const PoseEkfStep s = copy.update(buffer_[j].first);
      support += s.accepted && !s.reinitialised;
      cost += std::min(s.mahalanobis_sq, cap);
    }
    if (support > c.support || (support == c.support && cost < best_cost)) {
      c.support = support;
      best_cost = cost;
      c.best = i;
    }
  }
  return c;
}

bool ObjectPoseFusion::initialise_from_buffer(bool need_support) {
  const Consensus c = consensus();
  // No two of the buffered views agree (a near-symmetric object whose views scatter about its
  // axis by more than the tight rotation gate): any start would be arbitrary, so keep buffering,
  // up to 2 init_views measurements, until some pair agrees.
  if (need_support && c.support == 0) return false;
  start_from(c.best);
  return true;
}

void ObjectPoseFusion::start_from(size_t best) {
  ekf_.update(buffer_[best].first, buffer_[best].second);
  for (size_t j = 0; j < buffer_.size(); ++j) {
    if (j == best) continue;
    ekf_.predict();
    const PoseEkfStep s = ekf_.update(buffer_[j].first, buffer_[j].second);
    if (!s.accepted) ++rejected_;
  }
  buffer_.clear();
  buffer_decisive_ = true;
}

FusedObjectPose ObjectPoseFusion::result() const { return ekf_.result(); }

}  // namespace orpe
