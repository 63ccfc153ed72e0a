// Shared helpers of the SLAM benchmarks: reading the 7-Scenes frames directly (native layout,
// frame-NNNNNN.{color.jpg,depth.png,pose.txt}) and the ATE (rigid Umeyama fit, no scale, RMSE).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include "bench_args.h"
#include "orpe/core/error.h"
#include "orpe/core/frame.h"
#include "orpe/eval/trajectory_metrics.h"
#include "orpe/io/image_io.h"
#include "orpe/pipeline/config.h"

namespace orpe::bench {

inline std::string seven_scenes_dir() {
  return shared_data_dir() + "/7scenes-seq";
}

/// Applies `--set section.key=value` or `--preset NAME` to `config`; prints the error and returns
/// false when the value is not valid.
inline bool apply_config_flag(OrpeConfig& config, const std::string& flag,
                              const std::string& value) {
  try {
    if (flag == "--set")
      apply_config_override(config, value);
    else
      apply_config_preset(config, value);
    return true;
  } catch (const std::exception& e) {
    std::cerr << "error: " << flag << " " << value << ": " << e.what() << "\n";
    return false;
  }
}

/// Ground-truth camera-to-world pose of frame i (frame-NNNNNN.pose.txt), none when the file is
/// absent.
inline std::optional<SE3> load_7scenes_pose(const std::string& dir, int i) {
  char stem[64];
  std::snprintf(stem, sizeof stem, "/frame-%06d", i);
  const std::string pose_path = dir + stem + ".pose.txt";
  std::ifstream is(pose_path);
  if (!is) return std::nullopt;
  Mat4 M;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) is >> M(r, c);
  if (!is) throw IoError(pose_path, "expected a 4x4 matrix");
  return SE3(orthonormalize(M.topLeftCorner<3, 3>()), M.topRightCorner<3, 1>());
}

/// Frame i of the 7-Scenes sequence: depth in mm (1000 units/m unless `depth_units_per_m` says
/// otherwise), fx = fy = 585, cx 320, cy 240.
inline RgbdFrame load_7scenes_frame(const std::string& dir, int i,
                                    double depth_units_per_m = 1000.0) {
  char stem[64];
  std::snprintf(stem, sizeof stem, "/frame-%06d", i);
  RgbdFrame f;
  f.index = i;
  f.timestamp_s = i / 30.0;
  f.name = dir + stem + ".color.jpg";
  f.color = read_color_image(dir + stem + ".color.jpg");
  f.depth = read_depth_image(dir + stem + ".depth.png", depth_units_per_m);
  f.intrinsics.width = f.depth.width();
  f.intrinsics.height = f.depth.height();
  f.intrinsics.fx = f.intrinsics.fy = 585.0;
  f.intrinsics.cx = 320.0;
  f.intrinsics.cy = 240.0;
  f.T_world_cam_gt = load_7scenes_pose(dir, i);
  return f;
}

/// A guess of an unregistered colour camera relative to the depth camera (diagnostic): pinhole with
/// focal `f_px`, principal point (cx + du_px, cy + dv_px) of the depth camera shifted, and the
/// depth camera's origin at `t_color_depth_m` in the colour camera's frame (no rotation).
struct ColorCameraGuess {
  double f_px = 0, tx_m = 0, ty_m = 0, du_px = 0, dv_px = 0;
};

/// Resamples `f.color` onto the depth pixels (nearest colour pixel): each depth pixel with depth is
/// moved into the colour camera and projected; pixels without depth use the direction only.
inline void register_color_to_depth(RgbdFrame& f, const ColorCameraGuess& c) {
  const ColorImage src = f.color;
  const PinholeIntrinsics& K = f.intrinsics;
  const int W = src.width(), H = src.height();
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      const double z = f.depth.at(u, v);
      double x = (u - K.cx) / K.fx, y = (v - K.cy) / K.fy, zc = 1.0;
      if (z > 0) {
        x = x * z + c.tx_m;
        y = y * z + c.ty_m;
        zc = z;
      }
      const int uc =
          std::clamp(static_cast<int>(std::lround(c.f_px * x / zc + K.cx + c.du_px)), 0, W - 1);
      const int vc =
          std::clamp(static_cast<int>(std::lround(c.f_px * y / zc + K.cy + c.dv_px)), 0, H - 1);
      f.color.at(u, v) = src.at(uc, vc);
    }
}

/// Rigid (no scale) least-squares fit est -> gt (the library's Umeyama alignment), then the RMSE of
/// the translation residuals over the first min(est, gt) positions.
inline double ate_rmse(std::vector<Vec3> est, std::vector<Vec3> gt) {
  const size_t n = std::min(est.size(), gt.size());
  if (n == 0) return 0.0;
  est.resize(n);
  gt.resize(n);
  const SimilarityAlignment fit = align_umeyama(est, gt, /*with_scale=*/false);
  double sum = 0;
  for (size_t i = 0; i < n; ++i) sum += (fit.apply(est[i]) - gt[i]).squaredNorm();
  return std::sqrt(sum / double(n));
}

}  // namespace orpe::bench
