// CPU z-buffer rasteriser: renders meshes at given poses into depth (z along the optical axis,
// metres), shaded colour, per-pixel object id, optional camera-frame normals and per-object amodal
// silhouettes.
//
// Method (two passes, so shading cost does not grow with overdraw):
//  1. Setup: vertices to the camera frame; triangles clipped against the near plane (and a guard
//  band),
//     projected with the pinhole model and snapped to 1/256 pixel; binned into row bands.
//  2. Visibility pass, bands in parallel (OpenMP): the pixel centres (u, v) inside each triangle
//  (top-left
//     fill rule: shared edges are covered exactly once) keep the nearest triangle (largest 1/z).
//  3. Resolve pass: per pixel, the ray through the pixel centre is intersected with the visible
//     triangle in double precision, which gives the exact z and perspective-correct barycentrics
//     for interpolating normals, vertex colours and UVs (bilinear texture lookups).
// Shading: albedo * (ambient + diffuse * max(0, n . l)), n flipped to face the camera (two-sided).
// Results do not depend on the number of threads (each band draws its triangles in input order).
//
// A Rasterizer keeps scratch buffers between calls: use one instance per thread.
// Region of interest: render a crop by passing intrinsics with the crop's size and the principal
// point shifted by the crop's top-left corner (cx - u0, cy - v0): the cost scales with the crop's
// pixels.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "orpe/core/camera.h"
#include "orpe/core/image.h"
#include "orpe/core/se3.h"
#include "orpe/render/mesh.h"

namespace orpe {

struct RasterizerParams {
  double near_m = 0.01;          ///< near clipping plane (m)
  double far_m = 100.0;          ///< surfaces beyond this z are not drawn (m)
  bool cull_back_faces = false;  ///< skip triangles facing away (needs consistent CCW winding)
  double ambient = 0.35;         ///< ambient light factor
  double diffuse = 0.75;         ///< diffuse (Lambert) light factor
  double light_dir_x = -0.3;     ///< direction towards the light, camera frame (normalised on use)
  double light_dir_y = -0.6;
  double light_dir_z = -1.0;
  int background_gray = 0;  ///< colour of pixels without a surface (0..255)
  int band_rows = 8;        ///< rows per work unit of the parallel visibility pass
  int threads = 0;          ///< OpenMP threads; 0 = the OpenMP default (OMP_NUM_THREADS)

  template <class V>
  void visit(V&& v) {
    v("near_m", near_m, "Near clipping plane (m)");
    v("far_m", far_m, "Surfaces beyond this depth are not drawn (m)");
    v("cull_back_faces", cull_back_faces, "Skip back-facing triangles (needs outward CCW winding)");
    v("ambient", ambient, "Ambient light factor (0..1)");
    v("diffuse", diffuse, "Diffuse (Lambert) light factor (0..1)");
    v("light_dir_x", light_dir_x,
      "Direction towards the light, camera frame, x (normalised on use)");
    v("light_dir_y", light_dir_y, "Direction towards the light, camera frame, y (y is down)");
    v("light_dir_z", light_dir_z,
      "Direction towards the light, camera frame, z (negative = behind the camera)");
    v("background_gray", background_gray, "Colour of pixels without a surface (0..255)");
    v("band_rows", band_rows, "Rows per parallel work unit (4-64)");
    v("threads", threads, "OpenMP threads for one render; 0 = OMP_NUM_THREADS / all cores");
  }
  bool IsValid(std::string* why) const;
};

/// A light for one render call (overrides the Params' light).
struct Light {
  Eigen::Vector3f direction_cam{-0.3f, -0.6f, -1.0f};  ///< towards the light, camera frame
  float ambient = 0.35f;
  float diffuse = 0.75f;
};

/// One mesh instance to draw. `id` is written to RenderBuffers::ids where the instance is visible.
struct RenderItem {
  const TriangleMesh* mesh = nullptr;
  SE3 T_cam_obj;  ///< object (mesh) frame -> camera frame
  std::int32_t id = 0;
};

/// Which outputs to produce (bit flags); depth and ids are cheap, colour and normals cost a little
/// more.
enum RenderOutput : unsigned {
  kRenderDepth = 1u << 0,
  kRenderIds = 1u << 1,
  kRenderColor = 1u << 2,
  kRenderNormals = 1u << 3,
  kRenderSilhouettes = 1u << 4,  ///< per-item coverage ignoring the other items (amodal masks)
  kRenderTriangles = 1u << 5,    ///< index of the visible triangle within its item's mesh
  kRenderAll = 0x3fu,
};

struct RenderStats {
  size_t triangles_in = 0;       ///< triangles of all items
  size_t triangles_culled = 0;   ///< back-facing (when culling) or entirely outside near/far
  size_t triangles_clipped = 0;  ///< crossing the near plane or the guard band
  size_t triangles_drawn = 0;    ///< screen triangles rasterised (after clipping)
  size_t pixels_covered = 0;     ///< pixels with a surface
};

struct RenderBuffers {
  DepthImage depth;                ///< z along the optical axis (m); 0 = background
  ColorImage color;                ///< shaded RGB
  LabelImage ids;                  ///< RenderItem::id of the visible surface; 0 = background
  Image<Eigen::Vector3f> normals;  ///< camera-frame unit normals facing the camera; 0 = background
  std::vector<MaskImage>
      silhouettes;  ///< per item: 1 where the item covers the pixel, occluded or not
  Image<std::int32_t>
      triangles;              ///< visible triangle index within its item's mesh; -1 = background
  Image<std::int32_t> items;  ///< index into the items span of the visible surface; -1 = background
  RenderStats stats;
};

class Rasterizer {
 public:
  explicit Rasterizer(const RasterizerParams& params = {});
  const RasterizerParams& params() const { return params_; }

