// Masks from a frame's ground-truth labels (for the `gt` back-end's users: annotation tools,
// benchmarks and tests; never for a back-end that must not read ground truth).
#pragma once

#include <cstdint>

#include "orpe/core/frame.h"

namespace orpe {

/// The pixels of objects_gt[k] (labels_gt == k + 1) as a 0/1 mask; empty when the frame has no
/// labels.
inline MaskImage ground_truth_mask(const RgbdFrame& frame, size_t k) {
  if (frame.labels_gt.empty()) return {};
  MaskImage mask(frame.labels_gt.width(), frame.labels_gt.height(), 0);
  const auto label = static_cast<std::int32_t>(k + 1);
  for (size_t i = 0; i < mask.size(); ++i) mask[i] = frame.labels_gt[i] == label ? 1 : 0;
  return mask;
}

}  // namespace orpe
