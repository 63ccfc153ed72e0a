// One instance detection of a 2D segmenter (Mask R-CNN or a stand-in), in the full image frame.
//
// The soft mask is the per-pixel object (non-background) probability before the 0.5 threshold, as
// Mask R-CNN's mask branch gives it once resized to the RoI and pasted into the image (the paper's
// p_o(I_t)). Pixels outside the RoI have probability 0. The binary mask is probability >=
// threshold.
#pragma once

#include <utility>
#include <vector>

#include "orpe/core/image.h"

namespace orpe {

/// Axis-aligned pixel box, inclusive bounds. Empty when u_max < u_min or v_max < v_min.
struct BoxPx {
  int u_min = 0, v_min = 0, u_max = -1, v_max = -1;
  bool empty() const { return u_max < u_min || v_max < v_min; }
  int width_px() const { return empty() ? 0 : u_max - u_min + 1; }
  int height_px() const { return empty() ? 0 : v_max - v_min + 1; }
  void include(int u, int v);  ///< grows the box to contain pixel (u, v)
  friend bool operator==(const BoxPx&, const BoxPx&) = default;
};

struct Detection {
  int class_id = 0;    ///< dataset class id (YCB-Video 1..21, BOP obj_id); > 0
  float score = 0.0f;  ///< detector confidence in [0, 1]
  BoxPx box;  ///< box of the binary mask (or the detector's box when it has no mask pixels)
  ProbabilityImage probability;  ///< full-image soft mask in [0, 1]
  /// Optional full class distribution {class id, probability}; empty = {class_id: score} (the rest
  /// of the mass is "other"). Used by the instance class-probability average.
  std::vector<std::pair<int, float>> class_probabilities;
  /// Where it came from, for evaluation only: the ground-truth instance id (gt back-end), -1 for an
  /// injected spurious blob, 0 when unknown (files back-end). Fusion never reads it.
  int source_instance_id = 0;
};

/// The class distribution to average: `class_probabilities`, or {class_id: score} when empty.
std::vector<std::pair<int, float>> class_distribution(const Detection& detection);

/// Binary mask probability >= threshold (0/1).
MaskImage binary_mask(const ProbabilityImage& probability, float threshold);
/// Number of pixels with probability >= threshold.
int mask_area(const ProbabilityImage& probability, float threshold);
/// Box of the pixels with probability >= threshold (empty box when none).
BoxPx mask_box(const ProbabilityImage& probability, float threshold);
/// Box of the non-zero pixels of a mask.
BoxPx mask_box(const MaskImage& mask);

}  // namespace orpe