  /// Renders `items` into `out` (buffers are resized to the intrinsics' size; those not requested
  /// in `outputs` are left empty). `light` overrides the Params' light when given. Throws
  /// std::invalid_argument for invalid intrinsics or an item without a valid mesh.
  void render(const PinholeIntrinsics& K, std::span<const RenderItem> items, RenderBuffers& out,
              unsigned outputs = kRenderDepth | kRenderIds | kRenderColor,
              const Light* light = nullptr);
  RenderBuffers render(const PinholeIntrinsics& K, std::span<const RenderItem> items,
                       unsigned outputs = kRenderDepth | kRenderIds | kRenderColor,
                       const Light* light = nullptr);

  /// The Params' light as a Light.
  Light default_light() const;

 private:
  /// A projected triangle: vertices in 1/256 pixel fixed point, pixel bounds, 1/z plane in (u, v).
  struct ScreenTriangle {
    std::int32_t x[3], y[3];
    std::int32_t u_min, u_max, v_min, v_max;
    float inv_z_du, inv_z_dv, inv_z_0;
    std::int32_t item, triangle;
  };
  /// A vertex projected once: fixed-point position and 1/z, unless it needs clipping.
  struct ProjectedVertex {
    std::int32_t x = 0, y = 0;
    double inv_z = 0;
    bool needs_clip = true;  ///< behind the near plane or outside the guard band
  };
  // The steps of render(), in order.
  /// cam_vertices_ and proj_vertices_: every item's vertices in the camera frame, projected.
  void project_vertices(const PinholeIntrinsics& K, std::span<const RenderItem> items, int threads,
                        RenderStats& stats);
  /// tris_: the screen triangles (culled, clipped to the near plane and the guard band).
  void setup_triangles(const PinholeIntrinsics& K, std::span<const RenderItem> items, int threads,
                       RenderStats& stats);
  /// One fixed-size chunk of the global triangle sequence into chunk_tris_[c].
  void setup_chunk(const PinholeIntrinsics& K, std::span<const RenderItem> items,
                   const std::vector<size_t>& item_first, size_t c, size_t* culled,
                   size_t* clipped);
  /// The screen triangle (a, b, d) of fixed-point vertices X, Y with their 1/z, unless empty.
  static void emit(int W, int H, const std::int64_t* X, const std::int64_t* Y, const double* iz,
                   int a, int b, int d, int item, int tri, std::vector<ScreenTriangle>& outv);
  /// band_offsets_ / band_tris_: the triangles of each band of params_.band_rows rows.
  void bin_triangles(int H);
  /// inv_z_ / visible_: the nearest triangle per pixel; the silhouettes when wanted.
  void rasterise(const PinholeIntrinsics& K, size_t n_items, bool want_sil, int threads,
                 RenderBuffers& out);
  /// The requested images of the visible surfaces; returns the pixels covered.
  size_t resolve(const PinholeIntrinsics& K, std::span<const RenderItem> items, unsigned outputs,
                 const Light& light, int threads, RenderBuffers& out);

  RasterizerParams params_;
  // Scratch, reused between calls.
  std::vector<std::vector<Eigen::Vector3f>> cam_vertices_;
  std::vector<std::vector<ProjectedVertex>> proj_vertices_;
  std::vector<std::vector<ScreenTriangle>> chunk_tris_;
  std::vector<ScreenTriangle> tris_;
  std::vector<std::uint32_t> band_offsets_, band_tris_;
  std::vector<float> inv_z_;
  std::vector<std::int32_t> visible_;
};

}  // namespace orpe
