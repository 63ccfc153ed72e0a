#include "orpe/render/primitives.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace orpe {
namespace {

int cells_for(float length, float max_cell) {
  if (!(max_cell > 0)) return 1;
  return std::max(1, static_cast<int>(std::ceil(length / max_cell - 1e-4f)));
}

/// Adds a planar grid: origin corner + i/nr * right_len * r + j/nu * up_len * u, normal r x u.
void add_grid(TriangleMesh& m, const Eigen::Vector3f& corner, const Eigen::Vector3f& right,
              const Eigen::Vector3f& up, int nr, int nu, const UvRect& uv) {
  const int base = static_cast<int>(m.vertices.size());
  const Eigen::Vector3f n = right.cross(up).normalized();
  for (int j = 0; j <= nu; ++j)
    for (int i = 0; i <= nr; ++i) {
      const float a = static_cast<float>(i) / nr, b = static_cast<float>(j) / nu;
      m.vertices.push_back(corner + a * right + b * up);
      m.normals.push_back(n);
      m.uvs.emplace_back(uv.u0 + a * (uv.u1 - uv.u0), uv.v0 + b * (uv.v1 - uv.v0));
    }
  auto idx = [&](int i, int j) { return base + j * (nr + 1) + i; };
  for (int j = 0; j < nu; ++j)
    for (int i = 0; i < nr; ++i) {
      m.triangles.emplace_back(idx(i, j), idx(i + 1, j), idx(i + 1, j + 1));
      m.triangles.emplace_back(idx(i, j), idx(i + 1, j + 1), idx(i, j + 1));
    }
}

}  // namespace

TriangleMesh make_box(const Eigen::Vector3f& size, float max_cell_m,
                      const std::array<UvRect, 6>* face_uv) {
  TriangleMesh m;
  m.name = "box";
  const Eigen::Vector3f h = 0.5f * size;
  const Eigen::Vector3f X = Eigen::Vector3f::UnitX(), Y = Eigen::Vector3f::UnitY(),
                        Z = Eigen::Vector3f::UnitZ();
  struct Face {
    Eigen::Vector3f normal, right, up;
    float len_r, len_u;
  };
  const Face faces[6] = {
      {X, Y, Z, size.y(), size.z()},  {-X, -Y, Z, size.y(), size.z()},
      {Y, -X, Z, size.x(), size.z()}, {-Y, X, Z, size.x(), size.z()},
      {Z, X, Y, size.x(), size.y()},  {-Z, X, -Y, size.x(), size.y()},
  };
  for (int f = 0; f < 6; ++f) {
    const Face& fc = faces[f];
    const Eigen::Vector3f centre = fc.normal.cwiseProduct(h);
    const Eigen::Vector3f corner = centre - 0.5f * fc.len_r * fc.right - 0.5f * fc.len_u * fc.up;
    add_grid(m, corner, fc.len_r * fc.right, fc.len_u * fc.up, cells_for(fc.len_r, max_cell_m),
             cells_for(fc.len_u, max_cell_m), face_uv ? (*face_uv)[f] : UvRect{});
  }
  return m;
}

