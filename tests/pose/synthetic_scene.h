// Test-only synthetic objects and scenes: analytic shapes sampled as surface points with outward
// normals (the "model"), and depth images rendered by splatting a dense surface sampling into a
// z-buffer (the "sensor"), with a support plane, an optional occluder and depth noise.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <random>
#include <vector>

#include "orpe/core/camera.h"
#include "orpe/core/image.h"
#include "orpe/core/se3.h"
#include "orpe/pose/object_model.h"

namespace orpe::test {

struct SurfaceSamples {
  std::vector<Eigen::Vector3f> points;
  std::vector<Eigen::Vector3f> normals;
  void add(const Eigen::Vector3f& p, const Eigen::Vector3f& n) {
    points.push_back(p);
    normals.push_back(n);
  }
};

/// Box centred at the origin with edge lengths (sx, sy, sz), sampled on a grid of `step` metres.
inline SurfaceSamples sample_box(const Eigen::Vector3f& size, float step) {
  SurfaceSamples s;
  const Eigen::Vector3f h = size / 2;
  for (int axis = 0; axis < 3; ++axis) {
    const int a = (axis + 1) % 3, b = (axis + 2) % 3;
    const int na = std::max(1, static_cast<int>(std::ceil(size[a] / step)));
    const int nb = std::max(1, static_cast<int>(std::ceil(size[b] / step)));
    for (int sign : {-1, 1})
      for (int i = 0; i <= na; ++i)
        for (int j = 0; j <= nb; ++j) {
          Eigen::Vector3f p;
          p[axis] = sign * h[axis];
          p[a] = -h[a] + size[a] * i / na;
          p[b] = -h[b] + size[b] * j / nb;
          Eigen::Vector3f n = Eigen::Vector3f::Zero();
          n[axis] = static_cast<float>(sign);
          s.add(p, n);
        }
  }
  return s;
}

/// Closed cylinder about z, centred at the origin.
inline SurfaceSamples sample_cylinder(float radius, float height, float step) {
  SurfaceSamples s;
  const int n_around = std::max(8, static_cast<int>(std::ceil(2 * M_PI * radius / step)));
  const int n_up = std::max(1, static_cast<int>(std::ceil(height / step)));
  for (int i = 0; i < n_around; ++i) {
    const float a = static_cast<float>(2 * M_PI * i / n_around);
    const Eigen::Vector3f n(std::cos(a), std::sin(a), 0);
    for (int j = 0; j <= n_up; ++j)
      s.add(Eigen::Vector3f(radius * n.x(), radius * n.y(), -height / 2 + height * j / n_up), n);
  }
  const int n_r = std::max(1, static_cast<int>(std::ceil(radius / step)));
  for (int sign : {-1, 1})
    for (int k = 1; k <= n_r; ++k) {
      const float r = radius * k / n_r;
      const int m = std::max(6, static_cast<int>(std::ceil(2 * M_PI * r / step)));
      for (int i = 0; i < m; ++i) {
        const float a = static_cast<float>(2 * M_PI * i / m);
        s.add(Eigen::Vector3f(r * std::cos(a), r * std::sin(a), sign * height / 2),
              Eigen::Vector3f(0, 0, static_cast<float>(sign)));
      }
    }
  return s;
}

/// An asymmetric "L": a 0.12 x 0.04 x 0.04 bar plus a thinner 0.04 x 0.05 x 0.025 arm at one end,
/// flush with one face (two boxes; inner faces are kept, harmless for splatting and registration).
inline SurfaceSamples sample_l_shape(float step) {
  SurfaceSamples s;
  auto add_box = [&](const Eigen::Vector3f& size, const Eigen::Vector3f& centre) {
    SurfaceSamples b = sample_box(size, step);
    for (size_t i = 0; i < b.points.size(); ++i) s.add(b.points[i] + centre, b.normals[i]);
  };
  add_box({0.12f, 0.04f, 0.04f}, {0.0f, 0.0f, 0.0f});
  add_box({0.04f, 0.05f, 0.025f}, {0.04f, 0.045f, -0.0075f});
  return s;
}

/// A prepared ObjectModel from samples (no symmetry detection unless asked).
inline ObjectModel make_model(const SurfaceSamples& s, bool detect = false) {
  ObjectModel m;
  m.points = s.points;
  m.normals = s.normals;
  prepare_object_model(m);
  if (detect) m.symmetry = detect_symmetry(m);
  return m;
}

struct SyntheticView {
  DepthImage depth;
  MaskImage mask;  ///< visible object pixels
  PinholeIntrinsics K;
};

struct SceneOptions {
  double noise_std_m = 0.0;
  /// Support plane perpendicular to the camera's z-ish axis at this depth (0 = none), tilted a bit.
  double plane_depth_m = 0.0;
  /// Occluder: a box in front of the object covering this fraction of the object's width from the
  /// left (0 = none).
  double occluded_fraction = 0.0;
  unsigned seed = 1;
};

/// Renders the dense object samples at T_cam_obj (plus plane and occluder) into a 640x480 view
/// (f = 600 px: a pixel is 1 mm at 0.6 m, so the samples must be denser than that).
inline SyntheticView render_view(const SurfaceSamples& dense, const SE3& T_cam_obj,
                                 const SceneOptions& opt) {
  SyntheticView v;
  const int W = 640, H = 480;
  v.K.width = W;
  v.K.height = H;
  v.K.fx = v.K.fy = 600;
  v.K.cx = 319.5;
  v.K.cy = 239.5;
  v.depth = DepthImage(W, H, 0.0f);
  LabelImage id(W, H, 0);
  auto splat = [&](const Eigen::Vector3d& p, int label) {
    if (p.z() <= 0.05) return;
    const Eigen::Vector2d uv = v.K.project(p);
    const int u = static_cast<int>(std::lround(uv.x())), w = static_cast<int>(std::lround(uv.y()));
    if (!v.depth.in_bounds(u, w)) return;
    float& z = v.depth.at(u, w);
    if (z == 0 || p.z() < z) {
      z = static_cast<float>(p.z());
      id.at(u, w) = label;
    }
  };
  for (const auto& p : dense.points) splat(T_cam_obj * p.cast<double>(), 1);
  // Object's image extent for the occluder.
  int umin = 1 << 30, umax = -1;
  for (int w = 0; w < H; ++w)
    for (int u = 0; u < W; ++u)
      if (id.at(u, w) == 1) {
        umin = std::min(umin, u);
        umax = std::max(umax, u);
      }
  if (opt.occluded_fraction > 0 && umax >= umin) {
    const int ucut = umin + static_cast<int>(opt.occluded_fraction * (umax - umin));
    const double z_occ = T_cam_obj.translation().z() - 0.12;
    for (int w = 0; w < H; ++w)
      for (int u = 0; u <= ucut; ++u) {
        v.depth.at(u, w) = static_cast<float>(z_occ);
        id.at(u, w) = 2;
      }
  }
  if (opt.plane_depth_m > 0) {
    // Plane z = d + 0.2 y (camera frame), behind everything else.
    for (int w = 0; w < H; ++w)
      for (int u = 0; u < W; ++u) {
        if (v.depth.at(u, w) > 0) continue;
        const double ry = (w - v.K.cy) / v.K.fy;
        const double z = opt.plane_depth_m / (1.0 - 0.2 * ry);
        v.depth.at(u, w) = static_cast<float>(z);
      }
  }
  std::mt19937 rng(opt.seed);
  std::normal_distribution<float> noise(0.0f, static_cast<float>(opt.noise_std_m));
  v.mask = MaskImage(W, H, 0);
  for (int w = 0; w < H; ++w)
    for (int u = 0; u < W; ++u) {
      if (v.depth.at(u, w) > 0 && opt.noise_std_m > 0) v.depth.at(u, w) += noise(rng);
      v.mask.at(u, w) = id.at(u, w) == 1 ? 1 : 0;
    }
  return v;
}

/// ADD-S (m): mean over model points of the distance to the closest point of the other pose.
inline double add_s(const std::vector<Eigen::Vector3f>& pts, const SE3& T_est, const SE3& T_gt) {
  double sum = 0;
  std::vector<Eigen::Vector3d> gt(pts.size());
  for (size_t i = 0; i < pts.size(); ++i) gt[i] = T_gt * pts[i].cast<double>();
  for (const auto& p : pts) {
    const Eigen::Vector3d e = T_est * p.cast<double>();
    double best = 1e30;
    for (const auto& g : gt) best = std::min(best, (g - e).squaredNorm());
    sum += std::sqrt(best);
  }
  return sum / static_cast<double>(pts.size());
}

/// ADD (m): mean distance between corresponding model points.
inline double add(const std::vector<Eigen::Vector3f>& pts, const SE3& T_est, const SE3& T_gt) {
  double sum = 0;
  for (const auto& p : pts) sum += ((T_est * p.cast<double>()) - (T_gt * p.cast<double>())).norm();
  return sum / static_cast<double>(pts.size());
}

}  // namespace orpe::test
