// Scene geometry for model-based recognition: the frame's depth as a grid of camera-frame points,
// support planes (table, floor, shelf boards, walls) found by RANSAC and removed, and the rest
// split into connected regions at depth discontinuities. No ground truth, no colour: depth and
// intrinsics only.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "orpe/core/camera.h"
#include "orpe/core/image.h"
#include "orpe/core/plane_fit.h"

namespace orpe {

struct SceneGeometryParams {
  int grid_stride_px = 2;    ///< sample every n-th pixel in both directions
  double min_depth_m = 0.1;  ///< depths outside [min, max] are ignored
  double max_depth_m = 3.0;
  int max_planes = 3;                ///< support planes removed (largest first)
  double plane_distance_m = 0.012;   ///< a point this close to a plane is on it (removed)
  double min_plane_fraction = 0.08;  ///< a plane needs this fraction of the valid points
  double min_plane_extent_m = 0.35;  ///< and inliers spread over at least this (2 sigma, both axes)
  int plane_iterations = 300;        ///< RANSAC samples per plane
  double max_seen_below_fraction = 0.4;    ///< of the surface over a plane seen below it (1 = off)
  double max_height_above_plane_m = 0.45;  ///< points farther above the first plane are dropped
  double region_distance_m =
      0.008;  ///< neighbours closer than this + region_distance_per_m * z join
  double region_distance_per_m = 0.006;
  int min_region_points = 150;  ///< smaller regions are dropped (grid points) unless:
  /// a region of at least small_region_min_points grid points whose surface, as the camera sees
  /// it, covers at least min_region_area_m2 is kept too: a known object far away or in a
  /// low-resolution image (a can at 1.3 m in a 320 x 240 image: ~120 grid points, ~100 cm^2).
  int small_region_min_points = 40;
  double min_region_area_m2 = 0.002;  ///< 20 cm^2; 0 = off (grid points alone)
  double concave_edge_min_angle_deg =
      35;                             ///< regions split at concave creases this sharp (0 = off)
  int concave_edge_radius_cells = 3;  ///< normals and crease sides this many cells out
  int seed = 7;

  template <class V>
  void visit(V&& v) {
    v("grid_stride_px", grid_stride_px, "Recognition works on every n-th pixel (both directions)");
    v("min_depth_m", min_depth_m, "Depths below this (m) are ignored");
    v("max_depth_m", max_depth_m, "Depths above this (m) are ignored");
    v("max_planes", max_planes, "Support planes (table, floor, walls) removed, largest first");
    v("plane_distance_m", plane_distance_m,
      "Points within this distance (m) of a plane are removed");
    v("min_plane_fraction", min_plane_fraction,
      "A support plane holds at least this fraction of the valid points");
    v("min_plane_extent_m", min_plane_extent_m,
      "A support plane's inliers spread at least this far (m, 4 sigma) in both in-plane directions "
      "(an object's face is not a support plane)");
    v("plane_iterations", plane_iterations, "RANSAC samples per plane");
    v("max_seen_below_fraction", max_seen_below_fraction,
      "A support hides what is below it: a plane whose inliers' convex hull (in the plane) has "
      "more "
      "than this fraction of the observed points over it below the plane is no support (the "
      "coplanar tops of objects of one height, with the table seen between them); 1 = no test");
    v("max_height_above_plane_m", max_height_above_plane_m,
      "Points farther than this (m) above the first support plane are dropped; 0 = keep");
    v("region_distance_m", region_distance_m,
      "Neighbouring grid points closer than this (m, plus region_distance_per_m * depth) are one "
      "region");
    v("region_distance_per_m", region_distance_per_m,
      "Depth-proportional part of the region distance (m per m of depth)");
    v("min_region_points", min_region_points,
      "Regions with fewer grid points are dropped, unless small_region_min_points and "
      "min_region_area_m2 keep them");
    v("small_region_min_points", small_region_min_points,
      "A region under min_region_points is kept when it has at least this many grid points and "
      "covers min_region_area_m2 (far objects, low-resolution cameras)");
    v("min_region_area_m2", min_region_area_m2,
      "Surface (m^2, the area of its grid cells' pixels at their depth, as the camera sees it) "
      "that keeps a region of small_region_min_points to min_region_points grid points; 0 = off");
    v("concave_edge_min_angle_deg", concave_edge_min_angle_deg,
      "Regions are also split where the surface folds inwards (a concave crease, the normals of "
      "its two sides at least this angle apart, deg): objects are mostly convex, and where one "
      "rests on or leans against another the two surfaces meet in a concave crease without a "
      "depth step; 0 = split at depth steps only");
    v("concave_edge_radius_cells", concave_edge_radius_cells,
      "Crease test: the two sides' normals (plane fits over (2 r + 1)^2 cells) taken this many "
      "grid cells out from the link tested");
    v("seed", seed, "Seed of the RANSAC sampling");
  }
  bool IsValid(std::string* why) const;
};

// Planes (orpe/core/plane_fit.h) here are in the camera frame, oriented towards the camera (d > 0).

struct SceneGrid {
  int stride = 2;
  double fx = 1, fy = 1;                ///< the image's focal lengths (px)
  int width = 0, height = 0;            ///< grid size (image size / stride)
  std::vector<Eigen::Vector3f> points;  ///< per grid cell, camera frame; z = 0 when invalid
  std::vector<std::uint8_t> valid;      ///< valid depth
  std::vector<std::uint8_t> kept;       ///< valid and not removed with a plane
  std::vector<int> region;              ///< region index per cell, -1 = none
  std::vector<Plane> planes;            ///< removed support planes, first = the support

