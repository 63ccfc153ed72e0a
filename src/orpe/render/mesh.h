// Triangle meshes for rendering and for model points: vertices in metres in the object's own frame.
//
// Conventions:
//  - Triangles are wound counter-clockwise seen from outside (right-hand normal points outwards).
//    The rasteriser does not rely on it unless back-face culling is switched on.
//  - UVs follow the OBJ/PLY convention: (0, 0) is the bottom-left of the texture image, v points up.
//    Texture lookups are bilinear and wrap around outside [0, 1].
//  - Albedo of a surface point = base colour, times the interpolated vertex colour when present, times
//    the texture colour when UVs and a texture are present (each factor in [0, 1] per channel).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "orpe/core/image.h"
#include "orpe/core/se3.h"

namespace orpe {

struct TriangleMesh {
  std::string name;                        ///< for messages (e.g. the file it came from)
  std::vector<Eigen::Vector3f> vertices;   ///< metres, object frame
  std::vector<Eigen::Vector3f> normals;    ///< unit, per vertex; empty = call compute_vertex_normals()
  std::vector<Rgb8> colors;                ///< per vertex; optional (empty)
  std::vector<Eigen::Vector2f> uvs;        ///< per vertex; optional, used with `texture`
  std::shared_ptr<const ColorImage> texture;  ///< optional RGB8 texture image
  std::vector<Eigen::Vector3i> triangles;  ///< vertex indices, CCW seen from outside
  Rgb8 base_color{255, 255, 255};          ///< albedo factor; a mesh without colours renders in this

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
  /// Appends `other` (its triangles re-indexed). Textures cannot be merged: throws std::invalid_argument
  /// when both meshes carry different textures; colour/uv arrays are filled with defaults when one side lacks them.
  void append(const TriangleMesh& other);
  /// Largest distance between two vertices (m): exact for up to 3000 vertices, else over the convex-hull
  /// candidates of 64 directions plus a sample (within 0.1% for typical models).
  double diameter() const;
};

/// Bilinear texture lookup at (u, v) in OBJ convention (v up), wrapping around. Returns RGB in [0, 255].
Eigen::Vector3f sample_texture_bilinear(const ColorImage& texture, float u, float v);

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
