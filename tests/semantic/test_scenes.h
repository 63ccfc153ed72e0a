// Small synthetic frames with ground-truth labels for the semantic tests.
#pragma once

#include <cmath>
#include <vector>

#include "orpe/core/frame.h"

namespace orpe::test {

struct Disc {
  int class_id;
  int instance_id;
  double cu, cv, radius_px;
};

/// A frame of `width` x `height` whose labels_gt holds the given discs (later discs on top).
inline RgbdFrame frame_with_discs(int index, const std::vector<Disc>& discs, int width = 160,
                                  int height = 120) {
  RgbdFrame f;
  f.index = index;
  f.name = "synthetic";
  f.intrinsics.width = width;
  f.intrinsics.height = height;
  f.color = ColorImage(width, height, Rgb8{100, 100, 100});
  f.depth = DepthImage(width, height, 1.0f);
  f.labels_gt = LabelImage(width, height, 0);
  for (size_t k = 0; k < discs.size(); ++k) {
    ObjectGroundTruth o;
    o.class_id = discs[k].class_id;
    o.instance_id = discs[k].instance_id;
    f.objects_gt.push_back(o);
    for (int v = 0; v < height; ++v)
      for (int u = 0; u < width; ++u)
        if (std::hypot(u - discs[k].cu, v - discs[k].cv) <= discs[k].radius_px)
          f.labels_gt.at(u, v) = static_cast<int>(k) + 1;
  }
  return f;
}

}  // namespace orpe::test
