// CPU renderer of the surfel map: splats surfels as oriented discs into z-buffered images at any pose
// and intrinsics (ElasticFusion's model prediction), or renders surfel centres as single points into a
// supersampled index map (ElasticFusion's fusion index map).
//
// Output images are in the *camera* frame of the rendered view (x right, y down, z forward, metres).
// A pixel with no surfel has depth 0, surfel_index -1, instance_id 0, zero vertex/normal, black colour.
//
// Splatting: each pixel inside a surfel's projected disc takes the depth of the ray's intersection
// with the disc's plane; the nearest surface wins, where among discs of about the same depth the one
// whose centre is nearest the pixel wins (RenderOptions::centre_preference); exact ties go to the
// lower surfel index, so the result does not depend on thread timing. Back-facing surfels (normal
// pointing away from the camera) are skipped.
#pragma once

#include <cstdint>
#include <limits>
#include <string>

#include "orpe/core/camera.h"
#include "orpe/core/image.h"
#include "orpe/core/se3.h"
#include "orpe/slam/surfel_map.h"

namespace orpe::slam {

using VertexImage = Image<Vec3f>;  ///< per-pixel 3D point (m) in the camera frame; z = 0 invalid
using NormalImage = Image<Vec3f>;  ///< per-pixel unit normal in the camera frame; zero = invalid
using IndexImage = Image<std::int32_t>;  ///< per-pixel surfel index into SurfelMap, -1 = none

/// Which surfels to draw, and how.
struct RenderOptions {
  /// Draw only surfels with confidence >= this (e.g. FusionParams::stable_confidence for stable
  /// surfels only); 0 draws all.
  float min_confidence = 0.0f;
  /// Additionally draw unstable surfels last seen at or after this frame (-1: none). Tracking uses
  /// it to include the surfels the previous frame created or updated.
  std::int32_t also_seen_since = -1;
  /// Active window: only surfels active at `now` (SurfelMap::is_active). <= 0 draws all surfels.
  int active_window_frames = 0;
  std::int32_t now = 0;  ///< current frame counter, for the active window
  /// Only surfels last seen at or before this frame counter (loop closure renders the old part of
  /// the map with it); the default draws all.
  std::int32_t seen_until = std::numeric_limits<std::int32_t>::max();
  /// Only surfels of this instance (> 0), e.g. to render one object's mask/depth/colour; 0 = all.
  std::int32_t only_instance = 0;
  /// Only surfels with an instance (instance_id > 0): the map's objects.
  bool only_labelled = false;
  float near_m = 0.1f;   ///< surfels closer than this are skipped
  float far_m = 10.0f;   ///< surfels farther than this are skipped
  /// Cap of a splat's radius on screen (pixels), bounding the cost of surfels close to the camera.
  float max_splat_radius_px = 12.0f;
  /// Splat radius = surfel radius x this. Below 1 trims the overhang of discs past depth edges
  /// (a disc spacing of one pixel still leaves no holes down to ~0.6).
  float radius_scale = 1.0f;
  /// Among overlapping discs of one surface, prefer the one whose centre is nearest the pixel: the
  /// depth test compares t * (1 + centre_preference * d^2), d = pixel-to-centre distance (px). Without
  /// it, ties between coplanar discs go to the lowest index, which shifts colours systematically.
  float centre_preference = 0.003f;
  /// Surface band (m): when > 0, a pixel shows, among the discs whose ray intersection lies within
  /// this of the nearest one's, the disc whose centre is nearest the pixel (a second splatting
  /// pass). Overlapping discs of one surface then do not compete by depth: with noisy surfels
  /// (few observations) the nearest of several is biased towards the camera, which biases
  /// tracking (docs/SLAM.md, "Session 23: the tracking prediction's surface band"). 0 = the
  /// nearest disc wins.
  float surface_band_m = 0.0f;

  /// A window of K's image (render()): pixels [window_u0, window_u0 + window_width) x
  /// [window_v0, window_v0 + window_height); the outputs are window-sized and equal, bit for bit,
  /// that window of a whole-image render (the same pixel rays: the window is not a cropped camera).
  /// A width or height <= 0: the whole image. Precondition: the window lies inside the image.
  int window_u0 = 0, window_v0 = 0, window_width = 0, window_height = 0;