TriangleMesh make_cylinder(float radius, float height, int segments, float max_cell_m,
                           const UvRect& side_uv, const UvRect& top_uv, const UvRect& bottom_uv) {
  TriangleMesh m;
  m.name = "cylinder";
  segments = std::max(segments, 3);
  const int rings = cells_for(height, max_cell_m);
  const float two_pi = 2.0f * std::numbers::pi_v<float>;
  // Side, with a seam column duplicated so u runs 0..1.
  const int side_base = static_cast<int>(m.vertices.size());
  for (int k = 0; k <= rings; ++k) {
    const float b = static_cast<float>(k) / rings;
    const float z = -0.5f * height + b * height;
    for (int s = 0; s <= segments; ++s) {
      const float a = static_cast<float>(s) / segments;
      const float th = a * two_pi;
      const float c = std::cos(th), sn = std::sin(th);
      m.vertices.emplace_back(radius * c, radius * sn, z);
      m.normals.emplace_back(c, sn, 0.0f);
      m.uvs.emplace_back(side_uv.u0 + a * (side_uv.u1 - side_uv.u0),
                         side_uv.v0 + b * (side_uv.v1 - side_uv.v0));
    }
  }
  auto sidx = [&](int s, int k) { return side_base + k * (segments + 1) + s; };
  for (int k = 0; k < rings; ++k)
    for (int s = 0; s < segments; ++s) {
      m.triangles.emplace_back(sidx(s, k), sidx(s + 1, k), sidx(s + 1, k + 1));
      m.triangles.emplace_back(sidx(s, k), sidx(s + 1, k + 1), sidx(s, k + 1));
    }
  // Caps: centre vertex + concentric rings.
  const int cap_rings = cells_for(radius, max_cell_m);
  for (int cap = 0; cap < 2; ++cap) {
    const bool top = cap == 0;
    const float z = top ? 0.5f * height : -0.5f * height;
    const Eigen::Vector3f n(0, 0, top ? 1.0f : -1.0f);
    const UvRect& uv = top ? top_uv : bottom_uv;
    auto uv_of = [&](float x, float y) {
      const float a = 0.5f + x / (2 * radius);
      const float b = top ? 0.5f + y / (2 * radius) : 0.5f - y / (2 * radius);
      return Eigen::Vector2f(uv.u0 + a * (uv.u1 - uv.u0), uv.v0 + b * (uv.v1 - uv.v0));
    };
    const int centre = static_cast<int>(m.vertices.size());
    m.vertices.emplace_back(0.0f, 0.0f, z);
    m.normals.push_back(n);
    m.uvs.push_back(uv_of(0, 0));
    const int ring_base = static_cast<int>(m.vertices.size());
    for (int k = 1; k <= cap_rings; ++k) {
      const float r = radius * static_cast<float>(k) / cap_rings;
      for (int s = 0; s < segments; ++s) {
        const float th = two_pi * static_cast<float>(s) / segments;
        const float x = r * std::cos(th), y = r * std::sin(th);
        m.vertices.emplace_back(x, y, z);
        m.normals.push_back(n);
        m.uvs.push_back(uv_of(x, y));
      }
    }
    auto ridx = [&](int k, int s) { return ring_base + (k - 1) * segments + (s % segments); };
    auto add = [&](int a, int b, int c) {
      if (top)
        m.triangles.emplace_back(a, b, c);
      else
        m.triangles.emplace_back(a, c, b);
    };
    for (int s = 0; s < segments; ++s) add(centre, ridx(1, s), ridx(1, s + 1));
    for (int k = 1; k < cap_rings; ++k)
      for (int s = 0; s < segments; ++s) {
        add(ridx(k, s), ridx(k + 1, s), ridx(k + 1, s + 1));
        add(ridx(k, s), ridx(k + 1, s + 1), ridx(k, s + 1));
      }
  }
  return m;
}

TriangleMesh make_sphere(float radius, int segments, int rings) {
  TriangleMesh m;
  m.name = "sphere";
  segments = std::max(segments, 3);
  rings = std::max(rings, 2);
  const float pi = std::numbers::pi_v<float>;
  for (int k = 0; k <= rings; ++k) {
    const float phi = pi * static_cast<float>(k) / rings;  // from +z pole
    for (int s = 0; s <= segments; ++s) {
      const float th = 2 * pi * static_cast<float>(s) / segments;
      const Eigen::Vector3f n(std::sin(phi) * std::cos(th), std::sin(phi) * std::sin(th),
                              std::cos(phi));
      m.vertices.push_back(radius * n);
      m.normals.push_back(n);
      m.uvs.emplace_back(static_cast<float>(s) / segments, 1.0f - static_cast<float>(k) / rings);
    }
  }
  auto idx = [&](int s, int k) { return k * (segments + 1) + s; };
  for (int k = 0; k < rings; ++k)
    for (int s = 0; s < segments; ++s) {
      // Going down (k+1) and around (s+1): down x around = outward.
      if (k > 0) m.triangles.emplace_back(idx(s, k), idx(s, k + 1), idx(s + 1, k));
      if (k + 1 < rings) m.triangles.emplace_back(idx(s + 1, k), idx(s, k + 1), idx(s + 1, k + 1));
    }
  return m;
}

TriangleMesh make_quad(float size_x, float size_y, int cells_x, int cells_y, float repeat_x,
                       float repeat_y) {
  TriangleMesh m;
  m.name = "quad";
  add_grid(m, Eigen::Vector3f(-0.5f * size_x, -0.5f * size_y, 0), Eigen::Vector3f(size_x, 0, 0),
           Eigen::Vector3f(0, size_y, 0), std::max(1, cells_x), std::max(1, cells_y),
           UvRect{0, 0, repeat_x, repeat_y});
  return m;
}

}  // namespace orpe
