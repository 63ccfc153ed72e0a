// Pinhole camera model (no distortion: all supported datasets are rectified or distortion-free).
//
// A pixel (u, v) with depth z (metres, along the optical axis) back-projects to
//   x = (u - cx) z / fx,  y = (v - cy) z / fy,  z
// in the camera frame: x right, y down, z forward (OpenCV convention).
#pragma once

#include <Eigen/Core>
#include <string>

namespace orpe {

struct PinholeIntrinsics {
  int width = 640;   ///< pixels
  int height = 480;  ///< pixels
  double fx = 525.0, fy = 525.0;  ///< focal lengths, pixels
  double cx = 319.5, cy = 239.5;  ///< principal point, pixels

  Eigen::Vector3d backproject(double u, double v, double z_m) const {
    return {(u - cx) * z_m / fx, (v - cy) * z_m / fy, z_m};
  }
  /// Projects a camera-frame point. Precondition: p.z() > 0.
  Eigen::Vector2d project(const Eigen::Vector3d& p) const {
    return {fx * p.x() / p.z() + cx, fy * p.y() / p.z() + cy};
  }
  Eigen::Matrix3d K() const {
    Eigen::Matrix3d k;
    k << fx, 0, cx, 0, fy, cy, 0, 0, 1;
    return k;
  }
  /// Intrinsics of the image downsampled by 2^level (pixel centres follow the 2x2 block average).
  PinholeIntrinsics scaled(int level) const;
  bool IsValid(std::string* why) const;

  friend bool operator==(const PinholeIntrinsics&, const PinholeIntrinsics&) = default;
};

}  // namespace orpe
