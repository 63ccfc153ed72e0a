// A small analytic scene for SLAM tests: a room (seen from inside) with solid boxes, ray cast into
// depth + colour at any camera pose. The colour is a smooth procedural texture of the world point
// so photometric tracking has gradients everywhere.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "orpe/core/camera.h"
#include "orpe/core/frame.h"
#include "orpe/core/se3.h"

namespace orpe::slam::test {

struct Box {
  Vec3 lo, hi;
  bool room = false;  ///< seen from inside (the ray exits it) instead of a solid block
};

struct SyntheticScene {
  std::vector<Box> boxes;
  double texture_detail = 15;  ///< amplitude of the finest texture term (0 = smooth texture only)

  /// One large slab whose front face is the plane z = z0 (world frame).
  static SyntheticScene wall(double z0) {
    SyntheticScene s;
    s.boxes.push_back({Vec3(-20, -20, z0), Vec3(20, 20, z0 + 1), false});
    return s;
  }

  /// A 3 x 2.7 x 4 m room around the origin (the camera looks along +z at its far wall) with boxes
  /// on the floor and the walls, so that every direction of motion is constrained by some surface.
  static SyntheticScene room() {
    SyntheticScene s;
    s.boxes.push_back({Vec3(-1.5, -1.5, -1.0), Vec3(1.5, 1.2, 3.0), true});
    s.boxes.push_back({Vec3(-0.6, 0.6, 1.4), Vec3(-0.1, 1.2, 1.9), false});
    s.boxes.push_back({Vec3(0.3, 0.2, 1.8), Vec3(0.9, 1.2, 2.4), false});
    s.boxes.push_back({Vec3(-1.5, 0.5, 2.2), Vec3(-1.0, 1.2, 2.6), false});
    s.boxes.push_back({Vec3(0.5, -0.8, 2.7), Vec3(1.2, -0.3, 3.0), false});
    s.boxes.push_back({Vec3(-0.9, -1.1, 2.6), Vec3(-0.4, -0.7, 3.0), false});
    s.boxes.push_back({Vec3(-0.2, -0.3, 2.8), Vec3(0.2, 0.1, 3.0), false});
    s.boxes.push_back({Vec3(1.2, -0.6, 1.0), Vec3(1.5, 0.3, 1.6), false});
    s.boxes.push_back({Vec3(-1.5, -0.9, 1.2), Vec3(-1.2, -0.2, 1.9), false});
    return s;
  }

  Rgb8 texture(const Vec3& p) const {
    auto ch = [&](double a, double b, double c, double ph) {
      const double v = 128 + 45 * std::sin(a * p.x() + ph) + 35 * std::sin(b * p.y() + 0.5 * ph) +
                       30 * std::sin(c * p.z() + 1.7 * ph) +
                       texture_detail * std::sin(31 * (p.x() + p.y() + p.z()));
      return static_cast<std::uint8_t>(std::clamp(v, 0.0, 255.0));
    };
    return Rgb8{ch(9, 13, 11, 0.0), ch(12, 8, 15, 1.0), ch(7, 17, 10, 2.0)};
  }

  /// Nearest hit distance t along o + t d (d need not be unit), or +inf.
  double cast(const Vec3& o, const Vec3& d) const {
    double best = std::numeric_limits<double>::infinity();
    for (const Box& b : boxes) {
      double t0 = -std::numeric_limits<double>::infinity(),
             t1 = std::numeric_limits<double>::infinity();
      for (int k = 0; k < 3; ++k) {
        if (std::fabs(d[k]) < 1e-12) {
          if (o[k] < b.lo[k] || o[k] > b.hi[k]) t0 = std::numeric_limits<double>::infinity();
          continue;
        }
        double a = (b.lo[k] - o[k]) / d[k], c = (b.hi[k] - o[k]) / d[k];
        if (a > c) std::swap(a, c);
        t0 = std::max(t0, a);
        t1 = std::min(t1, c);
      }
      if (t0 > t1) continue;
      const double t = b.room ? t1 : t0;
      if (t > 1e-6 && t < best) best = t;
    }
    return best;
  }

  /// Depth (m) and colour of the scene seen from T_world_cam. Depth is the pixel centre's ray;
  /// colour averages `aa` x `aa` rays per pixel (a real lens band-limits the image; aliased texture
  /// would make photometric residuals inconsistent between views).
  RgbdFrame render(const SE3& T_world_cam, const PinholeIntrinsics& K, int index,
                   int aa = 3) const {
    RgbdFrame f;
    f.index = index;
    f.timestamp_s = index / 30.0;
    f.name = "synthetic-" + std::to_string(index);
    f.intrinsics = K;
    f.depth = DepthImage(K.width, K.height, 0.0f);
    f.color = ColorImage(K.width, K.height);
    f.T_world_cam_gt = T_world_cam;
    const Vec3 o = T_world_cam.translation();
    for (int v = 0; v < K.height; ++v)
      for (int u = 0; u < K.width; ++u) {
        const Vec3 dc((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);  // z = 1: t is the depth
        const Vec3 d = T_world_cam.rotation() * dc;
        const double t = cast(o, d);
        if (!std::isfinite(t)) continue;
        f.depth.at(u, v) = static_cast<float>(t);
        double sum[3] = {0, 0, 0};
        int n = 0;
        for (int sy = 0; sy < aa; ++sy)
          for (int sx = 0; sx < aa; ++sx) {
            const double du = (sx + 0.5) / aa - 0.5, dv = (sy + 0.5) / aa - 0.5;
            const Vec3 ds =
                T_world_cam.rotation() * Vec3((u + du - K.cx) / K.fx, (v + dv - K.cy) / K.fy, 1.0);
            const double ts = cast(o, ds);
            if (!std::isfinite(ts)) continue;
            const Rgb8 c = texture(o + ts * ds);
            sum[0] += c.r;
            sum[1] += c.g;
            sum[2] += c.b;
            ++n;
          }
        auto avg = [&](double x) { return static_cast<std::uint8_t>(std::lround(x / n)); };
        f.color.at(u, v) = Rgb8{avg(sum[0]), avg(sum[1]), avg(sum[2])};
      }
    return f;
  }
};

/// The 7-Scenes (Kinect v1) camera, 640 x 480 with f = 585 px, at 1 / `divisor` of its resolution.
inline PinholeIntrinsics kinect_intrinsics(int divisor) {
  PinholeIntrinsics K;
  K.width = 640 / divisor;
  K.height = 480 / divisor;
  K.fx = K.fy = 585.0 / divisor;
  K.cx = 0.5 * K.width - 0.5;
  K.cy = 0.5 * K.height - 0.5;
  return K;
}

inline PinholeIntrinsics small_intrinsics() {
  return kinect_intrinsics(4);
}

/// A smooth hand-held-like trajectory: the camera near (0, -0.2, 0) looking along +z and down,
/// swinging.
inline SE3 trajectory_pose(int i) {
  const double s = i * 0.05;
  const Vec3 t(0.25 * std::sin(s), -0.2 + 0.08 * std::sin(1.7 * s), 0.15 * (1 - std::cos(0.8 * s)));
  // Pitched down by ~0.3 rad so the floor is in view.
  const Vec3 rot(-0.3 + 0.12 * std::sin(0.9 * s), 0.35 * std::sin(0.6 * s),
                 0.05 * std::sin(1.3 * s));
  return SE3(so3_exp(rot), t);
}

}  // namespace orpe::slam::test
