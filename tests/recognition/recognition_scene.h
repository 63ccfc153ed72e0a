// Test-only tabletop scenes for the recognition tests: objects (analytic shapes) resting on a table
// (z = 0, world frame), seen by a camera looking down at the table; depth by ray-casting the table
// and splatting dense surface samples of the objects into a z-buffer. Exact depth (no noise) unless
// asked.
#pragma once

#include <random>
#include <vector>

#include "orpe/core/frame.h"
#include "orpe/core/se3.h"
#include "pose/synthetic_scene.h"

namespace orpe::test {

struct PlacedObject {
  int class_id = 0;
  const SurfaceSamples* dense = nullptr;  ///< surface samples of the object, object frame
  SE3 T_world_obj;
};

/// The three test classes: 1 = box 0.12 x 0.07 x 0.05, 2 = cylinder r 0.035 h 0.11, 3 = cube 0.045.
struct TestShapes {
  SurfaceSamples box = sample_box({0.12f, 0.07f, 0.05f}, 0.0015f);
  SurfaceSamples can = sample_cylinder(0.035f, 0.11f, 0.0015f);
  SurfaceSamples cube = sample_box({0.045f, 0.045f, 0.045f}, 0.0015f);
  /// Models (coarser samples), class ids 1, 2, 3.
  std::vector<ObjectModel> models() const {
    std::vector<ObjectModel> out;
    ObjectModel b = make_model(sample_box({0.12f, 0.07f, 0.05f}, 0.005f));
    ObjectModel c = make_model(sample_cylinder(0.035f, 0.11f, 0.005f));
    ObjectModel k = make_model(sample_box({0.045f, 0.045f, 0.045f}, 0.005f));
    b.class_id = 1;
    c.class_id = 2;
    k.class_id = 3;
    b.name = "box";
    c.name = "can";
    k.name = "cube";
    out = {b, c, k};
    return out;
  }
  /// Pose resting on the table at (x, y), turned by yaw about z; `half_height` of the shape.
  static SE3 on_table(double x, double y, double yaw_rad, double half_height) {
    return SE3(Eigen::AngleAxisd(yaw_rad, Vec3::UnitZ()).toRotationMatrix(),
               Vec3(x, y, half_height));
  }
};

/// A 320 x 240 frame (f = 300 px) of the objects on the table from a camera at `eye`.
inline RgbdFrame render_table_scene(const std::vector<PlacedObject>& objects,
                                    const Vec3& eye = Vec3(0.05, -0.5, 0.45),
                                    const Vec3& target = Vec3(0, 0, 0.03), double noise_m = 0,
                                    const std::vector<PlacedObject>& occluders = {}) {
  RgbdFrame f;
  f.intrinsics.width = 320;
  f.intrinsics.height = 240;
  f.intrinsics.fx = f.intrinsics.fy = 300;
  f.intrinsics.cx = 159.5;
  f.intrinsics.cy = 119.5;
  const PinholeIntrinsics& K = f.intrinsics;
  const SE3 T_world_cam = look_at(eye, target);
  const SE3 T_cam_world = T_world_cam.inverse();
  f.depth = DepthImage(K.width, K.height, 0.0f);
  f.color = ColorImage(K.width, K.height, Rgb8{128, 128, 128});
  // Table: ray-plane intersection with z = 0 (a 1.2 m square).
  for (int v = 0; v < K.height; ++v)
    for (int u = 0; u < K.width; ++u) {
      const Vec3 ray_cam((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);
      const Vec3 ray_w = T_world_cam.rotation() * ray_cam;
      if (ray_w.z() >= -1e-6) continue;
      const double s = -eye.z() / ray_w.z();
      const Vec3 hit = eye + s * ray_w;
      if (std::abs(hit.x()) > 0.6 || std::abs(hit.y()) > 0.6) continue;
      f.depth.at(u, v) = static_cast<float>(s);  // ray_cam has z = 1: s is the depth
    }
  auto splat = [&](const PlacedObject& o) {
    for (const auto& p : o.dense->points) {
      const Vec3 q = T_cam_world * (o.T_world_obj * p.cast<double>());
      if (q.z() <= 0.05) continue;
      const Eigen::Vector2d px = K.project(q);
      for (int dv = 0; dv <= 1; ++dv)
        for (int du = 0; du <= 1; ++du) {
          const int u = static_cast<int>(std::floor(px.x())) + du;
          const int v = static_cast<int>(std::floor(px.y())) + dv;
          if (!f.depth.in_bounds(u, v)) continue;
          float& z = f.depth.at(u, v);
          if (z == 0 || q.z() < z) z = static_cast<float>(q.z());
        }
    }
  };
  for (const auto& o : objects) splat(o);
  for (const auto& o : occluders) splat(o);
  if (noise_m > 0) {
    std::mt19937 rng(11);
    std::normal_distribution<float> n(0.0f, static_cast<float>(noise_m));
    for (auto& z : f.depth)
      if (z > 0) z += n(rng);
  }
  f.T_world_cam_gt = T_world_cam;
  return f;
}

}  // namespace orpe::test