  int cell(int gu, int gv) const { return gv * width + gu; }
  int pixel_u(int c) const { return (c % width) * stride; }
  int pixel_v(int c) const { return (c / width) * stride; }
};

struct SceneRegion {
  std::vector<int> cells;  ///< grid cells
  Eigen::Vector3f centroid = Eigen::Vector3f::Zero();
  float extent_m = 0;  ///< diagonal of the axis-aligned box of its points
};

/// Unit normals of the grid's kept cells (plane fit over the (2 radius + 1)^2 window's kept cells
/// within 1 cm of the centre's depth), computed on demand and cached; zero when the window has
/// fewer than 6 such points. Sign arbitrary.
class GridNormals {
 public:
  GridNormals(const SceneGrid& g, int radius);
  const Eigen::Vector3f& at(int c);

 private:
  Eigen::Vector3f fit(int c) const;
  const SceneGrid& g_;
  int r_;
  std::vector<Eigen::Vector3f> n_;
  std::vector<std::uint8_t> done_;
};

/// Whether the link from cell a to its neighbour a + (du, dv) crosses a concave crease: the cells
/// `radius` further out on either side (a - radius (du, dv), a + (radius + 1) (du, dv)), their
/// normals turned towards the camera with a dot product under `min_cos`, and each side in front
/// of the other's tangent plane (the surface folds towards the viewer, (n_a - n_b) . (p_b - p_a)
/// > 0.25 |p_b - p_a|; a convex edge, such as a box's own, folds away). False when a side is
/// off the grid, not kept or has no normal.
bool concave_link(const SceneGrid& g, GridNormals& normals, int a, int du, int dv, int radius,
                  float min_cos);

/// Surface the cells cover as the camera sees it (m^2): per cell, its stride x stride pixels'
/// footprint at the cell's depth.
double seen_area_m2(const SceneGrid& grid, const std::vector<int>& cells);
/// A region (or a region's unexplained rest) large enough to search: min_region_points grid points,
/// or small_region_min_points with min_region_area_m2 of surface.
bool region_large_enough(const SceneGrid& grid, const std::vector<int>& cells,
                         const SceneGeometryParams& params);

/// Back-projects every stride-th pixel's depth.
SceneGrid make_scene_grid(const DepthImage& depth, const PinholeIntrinsics& K,
                          const SceneGeometryParams& params);
/// Finds and removes support planes (grid.kept, grid.planes). Deterministic.
void remove_support_planes(SceneGrid& grid, const SceneGeometryParams& params);
/// Connected regions of the kept cells (4-neighbourhood, split at depth discontinuities and, with
/// concave_edge_min_angle_deg > 0, at concave creases); fills grid.region. The cells next to a
/// crease that the cut leaves in fragments under min_region_points join the region they touch
/// (depth rule only); other regions under min_region_points are dropped. Sorted by size, largest
/// first.
std::vector<SceneRegion> split_regions(SceneGrid& grid, const SceneGeometryParams& params);

/// Extents (m) of points along their principal axes, largest first. With `min_area`, the two
/// dominant axes are turned (5-degree steps) to the bounding rectangle of least area: on a face
/// close to square the principal axes are arbitrary (often the diagonals, whose extents exceed the
/// face's sides), the least-area rectangle is the face's own.
Eigen::Vector3f principal_extents(const std::vector<Eigen::Vector3f>& pts, bool min_area = true);

}  // namespace orpe
