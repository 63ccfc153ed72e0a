// An analytic table-top scene for the semantic tests: spheres and boxes on a plane, ray-cast into
// RGB-D frames with ground-truth labels, seen by a camera orbiting the table.
#pragma once

#include <cmath>
#include <limits>
#include <vector>

#include "orpe/core/frame.h"
#include "orpe/core/se3.h"

namespace orpe::test {

struct SceneObject {
  enum class Shape { kSphere, kBox };
  Shape shape = Shape::kSphere;
  int class_id = 1;
  int instance_id = 1;
  Vec3 centre_world = Vec3::Zero();           ///< m
  Vec3 half_extent_m = Vec3::Constant(0.05);  ///< box half sizes; sphere radius = x()
  Rgb8 color{200, 50, 50};

  /// Ray o + t d (t > 0): nearest hit t, or +inf.
  double intersect(const Vec3& o, const Vec3& d) const {
    const double inf = std::numeric_limits<double>::infinity();
    if (shape == Shape::kSphere) {
      const Vec3 oc = o - centre_world;
      const double a = d.squaredNorm(), b = oc.dot(d),
                   c = oc.squaredNorm() - half_extent_m.x() * half_extent_m.x();
      const double disc = b * b - a * c;
      if (disc < 0) return inf;
      const double t = (-b - std::sqrt(disc)) / a;
      return t > 1e-6 ? t : inf;
    }
    double t0 = -inf, t1 = inf;
    for (int k = 0; k < 3; ++k) {
      const double lo = centre_world[k] - half_extent_m[k], hi = centre_world[k] + half_extent_m[k];
      if (std::abs(d[k]) < 1e-12) {
        if (o[k] < lo || o[k] > hi) return inf;
        continue;
      }
      double a = (lo - o[k]) / d[k], b = (hi - o[k]) / d[k];
      if (a > b) std::swap(a, b);
      t0 = std::max(t0, a);
      t1 = std::min(t1, b);
    }
    return (t0 <= t1 && t0 > 1e-6) ? t0 : inf;
  }

  /// Distance of a point from the object's surface (m).
  double surface_distance(const Vec3& p) const {
    if (shape == Shape::kSphere) return std::abs((p - centre_world).norm() - half_extent_m.x());
    const Vec3 q = (p - centre_world).cwiseAbs() - half_extent_m;
    const double outside = q.cwiseMax(0.0).norm();
    const double inside = std::min(q.maxCoeff(), 0.0);
    return std::abs(outside + inside);
  }
};

struct SyntheticScene {
  std::vector<SceneObject> objects;
  double table_half_size_m = 0.6;  ///< table plane z = 0, |x|, |y| <= this
  PinholeIntrinsics K;

