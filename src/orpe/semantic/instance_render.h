// Label-aware rendering of the map's object instances (the masks M^ of the association, and the
// projected mask / depth / colour given to the pose stage).
//
// A plain splat render labels a pixel with whatever surfel is nearest. On real depth the fusion
// keeps creating young, noisy surfels (8 % of the pixels per frame on the YCB-Video clips) that sit
// a few millimetres in front of the fused object surface; unlabelled, they punch holes into the
// masks. So the labelled surfels are rendered on their own, and a pixel takes the nearest instance
// surface when it lies within `depth_tolerance_m` of the map's visible surface (all surfels):
// surfaces truly in front (another object, background) still occlude.
//
// Windowed: both renders cover only the window of the image the labelled surfels can reach (the
// bounding box of their projected splats, plus `scene_margin_px` when the scene images are wanted),
// rendered with the intrinsics cropped to it and pasted into full-size images. Outside the window
// there is no instance by construction, so the instance outputs equal those of a full-image render
// (up to float rounding of the shifted principal point); the cost scales with the window's area.
#pragma once

#include <array>
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
  /// Depth and colour of the render of every surfel (the occlusion test's; when requested): the
  /// scene around the instances, within the window (0 / black outside it).
  DepthImage scene_depth;
  ColorImage scene_color;
  /// The rendered window, inclusive pixel bounds (empty: no labelled surfel in view).
  int window_u_min = 0, window_v_min = 0, window_u_max = -1, window_v_max = -1;
};

struct InstanceRenderOptions {
  float max_splat_radius_px = 2.0f;  ///< cap of the splat radii (pixels)
  float splat_radius_scale = 1.0f;   ///< splat radius = surfel radius x this
  double depth_tolerance_m = 0.02;   ///< an instance pixel within this of the visible surface
  bool want_color = false;           ///< InstanceImages::color
  /// >= 0: also fill InstanceImages::scene_depth / scene_color, with the window grown by this many
  /// pixels around the instances' splats; -1: no scene images.
  int scene_margin_px = -1;
};

class InstanceRenderer {
 public:
  /// Renders at `T_world_cam` with intrinsics `K` (output size K.width x K.height). Splat radii are
  /// the surfel radii x `splat_radius_scale`, capped at `max_splat_radius_px`.
  void render(const slam::SurfelMap& map, const SE3& T_world_cam, const PinholeIntrinsics& K,
              float max_splat_radius_px, float splat_radius_scale, double depth_tolerance_m,
              bool want_color, InstanceImages* out);
  void render(const slam::SurfelMap& map, const SE3& T_world_cam, const PinholeIntrinsics& K,
              const InstanceRenderOptions& options, InstanceImages* out);

 private:
  /// Gathers the labelled surfels into labelled_ and returns the window their splats reach
  /// (inclusive bounds u0, v0, u1, v1; u1 < u0 when none is in view).
  std::array<int, 4> gather_labelled(const slam::SurfelMap& map, const SE3& T_world_cam,
                                     const PinholeIntrinsics& K, float max_splat_radius_px,
                                     float splat_radius_scale);

  slam::MapRenderer renderer_;
  slam::SurfelMap labelled_;  // scratch: the labelled surfels only
  std::vector<std::uint32_t> selected_;
  slam::RenderedView all_, objects_;
};

}  // namespace orpe
