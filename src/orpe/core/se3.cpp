#include "orpe/core/se3.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>

namespace orpe {

Mat3 hat(const Vec3& a) {
  Mat3 m;
  m << 0, -a.z(), a.y(), a.z(), 0, -a.x(), -a.y(), a.x(), 0;
  return m;
}

Mat3 so3_exp(const Vec3& phi) {
  const double theta2 = phi.squaredNorm();
  const Mat3 K = hat(phi);
  double a, b;  // R = I + a K + b K^2
  if (theta2 < 1e-12) {
    a = 1.0 - theta2 / 6.0;
    b = 0.5 - theta2 / 24.0;
  } else {
    const double theta = std::sqrt(theta2);
    a = std::sin(theta) / theta;
    b = (1.0 - std::cos(theta)) / theta2;
  }
  return Mat3::Identity() + a * K + b * K * K;
}

Vec3 so3_log(const Mat3& R) {
  const double cos_theta = std::clamp((R.trace() - 1.0) * 0.5, -1.0, 1.0);
  const Vec3 w(R(2, 1) - R(1, 2), R(0, 2) - R(2, 0), R(1, 0) - R(0, 1));  // 2 sin(theta) axis
  const double sin_theta = 0.5 * w.norm();
  const double theta = std::atan2(sin_theta, cos_theta);
  if (theta < 1e-6) {
    return 0.5 * (1.0 + theta * theta / 6.0) * w;
  }
  if (M_PI - theta < 1e-3) {
    // Near pi, sin(theta) is tiny and the antisymmetric part loses precision: recover the axis
    // from the symmetric part R + R^T = 2 cos(theta) I + 2 (1 - cos(theta)) a a^T.
    const Mat3 B = (R + R.transpose()) * 0.5 - cos_theta * Mat3::Identity();
    int k;
    B.diagonal().maxCoeff(&k);
    Vec3 axis = B.col(k) / std::sqrt(std::max(B(k, k), 1e-300));
    axis.normalize();
    if (axis.dot(w) < 0) axis = -axis;  // keep the sign consistent with the antisymmetric part
    return theta * axis;
  }
  return theta / (2.0 * std::sin(theta)) * w;
}

Mat3 so3_left_jacobian(const Vec3& phi) {
  const double theta2 = phi.squaredNorm();
  const Mat3 K = hat(phi);
  if (theta2 < 1e-10) return Mat3::Identity() + 0.5 * K + K * K / 6.0;
  const double theta = std::sqrt(theta2);
  return Mat3::Identity() + (1.0 - std::cos(theta)) / theta2 * K +
         (theta - std::sin(theta)) / (theta2 * theta) * K * K;
}

Mat3 so3_left_jacobian_inverse(const Vec3& phi) {
  const double theta2 = phi.squaredNorm();
  const Mat3 K = hat(phi);
  if (theta2 < 1e-10) return Mat3::Identity() - 0.5 * K + K * K / 12.0;
  const double theta = std::sqrt(theta2);
  const double half = 0.5 * theta;
  const double coef = (1.0 - half * std::cos(half) / std::sin(half)) / theta2;
  return Mat3::Identity() - 0.5 * K + coef * K * K;
}

Mat3 orthonormalize(const Mat3& M) {
  Eigen::JacobiSVD<Mat3> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 U = svd.matrixU();
  const Mat3 V = svd.matrixV();
  if ((U * V.transpose()).determinant() < 0) U.col(2) *= -1.0;
  return U * V.transpose();
}

SE3 SE3::exp(const Vec6& xi) {
  const Vec3 rho = xi.head<3>();
  const Vec3 phi = xi.tail<3>();
  return SE3(so3_exp(phi), so3_left_jacobian(phi) * rho);
}

Vec6 SE3::log() const {
  const Vec3 phi = so3_log(R_);
  Vec6 xi;
  xi.head<3>() = so3_left_jacobian_inverse(phi) * t_;
  xi.tail<3>() = phi;
  return xi;
}

Mat4 SE3::matrix() const {
  Mat4 M = Mat4::Identity();
  M.topLeftCorner<3, 3>() = R_;
  M.topRightCorner<3, 1>() = t_;
  return M;
}

Mat6 SE3::adjoint() const {
  Mat6 A = Mat6::Zero();
  A.topLeftCorner<3, 3>() = R_;
  A.topRightCorner<3, 3>() = hat(t_) * R_;
  A.bottomRightCorner<3, 3>() = R_;
  return A;
}

double SE3::rotation_angle_deg() const { return so3_log(R_).norm() * 180.0 / M_PI; }

double rotation_distance_rad(const Mat3& Ra, const Mat3& Rb) {
  return so3_log(Ra.transpose() * Rb).norm();
}

SE3 look_at(const Vec3& eye, const Vec3& target, const Vec3& up_world) {
  Vec3 z = target - eye;
  if (z.norm() < 1e-12) z = Vec3::UnitZ();
  z.normalize();
  Vec3 x = z.cross(up_world);                    // right = forward x up
  if (x.norm() < 1e-9) x = z.unitOrthogonal();  // looking straight up/down
  x.normalize();
  const Vec3 y = z.cross(x);
  Mat3 R;
  R.col(0) = x, R.col(1) = y, R.col(2) = z;
  return SE3(R, eye);
}

}  // namespace orpe
