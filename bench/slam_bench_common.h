// Shared helpers of the SLAM benchmarks: reading the 7-Scenes frames directly (native layout,
// frame-NNNNNN.{color.jpg,depth.png,pose.txt}) and the ATE (rigid Horn/Umeyama fit, no scale, RMSE).
#pragma once

#include <Eigen/SVD>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "orpe/core/error.h"
#include "orpe/core/frame.h"
#include "orpe/io/image_io.h"

namespace orpe::bench {

inline std::string seven_scenes_dir() {
  if (const char* env = std::getenv("ORPE_DATA_DIR"); env && *env) return std::string(env) + "/7scenes-seq";
  return "/work/shared/data/7scenes-seq";
}

/// Frame i of the 7-Scenes sequence: depth in mm (1000 units/m), fx = fy = 585, cx 320, cy 240.
inline RgbdFrame load_7scenes_frame(const std::string& dir, int i) {
  char stem[64];
  std::snprintf(stem, sizeof stem, "/frame-%06d", i);
  RgbdFrame f;
  f.index = i;
  f.timestamp_s = i / 30.0;
  f.name = dir + stem + ".color.jpg";
  f.color = read_color_image(dir + stem + ".color.jpg");
  f.depth = read_depth_image(dir + stem + ".depth.png", 1000.0);
  f.intrinsics.width = f.depth.width();
  f.intrinsics.height = f.depth.height();
  f.intrinsics.fx = f.intrinsics.fy = 585.0;
  f.intrinsics.cx = 320.0;
  f.intrinsics.cy = 240.0;
  const std::string pose_path = dir + stem + ".pose.txt";
  std::ifstream is(pose_path);
  if (is) {
    Mat4 M;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) is >> M(r, c);
    if (!is) throw IoError(pose_path, "expected a 4x4 matrix");
    f.T_world_cam_gt = SE3(orthonormalize(M.topLeftCorner<3, 3>()), M.topRightCorner<3, 1>());
  }
  return f;
}

/// Rigid (no scale) least-squares fit est -> gt, then the RMSE of the translation residuals.
inline double ate_rmse(const std::vector<Vec3>& est, const std::vector<Vec3>& gt, SE3* T_gt_est = nullptr) {
  const size_t n = std::min(est.size(), gt.size());
  if (n == 0) return 0.0;
  Vec3 me = Vec3::Zero(), mg = Vec3::Zero();
  for (size_t i = 0; i < n; ++i) {
    me += est[i];
    mg += gt[i];
  }
  me /= double(n);
  mg /= double(n);
  Mat3 S = Mat3::Zero();
  for (size_t i = 0; i < n; ++i) S += (gt[i] - mg) * (est[i] - me).transpose();
  Eigen::JacobiSVD<Mat3> svd(S, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 D = Mat3::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) D(2, 2) = -1;
  const Mat3 R = svd.matrixU() * D * svd.matrixV().transpose();
  const Vec3 t = mg - R * me;
  double sum = 0;
  for (size_t i = 0; i < n; ++i) sum += (R * est[i] + t - gt[i]).squaredNorm();
  if (T_gt_est) *T_gt_est = SE3(R, t);
  return std::sqrt(sum / double(n));
}

}  // namespace orpe::bench
