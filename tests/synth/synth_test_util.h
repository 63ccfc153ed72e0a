// Helpers for the synthetic-scene tests: independent geometry (ray casting, winding numbers) and a
// minimal reader of the BOP files the generator writes.
#pragma once

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "orpe/core/se3.h"
#include "orpe/render/mesh.h"
#include "orpe/synth/synth_params.h"

namespace orpe::test {

/// Small, fast generator settings for tests.
inline SynthParams small_synth(int seed, int frames, bool noise) {
  SynthParams p;
  p.seed = seed;
  p.frames = frames;
  p.objects = 8;
  p.width = 160;
  p.height = 120;
  p.noise = noise;
  p.model_points = 1500;
  p.preview_stride = 0;
  return p;
}

inline nlohmann::json read_json(const std::string& path) {
  std::ifstream is(path);
  if (!is) throw std::runtime_error("cannot open " + path);
  return nlohmann::json::parse(is);
}

inline std::string read_bytes(const std::string& path) {
  std::ifstream is(path, std::ios::binary);
  std::ostringstream ss;
  ss << is.rdbuf();
  return ss.str();
}

/// Every regular file under `dir` (relative path -> bytes).
inline std::map<std::string, std::string> read_tree(const std::string& dir) {
  std::map<std::string, std::string> files;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir))
    if (e.is_regular_file())
      files[std::filesystem::relative(e.path(), dir).string()] = read_bytes(e.path().string());
  return files;
}

/// BOP pose entry -> T_cam_obj in metres.
inline SE3 bop_pose(const nlohmann::json& e) {
  Mat3 R;
  for (int i = 0; i < 9; ++i) R(i / 3, i % 3) = e["cam_R_m2c"][i].get<double>();
  Vec3 t(e["cam_t_m2c"][0].get<double>(), e["cam_t_m2c"][1].get<double>(),
         e["cam_t_m2c"][2].get<double>());
  return SE3(R, t / 1000.0);
}

inline std::vector<Vec3> read_xyz(const std::string& path) {
  std::ifstream is(path);
  std::vector<Vec3> pts;
  double x, y, z;
  while (is >> x >> y >> z) pts.emplace_back(x, y, z);
  return pts;
}

/// Nearest positive ray parameter t (origin 0, direction d) over the mesh's triangles in the given
/// pose, or -1. Moeller-Trumbore in double precision; `edge_tol` widens each triangle (in
/// barycentric units).
inline double ray_cast(const TriangleMesh& mesh, const SE3& T, const Vec3& d,
                       Vec3* normal = nullptr, double edge_tol = 1e-9) {
  double best = -1;
  for (const auto& tri : mesh.triangles) {
    const Vec3 p0 = T * mesh.vertices[tri[0]].cast<double>();
    const Vec3 p1 = T * mesh.vertices[tri[1]].cast<double>();
    const Vec3 p2 = T * mesh.vertices[tri[2]].cast<double>();
    const Vec3 e1 = p1 - p0, e2 = p2 - p0;
    const Vec3 pv = d.cross(e2);
    const double det = e1.dot(pv);
    if (std::abs(det) < 1e-15) continue;
    const double inv = 1.0 / det;
    const Vec3 tv = -p0;
    const double u = tv.dot(pv) * inv;
    if (u < -edge_tol || u > 1 + edge_tol) continue;
    const Vec3 qv = tv.cross(e1);
    const double v = d.dot(qv) * inv;
    if (v < -edge_tol || u + v > 1 + edge_tol) continue;
    const double t = e2.dot(qv) * inv;
    if (t > 1e-6 && (best < 0 || t < best)) {
      best = t;
      if (normal) *normal = e1.cross(e2).normalized();
    }
  }
  return best;
}

/// Generalised winding number of a closed mesh (posed by T) at p: ~1 inside, ~0 outside, 0.5 on the
/// surface.
inline double winding_number(const TriangleMesh& mesh, const SE3& T, const Vec3& p) {
  double total = 0;
  for (const auto& tri : mesh.triangles) {
    const Vec3 a = T * mesh.vertices[tri[0]].cast<double>() - p;
    const Vec3 b = T * mesh.vertices[tri[1]].cast<double>() - p;
    const Vec3 c = T * mesh.vertices[tri[2]].cast<double>() - p;
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    const double num = a.dot(b.cross(c));
    const double den = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
    total += 2.0 * std::atan2(num, den);
  }
  return total / (4.0 * M_PI);
}

}  // namespace orpe::test
