// A float rigid transform for inner loops: explicit, always-inlined arithmetic (Eigen's 3x3 float
// products were emitted out of line in the hot loops and cost ~6% of a frame).
#pragma once

#include <Eigen/Core>

#include "orpe/core/se3.h"

namespace orpe::slam {

struct RigidF {
  float r00, r01, r02, r10, r11, r12, r20, r21, r22;
  float t0, t1, t2;

  RigidF() : RigidF(SE3()) {}
  explicit RigidF(const SE3& T) {
    const Mat3& R = T.rotation();
    r00 = float(R(0, 0)), r01 = float(R(0, 1)), r02 = float(R(0, 2));
    r10 = float(R(1, 0)), r11 = float(R(1, 1)), r12 = float(R(1, 2));
    r20 = float(R(2, 0)), r21 = float(R(2, 1)), r22 = float(R(2, 2));
    t0 = float(T.translation().x()), t1 = float(T.translation().y()), t2 = float(T.translation().z());
  }
  /// R p + t
  Eigen::Vector3f operator()(const Eigen::Vector3f& p) const {
    return {r00 * p.x() + r01 * p.y() + r02 * p.z() + t0, r10 * p.x() + r11 * p.y() + r12 * p.z() + t1,
            r20 * p.x() + r21 * p.y() + r22 * p.z() + t2};
  }
  /// R v
  Eigen::Vector3f rotate(const Eigen::Vector3f& v) const {
    return {r00 * v.x() + r01 * v.y() + r02 * v.z(), r10 * v.x() + r11 * v.y() + r12 * v.z(),
            r20 * v.x() + r21 * v.y() + r22 * v.z()};
  }
  /// R^T v
  Eigen::Vector3f rotate_inverse(const Eigen::Vector3f& v) const {
    return {r00 * v.x() + r10 * v.y() + r20 * v.z(), r01 * v.x() + r11 * v.y() + r21 * v.z(),
            r02 * v.x() + r12 * v.y() + r22 * v.z()};
  }
  /// z component of R p + t only (frustum tests).
  float z(const Eigen::Vector3f& p) const { return r20 * p.x() + r21 * p.y() + r22 * p.z() + t2; }
};

}  // namespace orpe::slam