  // What to write (index and depth are always written; the rest on request).
  bool want_vertex = true;
  bool want_normal = true;
  bool want_color = true;
  bool want_instance = false;
  bool want_surfel_centre = false;
};

/// Images of one rendered view. Image sizes equal the requested intrinsics' width x height.
struct RenderedView {
  DepthImage depth;          ///< z (m) of the visible surface, 0 = empty
  IndexImage surfel_index;   ///< visible surfel, -1 = empty
  VertexImage vertex;        ///< camera frame (m); only when RenderOptions::want_vertex
  NormalImage normal;        ///< camera frame; only when want_normal
  ColorImage color;          ///< surfel colour; only when want_color
  LabelImage instance_id;    ///< SurfelMap::instance_id of the visible surfel (0 = none); want_instance
  /// Centre of the visible surfel (camera frame, m), where its colour was measured; z = 0 empty.
  /// Photometric tracking uses it so that a colour is paired with its own 3D point. want_surfel_centre
  VertexImage surfel_centre;
  size_t drawn_surfels = 0;  ///< surfels that passed the filters and projected into the image
};

/// Index map of surfel centres: each drawn surfel writes its index at the sub-pixel cell containing
/// its projected centre, at `supersample` x the resolution of the intrinsics (nearest surfel wins).
/// Live pixel (u, v) covers cells [u * s, u * s + s) x [v * s, v * s + s).
struct IndexMap {
  int supersample = 1;
  IndexImage surfel_index;  ///< (width * s) x (height * s), -1 = empty
  DepthImage depth;         ///< z (m) of the cell's surfel centre in the camera frame, 0 = empty
  VertexImage position_cam; ///< the cell's surfel centre in the camera frame (m); zero = empty
  // Copies of the cell's surfel attributes, so that per-pixel association reads contiguous memory
  // instead of gathering from the map (filled only when `want_attributes` was passed).
  NormalImage normal_world;  ///< world frame
  Image<float> radius_m;
  Image<float> confidence;
  size_t drawn_surfels = 0;
};

/// Stateless apart from reusable scratch buffers (so one renderer per thread of use). OpenMP inside.
class MapRenderer {
 public:
  /// Splats the map as seen from `T_world_cam` with intrinsics `K` into `out` (its images are
  /// reallocated only when the size changes): the whole image, or RenderOptions' window of it.
  void render(const SurfelMap& map, const SE3& T_world_cam, const PinholeIntrinsics& K,
              const RenderOptions& options, RenderedView* out);
  /// render() into `out` and, in the same pass over the map, into `labelled` the view of the
  /// surfels that `options` draws and that have an instance (instance_id > 0), with the outputs
  /// `labelled_wants` asks for (its want_* flags; the rest as `options`): both equal, bit for bit,
  /// what render() gives, `labelled` with only_labelled set (the label-aware instance render's two
  /// views for the price of one transform and splat per surfel). Precondition:
  /// options.surface_band_m == 0.
  void render_with_labelled(const SurfelMap& map, const SE3& T_world_cam,
                            const PinholeIntrinsics& K, const RenderOptions& options,
                            const RenderOptions& labelled_wants, RenderedView* out,
                            RenderedView* labelled);

  /// Renders surfel centres as points into a supersampled index map (fusion's data association).
  /// Uses the filters of `options` (confidence, active window, instance, near/far).
  void render_index_map(const SurfelMap& map, const SE3& T_world_cam, const PinholeIntrinsics& K,
                        int supersample, const RenderOptions& options, IndexMap* out,
                        bool want_attributes = false);

 private:
  std::vector<std::uint64_t> zbuffer_;  // packed (depth bits << 32 | surfel index), min wins
  std::vector<std::uint64_t> zbuffer2_;  // the surface band's pass: (d^2 bits << 32 | index)
  std::vector<std::uint8_t> drawn_;      // the surface band's pass: 1 = drawn by the first pass
  std::vector<std::uint64_t> zbuffer_labelled_;  // render_with_labelled's second view
};

}  // namespace orpe::slam
