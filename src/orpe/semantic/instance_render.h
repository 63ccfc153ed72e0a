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
// rendered as a window of the image (slam::RenderOptions' window: the whole image's pixel rays) and
// pasted into full-size images. Outside the window there is no instance by construction, so the
// outputs equal, bit for bit, those of a full-image render; the cost scales with the window's area.
//
// One pass: the render of every surfel and that of the labelled ones come from one pass over the
// map (slam::MapRenderer::render_with_labelled: each surfel transformed and splatted once, into
// two z-buffers), unless the render of every surfel is reused (then the labelled surfels only).
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
  /// The render of every surfel came from InstanceRenderOptions::reuse_scene (not rendered again).
  bool scene_reused = false;
  /// Splatting passes over the map's surfels this render made: 1 (both views in one pass, or the
  /// labelled surfels alone with a reused scene), 2 (InstanceRenderOptions::one_pass off), 0 (no
  /// labelled surfel in view).
  int map_passes = 0;
};

/// The render of every surfel over a window of the image (depth and colour), kept by one render so
/// that a later one at the same camera whose window lies inside skips it: the semantic stage keeps
/// it, the pose stage reuses it (ObjectRpePipeline; docs/PIPELINE.md, "Projected images"). Valid
/// only while the map's geometry (positions, normals, radii, the number of surfels) is unchanged:
/// matches() checks the map, its size, the camera and the splat options; that nothing moved in
/// between is the caller's promise.
struct SceneRender {
  const slam::SurfelMap* map = nullptr;  ///< null: nothing kept
  size_t map_size = 0;
  SE3 T_world_cam;
  PinholeIntrinsics K;  ///< of the whole image
  float max_splat_radius_px = 0, splat_radius_scale = 0;
  int u0 = 0, v0 = 0;  ///< the window's first pixel in the image; its size is depth's
  DepthImage depth;    ///< 0 = empty
  ColorImage color;
  /// Same map (and size), camera and splat options, and the window [u0, u1] x [v0, v1] inside.
  bool matches(const slam::SurfelMap& m, const SE3& T, const PinholeIntrinsics& k,
               float max_splat_px, float radius_scale, int wu0, int wv0, int wu1, int wv1) const;
  void clear() { map = nullptr; }
};

struct InstanceRenderOptions {
  float max_splat_radius_px = 2.0f;  ///< cap of the splat radii (pixels)
  float splat_radius_scale = 1.0f;   ///< splat radius = surfel radius x this
  double depth_tolerance_m = 0.02;   ///< an instance pixel within this of the visible surface
  bool want_color = false;           ///< InstanceImages::color
  /// >= 0: also fill InstanceImages::scene_depth / scene_color, with the window grown by this many
  /// pixels around the instances' splats; -1: no scene images.
  int scene_margin_px = -1;
  /// Non-null: the render of every surfel (with colour) is kept here, over the window grown by
  /// `keep_margin_px` (cleared when no labelled surfel is in view). The outputs are as without it.
  SceneRender* keep_scene = nullptr;
  int keep_margin_px = 0;
  /// Non-null and matching (SceneRender::matches, this render's window inside its window): the
  /// render of every surfel is taken from it instead of rendered again. The outputs are as without
  /// it, bit for bit (every render is a window of the same image's pixel rays).
  const SceneRender* reuse_scene = nullptr;
  /// Both views (every surfel; the labelled ones) from one pass over the map
  /// (slam::MapRenderer::render_with_labelled); false: one render each (same images, the cost
  /// before session 24; SemanticParams::mask_render_one_pass).
  bool one_pass = true;
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
  /// Where compose() reads: the render of every surfel (null: all_) from pixel (sx, sy) on, the
  /// labelled view (objects_) from (ox, oy) on, for the window's first pixel.
  struct Renders {
    const DepthImage* scene_depth = nullptr;
    const ColorImage* scene_color = nullptr;
    int sx = 0, sy = 0, ox = 0, oy = 0;
  };
  /// The two views over the window (inclusive bounds u0, v0, u1, v1): the render of every surfel
  /// reused, or rendered with the labelled view in one pass (kept when asked).
  Renders render_window(const slam::SurfelMap& map, const SE3& T_world_cam,
                        const PinholeIntrinsics& K, const InstanceRenderOptions& o,
                        const std::array<int, 4>& window, InstanceImages* out);
  /// The label-aware images of the window from the two views.
  void compose(const Renders& r, const InstanceRenderOptions& o, const std::array<int, 4>& window,
               bool want_scene, InstanceImages* out) const;

  slam::MapRenderer renderer_;
  slam::RenderedView all_, objects_;
};

}  // namespace orpe
