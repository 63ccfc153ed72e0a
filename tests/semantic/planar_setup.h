// A fronto-parallel wall of surfels, one per pixel, for exact tests of the semantic fusion rules.
#pragma once

#include <functional>
#include <vector>

#include "orpe/core/frame.h"
#include "orpe/semantic/detection.h"
#include "orpe/slam/map_renderer.h"
#include "orpe/slam/surfel_map.h"

namespace orpe::test {

struct PlanarSetup {
  PinholeIntrinsics K;
  slam::SurfelMap map;
  slam::IndexImage pixel_surfel;  ///< pixel -> its surfel (identity layout)

  explicit PlanarSetup(int width = 80, int height = 60) {
    K.width = width;
    K.height = height;
    K.fx = K.fy = 80;
    K.cx = (width - 1) / 2.0;
    K.cy = (height - 1) / 2.0;
    pixel_surfel = slam::IndexImage(width, height, -1);
    for (int v = 0; v < height; ++v)
      for (int u = 0; u < width; ++u) {
        slam::Surfel s;
        s.position_world = K.backproject(u, v, 1.0).cast<float>();
        s.normal_world = Eigen::Vector3f(0, 0, -1);  // facing the camera at the origin
        s.radius_m = 0.7f / 80.0f;                   // 0.7 px: each pixel shows its own surfel
        s.confidence = 20;
        s.color = Rgb8{static_cast<std::uint8_t>(u), static_cast<std::uint8_t>(v), 7};
        pixel_surfel.at(u, v) = static_cast<std::int32_t>(map.push_back(s));
      }
  }

  RgbdFrame frame(int index) const {
    RgbdFrame f;
    f.index = index;
    f.name = "planar";
    f.intrinsics = K;
    f.color = ColorImage(K.width, K.height);
    f.depth = DepthImage(K.width, K.height, 1.0f);
    return f;
  }

  std::int32_t surfel(int u, int v) const { return pixel_surfel.at(u, v); }
};

/// A detection whose probability is given per pixel by `prob(u, v)`.
inline Detection make_detection(int width, int height, int class_id, float score,
                                const std::function<float(int, int)>& prob) {
  Detection d;
  d.class_id = class_id;
  d.score = score;
  d.probability = ProbabilityImage(width, height, 0.0f);
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u) d.probability.at(u, v) = prob(u, v);
  d.box = mask_box(d.probability, 0.5f);
  return d;
}

/// A rectangle [u0, u1] x [v0, v1] of probability `inside`, `outside` elsewhere.
inline Detection rect_detection(int width, int height, int class_id, float score, int u0, int v0,
                                int u1, int v1, float inside = 0.9f, float outside = 0.05f) {
  return make_detection(width, height, class_id, score, [=](int u, int v) {
    return (u >= u0 && u <= u1 && v >= v0 && v <= v1) ? inside : outside;
  });
}

}  // namespace orpe::test
