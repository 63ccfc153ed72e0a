#include "orpe/pipeline/object_fusion.h"

#include <algorithm>

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
    const PoseEkfStep step = ekf_.update(m);
    out.accepted = step.accepted;
    if (step.reinitialised) {  // the state restarted from the pending measurements
      score_sum_ = 0;
      accepted_ = 0;
    }
    if (step.accepted) {
      score_sum_ += score;
      ++accepted_;
    } else {
      ++rejected_;
    }
    return out;
  }
  buffer_.emplace_back(m, score);
  out.accepted = true;
  if (static_cast<int>(buffer_.size()) < init_views_) return out;
  initialise_from_buffer();
  out.initialised = true;
  return out;
}

void ObjectPoseFusion::flush() {
  if (!ekf_.initialised() && !buffer_.empty()) initialise_from_buffer();
}

void ObjectPoseFusion::initialise_from_buffer() {
  // Consensus: the buffered measurement the most others pass the gate against.
  size_t best = 0;
  int best_support = -1;
  for (size_t i = 0; i < buffer_.size(); ++i) {
    PoseEkf probe(params_, symmetry_);
    probe.update(buffer_[i].first);
    int support = 0;
    for (size_t j = 0; j < buffer_.size(); ++j) {
      if (j == i) continue;
      PoseEkf copy = probe;
      const PoseEkfStep s = copy.update(buffer_[j].first);
      support += s.accepted && !s.reinitialised;
    }
    if (support > best_support) {
      best_support = support;
      best = i;
    }
  }
  ekf_.update(buffer_[best].first);
  score_sum_ = buffer_[best].second;
  accepted_ = 1;
  for (size_t j = 0; j < buffer_.size(); ++j) {
    if (j == best) continue;
    ekf_.predict();
    const PoseEkfStep s = ekf_.update(buffer_[j].first);
    if (s.accepted) {
      score_sum_ += buffer_[j].second;
      ++accepted_;
    } else {
      ++rejected_;
    }
  }
  buffer_.clear();
}

FusedObjectPose ObjectPoseFusion::result() const { return ekf_.result(); }

}  // namespace orpe
