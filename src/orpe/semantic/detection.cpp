#include "orpe/semantic/detection.h"

#include <algorithm>

namespace orpe {

void BoxPx::include(int u, int v) {
  if (empty()) {
    u_min = u_max = u;
    v_min = v_max = v;
    return;
  }
  u_min = std::min(u_min, u);
  u_max = std::max(u_max, u);
  v_min = std::min(v_min, v);
  v_max = std::max(v_max, v);
}

std::vector<std::pair<int, float>> class_distribution(const Detection& detection) {
  if (!detection.class_probabilities.empty()) return detection.class_probabilities;
  return {{detection.class_id, detection.score}};
}

MaskImage binary_mask(const ProbabilityImage& probability, float threshold) {
  MaskImage mask(probability.width(), probability.height(), 0);
  for (size_t i = 0; i < probability.size(); ++i) mask[i] = probability[i] >= threshold ? 1 : 0;
  return mask;
}

int mask_area(const ProbabilityImage& probability, float threshold) {
  return static_cast<int>(std::count_if(probability.begin(), probability.end(),
                                        [&](float p) { return p >= threshold; }));
}

BoxPx mask_box(const ProbabilityImage& probability, float threshold) {
  BoxPx box;
  for (int v = 0; v < probability.height(); ++v) {
    const float* row = probability.row(v);
    for (int u = 0; u < probability.width(); ++u)
      if (row[u] >= threshold) box.include(u, v);
  }
  return box;
}

BoxPx mask_box(const MaskImage& mask) {
  BoxPx box;
  for (int v = 0; v < mask.height(); ++v) {
    const auto* row = mask.row(v);
    for (int u = 0; u < mask.width(); ++u)
      if (row[u]) box.include(u, v);
  }
  return box;
}

}  // namespace orpe