  /// Renders frame `index` at `T_world_cam`. labels_gt: k = objects[k - 1]; depth 0 off the table.
  RgbdFrame render(int index, const SE3& T_world_cam) const {
    RgbdFrame f;
    f.index = index;
    f.timestamp_s = index / 30.0;
    f.name = "synthetic-" + std::to_string(index);
    f.intrinsics = K;
    f.color = ColorImage(K.width, K.height);
    f.depth = DepthImage(K.width, K.height, 0.0f);
    f.labels_gt = LabelImage(K.width, K.height, 0);
    f.T_world_cam_gt = T_world_cam;
    const Mat3& R = T_world_cam.rotation();
    const Vec3& o = T_world_cam.translation();
    for (int v = 0; v < K.height; ++v)
      for (int u = 0; u < K.width; ++u) {
        const Vec3 d_cam((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);  // t along it = depth z
        const Vec3 d = R * d_cam;
        double best = std::numeric_limits<double>::infinity();
        int label = 0;
        for (size_t k = 0; k < objects.size(); ++k) {
          const double t = objects[k].intersect(o, d);
          if (t < best) {
            best = t;
            label = static_cast<int>(k) + 1;
          }
        }
        Rgb8 c{};
        if (std::abs(d.z()) > 1e-9) {
          const double t = -o.z() / d.z();
          const Vec3 p = o + t * d;
          if (t > 0 && t < best && std::abs(p.x()) <= table_half_size_m &&
              std::abs(p.y()) <= table_half_size_m) {
            best = t;
            label = 0;
            const bool check = (static_cast<int>(std::floor(p.x() / 0.05)) +
                                static_cast<int>(std::floor(p.y() / 0.05))) %
                               2;
            c = check ? Rgb8{90, 70, 50} : Rgb8{150, 120, 90};
          }
        }
        if (!std::isfinite(best)) continue;
        if (label > 0) c = objects[label - 1].color;
        f.depth.at(u, v) = static_cast<float>(best);
        f.labels_gt.at(u, v) = label;
        f.color.at(u, v) = c;
      }
    const SE3 T_cam_world = T_world_cam.inverse();
    for (const auto& obj : objects) {
      ObjectGroundTruth g;
      g.class_id = obj.class_id;
      g.instance_id = obj.instance_id;
      g.T_cam_obj = T_cam_world * SE3(Mat3::Identity(), obj.centre_world);
      f.objects_gt.push_back(g);
    }
    return f;
  }

  /// Index of the object whose surface is within `tolerance_m` of p and nearer than the table
  /// plane, or -1 (background).
  int object_at(const Vec3& p, double tolerance_m) const {
    int best = -1;
    double best_d = std::min(tolerance_m, std::abs(p.z()));
    for (size_t k = 0; k < objects.size(); ++k) {
      const double dist = objects[k].surface_distance(p);
      if (dist < best_d) {
        best_d = dist;
        best = static_cast<int>(k);
      }
    }
    return best;
  }
};

/// Poses on a circular arc around the table centre.
inline std::vector<SE3> orbit(int frames, double radius_m, double height_m, double arc_deg,
                              double start_deg = 0) {
  std::vector<SE3> poses;
  for (int i = 0; i < frames; ++i) {
    const double a = (start_deg + arc_deg * i / std::max(1, frames - 1)) * M_PI / 180.0;
    poses.push_back(
        look_at(Vec3(radius_m * std::cos(a), radius_m * std::sin(a), height_m), Vec3(0, 0, 0.05)));
  }
  return poses;
}

/// A 3x3 grid of nine objects (spheres and boxes, 8 classes: two instances share class 4).
inline SyntheticScene nine_object_scene(int width = 320, int height = 240) {
  SyntheticScene s;
  s.K.width = width;
  s.K.height = height;
  s.K.fx = s.K.fy = 300.0 * width / 320.0;
  s.K.cx = (width - 1) / 2.0;
  s.K.cy = (height - 1) / 2.0;
  const int classes[9] = {1, 2, 3, 4, 5, 6, 7, 4, 8};
  for (int k = 0; k < 9; ++k) {
    SceneObject o;
    const double x = ((k % 3) - 1) * 0.22, y = ((k / 3) - 1) * 0.22;
    o.class_id = classes[k];
    o.instance_id = 101 + k;
    o.shape = k % 2 ? SceneObject::Shape::kBox : SceneObject::Shape::kSphere;
    if (o.shape == SceneObject::Shape::kSphere) {
      const double r = 0.05 + 0.01 * (k % 3);
      o.half_extent_m = Vec3::Constant(r);
      o.centre_world = Vec3(x, y, r);
    } else {
      o.half_extent_m = Vec3(0.045 + 0.01 * (k % 2), 0.04, 0.05 + 0.015 * (k % 3));
      o.centre_world = Vec3(x, y, o.half_extent_m.z());
    }
    o.color = Rgb8{static_cast<std::uint8_t>(40 + 23 * k), static_cast<std::uint8_t>(200 - 17 * k),
                   static_cast<std::uint8_t>(80 + 31 * (k % 4))};
    s.objects.push_back(o);
  }
  return s;
}

}  // namespace orpe::test
