// Triangle meshes for rendering and for model points: vertices in metres in the object's own frame.
//
// Conventions:
//  - Triangles are wound counter-clockwise seen from outside (right-hand normal points outwards).
//    The rasteriser does not rely on it unless back-face culling is switched on.
//  - UVs follow the OBJ/PLY convention: (0, 0) is the bottom-left of the texture image, v points
//  up.
//    Texture lookups are bilinear and wrap around outside [0, 1].
//  - Albedo of a surface point = base colour, times the interpolated vertex colour when present,
//  times
//    the texture colour when UVs and a texture are present (each factor in [0, 1] per channel).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "orpe/core/image.h"
#include "orpe/core/se3.h"

namespace orpe {

struct TriangleMesh {
  std::string name;                       ///< for messages (e.g. the file it came from)
  std::vector<Eigen::Vector3f> vertices;  ///< metres, object frame
  std::vector<Eigen::Vector3f>
      normals;                       ///< unit, per vertex; empty = call compute_vertex_normals()
  std::vector<Rgb8> colors;          ///< per vertex; optional (empty)
  std::vector<Eigen::Vector2f> uvs;  ///< per vertex; optional, used with `texture`
  std::shared_ptr<const ColorImage> texture;  ///< optional RGB8 texture image
  std::vector<Eigen::Vector3i> triangles;     ///< vertex indices, CCW seen from outside
  Rgb8 base_color{255, 255, 255};  ///< albedo factor; a mesh without colours renders in this

  size_t num_vertices() const { return vertices.size(); }
  size_t num_triangles() const { return triangles.size(); }
  bool has_colors() const { return !colors.empty(); }
  bool has_texture() const { return texture && !texture->empty() && !uvs.empty(); }

  /// Checks sizes (normals/colours/uvs empty or one per vertex), indices in range, finite values.
  bool IsValid(std::string* why) const;
  /// Area-weighted vertex normals from the triangles (vertices of no triangle get +z).
  void compute_vertex_normals();
  /// Axis-aligned bounds of the vertices (empty box for an empty mesh).
  Eigen::AlignedBox3f bounds() const;
  /// Total triangle area, m^2.
  double surface_area() const;
  /// Applies T (points and normals) in place: the mesh is re-expressed in the target frame.
  void transform(const SE3& T_target_mesh);
  /// Appends `other` (its triangles re-indexed). Textures cannot be merged: throws
  /// std::invalid_argument when both meshes carry different textures; colour/uv arrays are filled
  /// with defaults when one side lacks them.
  void append(const TriangleMesh& other);
  /// Largest distance between two vertices (m): exact for up to 3000 vertices, else over the
  /// convex-hull candidates of 64 directions plus a sample (within 0.1% for typical models).
  double diameter() const;
};

/// Bilinear texture lookup at (u, v) in OBJ convention (v up), wrapping around. Returns RGB in [0,
/// 255]. Inline: the rasteriser calls it once per textured pixel.
inline Eigen::Vector3f sample_texture_bilinear(const ColorImage& tex, float u, float v) {
  const int w = tex.width(), h = tex.height();
  // Texel centres at (i + 0.5) / w; v is up, image rows go down.
  const float x = (u - std::floor(u)) * w - 0.5f;
  const float y = (1.0f - (v - std::floor(v))) * h - 0.5f;
  const float fx0 = std::floor(x), fy0 = std::floor(y);
  const float ax = x - fx0, ay = y - fy0;
  int x0 = static_cast<int>(fx0), y0 = static_cast<int>(fy0);
  int x1 = x0 + 1, y1 = y0 + 1;
  // x, y lie in [-0.5, size - 0.5]: only -1 and size need wrapping.
  if (x0 < 0) x0 += w;
  if (x1 >= w) x1 -= w;
  if (y0 < 0) y0 += h;
  if (y1 >= h) y1 -= h;
  x0 = std::clamp(x0, 0, w - 1), x1 = std::clamp(x1, 0, w - 1), y0 = std::clamp(y0, 0, h - 1),
  y1 = std::clamp(y1, 0, h - 1);
  const Rgb8 a = tex.at(x0, y0), b = tex.at(x1, y0), c = tex.at(x0, y1), d = tex.at(x1, y1);
  const float wa = (1 - ax) * (1 - ay), wb = ax * (1 - ay), wc = (1 - ax) * ay, wd = ax * ay;
  return {wa * a.r + wb * b.r + wc * c.r + wd * d.r, wa * a.g + wb * b.g + wc * c.g + wd * d.g,
          wa * a.b + wb * b.b + wc * c.b + wd * d.b};
}

/// Albedo (RGB in [0, 1]) of the surface point with barycentrics `bary` on triangle `tri`.
Eigen::Vector3f surface_albedo(const TriangleMesh& mesh, int tri, const Eigen::Vector3f& bary);

/// Samples `count` points uniformly on the surface (area-weighted), deterministic for a given seed.
/// Optionally returns each point's albedo (RGB8). Metres, object frame.
std::vector<Eigen::Vector3d> sample_surface_points(const TriangleMesh& mesh, size_t count,
                                                   std::uint64_t seed,
                                                   std::vector<Rgb8>* colors = nullptr);

/// Bakes the texture into per-vertex colours (texture colour at each vertex's uv times its colour).
void bake_texture_into_vertex_colors(TriangleMesh& mesh);

}  // namespace orpe
