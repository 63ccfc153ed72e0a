// Rigid transforms and rotations with exp/log maps.
//
// Conventions (see docs/CONVENTIONS.md):
//  - A transform is named by its frames: T_a_b maps coordinates expressed in frame b into frame a,
//    p_a = T_a_b * p_b. Composition chains inner names: T_a_c = T_a_b * T_b_c.
//  - Tangent vectors of SE(3) are ordered [rho; phi] = [translation part (m); rotation vector (rad)],
//    as in Sophus. exp([rho; phi]) = [Exp(phi), V(phi) rho; 0, 1].
//  - Quaternions are stored and printed as (x, y, z, w) wherever the TUM format is involved and as
//    (w, x, y, z) in DenseFusion's network outputs; every function names its order explicitly.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace orpe {

using Vec3 = Eigen::Vector3d;
using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat3 = Eigen::Matrix3d;
using Mat4 = Eigen::Matrix4d;
using Mat6 = Eigen::Matrix<double, 6, 6>;

/// Skew-symmetric matrix: hat(a) * b == a.cross(b).
Mat3 hat(const Vec3& a);

/// SO(3) exponential of a rotation vector (axis * angle, rad). Exact near zero (Taylor series).
Mat3 so3_exp(const Vec3& phi);

/// SO(3) logarithm: rotation vector with angle in [0, pi]. Precondition: R is a rotation matrix
/// (orthonormal, det +1) within 1e-6. Stable near identity and near pi.
Vec3 so3_log(const Mat3& R);

/// Left Jacobian V(phi) of SO(3), used by SE(3) exp/log.
Mat3 so3_left_jacobian(const Vec3& phi);
Mat3 so3_left_jacobian_inverse(const Vec3& phi);

/// Projects an almost-rotation matrix onto SO(3) (SVD, determinant fixed to +1).
Mat3 orthonormalize(const Mat3& M);

/// Rigid transform (rotation R, translation t in metres). Invariant: R in SO(3).
class SE3 {
 public:
  SE3() : R_(Mat3::Identity()), t_(Vec3::Zero()) {}
  SE3(const Mat3& R, const Vec3& t) : R_(R), t_(t) {}
  /// From a unit quaternion and translation. Eigen's Quaterniond constructor takes (w, x, y, z).
  SE3(const Eigen::Quaterniond& q, const Vec3& t) : R_(q.normalized().toRotationMatrix()), t_(t) {}
  /// From the top 3x4 block of a homogeneous matrix (the bottom row is ignored).
  static SE3 from_matrix(const Mat4& M) { return SE3(M.topLeftCorner<3, 3>(), M.topRightCorner<3, 1>()); }
  static SE3 identity() { return SE3(); }

  /// exp([rho; phi]) (rho: metres, phi: rad).
  static SE3 exp(const Vec6& xi);
  /// Inverse of exp; rotation angle in [0, pi].
  Vec6 log() const;

  const Mat3& rotation() const { return R_; }
  const Vec3& translation() const { return t_; }
  Mat3& rotation() { return R_; }
  Vec3& translation() { return t_; }
  Eigen::Quaterniond quaternion() const { return Eigen::Quaterniond(R_).normalized(); }
  Mat4 matrix() const;

  SE3 inverse() const { return SE3(R_.transpose(), -(R_.transpose() * t_)); }
  SE3 operator*(const SE3& o) const { return SE3(R_ * o.R_, R_ * o.t_ + t_); }
  Vec3 operator*(const Vec3& p) const { return R_ * p + t_; }

  /// 6x6 adjoint: Ad(T) xi = log(T exp(xi) T^-1) for small xi, in [rho; phi] order.
  Mat6 adjoint() const;

  /// Rotation angle of R in degrees, in [0, 180].
  double rotation_angle_deg() const;

 private:
  Mat3 R_;
  Vec3 t_;
};

/// Rotation angle (rad) between two rotations: |log(Ra^T Rb)|.
double rotation_distance_rad(const Mat3& Ra, const Mat3& Rb);

/// Camera-to-world pose (T_world_cam, OpenCV camera axes: x right, y down, z forward) of a camera at
/// `eye` looking at `target`, its y axis as close to -up_world as the view direction allows. Looking
/// along up_world, x is any unit vector orthogonal to z; eye == target looks along world +z.
SE3 look_at(const Vec3& eye, const Vec3& target, const Vec3& up_world = Vec3::UnitZ());

}  // namespace orpe
