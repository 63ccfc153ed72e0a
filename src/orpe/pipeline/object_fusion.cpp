#include "orpe/pipeline/object_fusion.h"

#include <algorithm>
#include <limits>

namespace orpe {

ObjectPoseFusion::ObjectPoseFusion(const PoseEkfParams& params, const ObjectSymmetry& symmetry,
                                   int init_views)
    : params_(params),
      symmetry_(symmetry),
      init_views_(std::max(1, init_views)),
      ekf_(params, symmetry) {}

ObjectPoseFusion::Outcome ObjectPoseFusion::add(const PoseMeasurement& m, double score) {
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
  out.accepted = true;
  if (static_cast<int>(buffer_.size()) < init_views_) return out;
  if (!initialise_from_buffer(static_cast<int>(buffer_.size()) < 2 * init_views_)) return out;
  out.initialised = true;
  return out;
}

void ObjectPoseFusion::flush() {
  if (!ekf_.initialised() && !buffer_.empty()) initialise_from_buffer();
}

bool ObjectPoseFusion::initialise_from_buffer(bool need_support) {
  // Consensus: the buffered measurement the most others pass the gate against; ties (common for
  // near-symmetric objects, whose views scatter about the axis so that few pairs pass the tight
  // rotation gate) go to the one with the smallest summed Mahalanobis distance to the others,
  // each truncated at the gate (a robust medoid in the filter's own metric), so that an isolated
  // first view no longer wins a tie by its position in the buffer.
  const double cap = params_.gate_chi2 > 0 ? params_.gate_chi2 : std::numeric_limits<double>::max();
  size_t best = 0;
  int best_support = -1;
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
    if (support > best_support || (support == best_support && cost < best_cost)) {
      best_support = support;
      best_cost = cost;
      best = i;
    }
  }
  // No two of the buffered views agree (a near-symmetric object whose views scatter about its
  // axis by more than the tight rotation gate): any start would be arbitrary, so keep buffering,
  // up to 2 init_views measurements, until some pair agrees.
  if (need_support && best_support == 0) return false;
  ekf_.update(buffer_[best].first, buffer_[best].second);
  for (size_t j = 0; j < buffer_.size(); ++j) {
    if (j == best) continue;
    ekf_.predict();
    const PoseEkfStep s = ekf_.update(buffer_[j].first, buffer_[j].second);
    if (!s.accepted) ++rejected_;
  }
  buffer_.clear();
  return true;
}

FusedObjectPose ObjectPoseFusion::result() const { return ekf_.result(); }

}  // namespace orpe
