// Parametric meshes: tessellated boxes, cylinders, spheres and quads with texture coordinates.
// Used by the synthetic scene generator (warehouse objects, floors, shelves), by tests and
// benchmarks. All shapes are centred on the origin (a box's centre, a cylinder's mid-height on its
// axis z).
#pragma once

#include <array>

#include "orpe/render/mesh.h"

namespace orpe {

/// A rectangle of texture space (OBJ convention, v up) that one face maps onto.
struct UvRect {
  float u0 = 0, v0 = 0, u1 = 1, v1 = 1;
};

/// Box faces in this order; each face's texture is seen upright from outside: for the four side
/// faces "up" is +z, for the top (+z) "up" is +y, for the bottom (-z) "up" is -y.
enum BoxFace { kBoxPosX = 0, kBoxNegX = 1, kBoxPosY = 2, kBoxNegY = 3, kBoxPosZ = 4, kBoxNegZ = 5 };

/// Axis-aligned box of the given full sizes (m), each face a grid of cells no larger than
/// `max_cell_m` (finer tessellation lets vertex colours carry a texture). Flat per-face normals.
TriangleMesh make_box(const Eigen::Vector3f& size_m, float max_cell_m,
                      const std::array<UvRect, 6>* face_uv = nullptr);

/// Closed cylinder around z: side with `segments` around and rings no taller than `max_cell_m`,
/// caps as concentric rings. Side uv: u = angle / 2pi across `side_uv`, v = height fraction. Caps
/// map the disc onto the square `top_uv` / `bottom_uv`. Smooth side normals, flat caps.
TriangleMesh make_cylinder(float radius_m, float height_m, int segments, float max_cell_m,
                           const UvRect& side_uv = {}, const UvRect& top_uv = {},
                           const UvRect& bottom_uv = {});

/// UV sphere (tests and benchmarks): `segments` around z, `rings` from pole to pole.
TriangleMesh make_sphere(float radius_m, int segments, int rings);

/// Rectangle in the z = 0 plane facing +z, sizes along x and y, `cells_x` x `cells_y` grid, uv
/// covering [0, uv_repeat_x] x [0, uv_repeat_y] (repeat > 1 tiles a texture).
TriangleMesh make_quad(float size_x_m, float size_y_m, int cells_x, int cells_y,
                       float uv_repeat_x = 1, float uv_repeat_y = 1);

}  // namespace orpe
