#include "orpe/render/mesh.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

namespace orpe {

bool TriangleMesh::IsValid(std::string* why) const {
  auto fail = [&](const std::string& msg) {
    if (why) *why = msg;
    return false;
  };
  const size_t n = vertices.size();
  if (!normals.empty() && normals.size() != n)
    return fail("normals must be empty or one per vertex");
  if (!colors.empty() && colors.size() != n) return fail("colors must be empty or one per vertex");
  if (!uvs.empty() && uvs.size() != n) return fail("uvs must be empty or one per vertex");
  for (const auto& v : vertices)
    if (!v.allFinite()) return fail("non-finite vertex coordinate");
  for (const auto& nv : normals)
    if (!nv.allFinite()) return fail("non-finite normal");
  for (const auto& t : uvs)
    if (!t.allFinite()) return fail("non-finite texture coordinate");
  for (const auto& t : triangles)
    for (int k = 0; k < 3; ++k)
      if (t[k] < 0 || static_cast<size_t>(t[k]) >= n)
        return fail("triangle vertex index " + std::to_string(t[k]) + " out of range (" +
                    std::to_string(n) + " vertices)");
  return true;
}

void TriangleMesh::compute_vertex_normals() {
  std::vector<Eigen::Vector3d> acc(vertices.size(), Eigen::Vector3d::Zero());
  for (const auto& t : triangles) {
    const Eigen::Vector3d a = vertices[t[0]].cast<double>();
    const Eigen::Vector3d b = vertices[t[1]].cast<double>();
    const Eigen::Vector3d c = vertices[t[2]].cast<double>();
    const Eigen::Vector3d n = (b - a).cross(c - a);  // length = 2 * area: area weighting
    for (int k = 0; k < 3; ++k) acc[t[k]] += n;
  }
  normals.resize(vertices.size());
  for (size_t i = 0; i < acc.size(); ++i) {
    const double len = acc[i].norm();
    normals[i] = len > 0 ? Eigen::Vector3f((acc[i] / len).cast<float>()) : Eigen::Vector3f::UnitZ();
  }
}

Eigen::AlignedBox3f TriangleMesh::bounds() const {
  Eigen::AlignedBox3f box;
  for (const auto& v : vertices) box.extend(v);
  return box;
}

double TriangleMesh::surface_area() const {
  double area = 0;
  for (const auto& t : triangles) {
    const Eigen::Vector3d a = vertices[t[0]].cast<double>();
    area +=
        0.5 * (vertices[t[1]].cast<double>() - a).cross(vertices[t[2]].cast<double>() - a).norm();
  }
  return area;
}

void TriangleMesh::transform(const SE3& T) {
  const Eigen::Matrix3f R = T.rotation().cast<float>();
  for (auto& v : vertices) v = (T.rotation() * v.cast<double>() + T.translation()).cast<float>();
  for (auto& n : normals) n = R * n;
}

void TriangleMesh::append(const TriangleMesh& other) {
  if (other.has_texture() && has_texture() && other.texture != texture)
    throw std::invalid_argument("TriangleMesh::append: cannot merge two different textures");
  const int offset = static_cast<int>(vertices.size());
  const size_t n_self = vertices.size(), n_other = other.vertices.size();
  // Colours/uvs/normals: keep an array if either side has it, filling the other side with defaults.
  auto merge = [&](auto& mine, const auto& theirs, const auto& fill) {
    if (mine.empty() && theirs.empty()) return;
    if (mine.empty()) mine.assign(n_self, fill);
    if (theirs.empty())
      mine.insert(mine.end(), n_other, fill);
    else
      mine.insert(mine.end(), theirs.begin(), theirs.end());
  };
  if (!other.normals.empty() && normals.empty() && n_self > 0) compute_vertex_normals();
  merge(normals, other.normals, Eigen::Vector3f::UnitZ().eval());
  merge(colors, other.colors, Rgb8{255, 255, 255});
  merge(uvs, other.uvs, Eigen::Vector2f::Zero().eval());
  if (!texture) texture = other.texture;
  vertices.insert(vertices.end(), other.vertices.begin(), other.vertices.end());
  for (const auto& t : other.triangles) triangles.push_back(t + Eigen::Vector3i::Constant(offset));
  if (normals.size() != vertices.size() && !normals.empty()) compute_vertex_normals();
}

double TriangleMesh::diameter() const {
  const size_t n = vertices.size();
  if (n < 2) return 0.0;
  auto farthest_from = [&](const Eigen::Vector3f& p) {
    double best = 0;
    for (const auto& q : vertices)
      best = std::max(best, static_cast<double>((q - p).squaredNorm()));
    return best;
  };
  double best_sq = 0;
  if (n <= 3000) {
    for (size_t i = 0; i < n; ++i)
      for (size_t j = i + 1; j < n; ++j)
        best_sq = std::max(best_sq, static_cast<double>((vertices[i] - vertices[j]).squaredNorm()));
    return std::sqrt(best_sq);
  }
  // Candidates: extreme vertices along directions of a Fibonacci sphere; the diameter's end points
  // are hull vertices, extreme in some direction. Then exact farthest-point from each candidate.
  std::vector<size_t> candidates;
  const int dirs = 128;
  for (int k = 0; k < dirs; ++k) {
    const double z = 1.0 - (2.0 * k + 1.0) / dirs;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = k * 2.399963229728653;  // golden angle
    const Eigen::Vector3f d(static_cast<float>(r * std::cos(phi)),
                            static_cast<float>(r * std::sin(phi)), static_cast<float>(z));
    size_t imax = 0;
    float vmax = -1e30f;
    for (size_t i = 0; i < n; ++i) {
      const float s = d.dot(vertices[i]);
      if (s > vmax) vmax = s, imax = i;
    }
    candidates.push_back(imax);
  }
  std::sort(candidates.begin(), candidates.end());
  candidates.erase(std::unique(candidates.begin(), candidates.end()), candidates.end());
  for (size_t c : candidates) best_sq = std::max(best_sq, farthest_from(vertices[c]));
  return std::sqrt(best_sq);
}

Eigen::Vector3f surface_albedo(const TriangleMesh& mesh, int tri, const Eigen::Vector3f& bary) {
  const Eigen::Vector3i& t = mesh.triangles[tri];
  Eigen::Vector3f albedo(mesh.base_color.r, mesh.base_color.g, mesh.base_color.b);
  albedo /= 255.0f;
  if (!mesh.colors.empty()) {
    Eigen::Vector3f c = Eigen::Vector3f::Zero();
    for (int k = 0; k < 3; ++k) {
      const Rgb8 vc = mesh.colors[t[k]];
      c += bary[k] * Eigen::Vector3f(vc.r, vc.g, vc.b);
    }
    albedo = albedo.cwiseProduct(c / 255.0f);
  }
  if (mesh.has_texture()) {
    const Eigen::Vector2f uv =
        bary[0] * mesh.uvs[t[0]] + bary[1] * mesh.uvs[t[1]] + bary[2] * mesh.uvs[t[2]];
    albedo = albedo.cwiseProduct(sample_texture_bilinear(*mesh.texture, uv.x(), uv.y()) / 255.0f);
  }
  return albedo;
}

std::vector<Eigen::Vector3d> sample_surface_points(const TriangleMesh& mesh, size_t count,
                                                   std::uint64_t seed, std::vector<Rgb8>* colors) {
  std::vector<Eigen::Vector3d> points;
  if (colors) colors->clear();
  if (mesh.triangles.empty() || count == 0) return points;
  std::vector<double> cdf(mesh.triangles.size());
  double total = 0;
  for (size_t i = 0; i < mesh.triangles.size(); ++i) {
    const auto& t = mesh.triangles[i];
    const Eigen::Vector3d a = mesh.vertices[t[0]].cast<double>();
    total += 0.5 * (mesh.vertices[t[1]].cast<double>() - a)
                       .cross(mesh.vertices[t[2]].cast<double>() - a)
                       .norm();
    cdf[i] = total;
  }
  if (!(total > 0)) return points;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  points.reserve(count);
  for (size_t s = 0; s < count; ++s) {
    const double r = uni(rng) * total;
    const size_t i =
        std::min(cdf.size() - 1,
                 static_cast<size_t>(std::upper_bound(cdf.begin(), cdf.end(), r) - cdf.begin()));
    double b1 = uni(rng), b2 = uni(rng);
    if (b1 + b2 > 1) b1 = 1 - b1, b2 = 1 - b2;
    const auto& t = mesh.triangles[i];
    const Eigen::Vector3d a = mesh.vertices[t[0]].cast<double>();
    const Eigen::Vector3d p = a + b1 * (mesh.vertices[t[1]].cast<double>() - a) +
                              b2 * (mesh.vertices[t[2]].cast<double>() - a);
    points.push_back(p);
    if (colors) {
      const Eigen::Vector3f alb =
          surface_albedo(mesh, static_cast<int>(i),
                         Eigen::Vector3f(static_cast<float>(1 - b1 - b2), static_cast<float>(b1),
                                         static_cast<float>(b2)));
      auto q = [](float x) {
        return static_cast<std::uint8_t>(std::clamp(x * 255.0f + 0.5f, 0.0f, 255.0f));
      };
      colors->push_back({q(alb.x()), q(alb.y()), q(alb.z())});
    }
  }
  return points;
}

void bake_texture_into_vertex_colors(TriangleMesh& mesh) {
  if (!mesh.has_texture()) return;
  if (mesh.colors.empty()) mesh.colors.assign(mesh.vertices.size(), Rgb8{255, 255, 255});
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Eigen::Vector3f t =
        sample_texture_bilinear(*mesh.texture, mesh.uvs[i].x(), mesh.uvs[i].y());
    Rgb8& c = mesh.colors[i];
    auto mul = [](std::uint8_t a, float b) {
      return static_cast<std::uint8_t>(std::clamp(a * b / 255.0f + 0.5f, 0.0f, 255.0f));
    };
    c = {mul(c.r, t.x()), mul(c.g, t.y()), mul(c.b, t.z())};
  }
}

}  // namespace orpe
