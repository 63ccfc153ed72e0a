// Label-aware rendering of the map's object instances (the masks M^ of the association, and the
// projected mask / depth / colour given to the pose stage).
//
// A plain splat render labels a pixel with whatever surfel is nearest. On real depth the fusion
// keeps creating young, noisy surfels (8 % of the pixels per frame on the YCB-Video clips) that sit
// a few millimetres in front of the fused object surface; unlabelled, they punch holes into the
// masks. So the labelled surfels are rendered on their own, and a pixel takes the nearest instance
// surface when it lies within `depth_tolerance_m` of the map's visible surface (all surfels):
// surfaces truly in front (another object, background) still occlude.
#pragma once

#include <cstdint>
#include <vector>

#include "orpe/core/camera.h"
#include "orpe/core/image.h"
#include "orpe/core/se3.h"
#include "orpe/slam/map_renderer.h"
#include "orpe/slam/surfel_map.h"

namespace orpe {

struct InstanceImages {
  LabelImage instance_id;  ///< instance of the pixel, 0 = none
  DepthImage depth;        ///< depth (m) of that instance's surface, 0 where none
  ColorImage color;        ///< its splatted surfel colour (when requested), black where none
};

class InstanceRenderer {
 public:
  /// Renders at `T_world_cam` with intrinsics `K` (output size K.width x K.height). Splat radii are
  /// the surfel radii x `splat_radius_scale`, capped at `max_splat_radius_px`.
  void render(const slam::SurfelMap& map, const SE3& T_world_cam, const PinholeIntrinsics& K,
              float max_splat_radius_px, float splat_radius_scale, double depth_tolerance_m,
              bool want_color, InstanceImages* out);

 private:
  slam::MapRenderer renderer_;
  slam::SurfelMap labelled_;  // scratch: the labelled surfels only
  std::vector<std::uint32_t> selected_;
  slam::RenderedView all_, objects_;
};

}  // namespace orpe
