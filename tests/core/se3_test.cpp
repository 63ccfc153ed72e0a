// Property tests of the SE(3)/SO(3) maps: exp/log round trips, composition, quaternion conversion,
// near-identity and near-pi rotations.
#include <gtest/gtest.h>

#include <random>

#include "orpe/core/se3.h"

namespace orpe {
namespace {

Vec3 random_axis(std::mt19937& rng) {
  std::normal_distribution<double> n(0, 1);
  return Vec3(n(rng), n(rng), n(rng)).normalized();
}

TEST(So3, ExpLogRoundTripOverAllAngles) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> ang(0, M_PI - 1e-9);
  for (int i = 0; i < 2000; ++i) {
    const Vec3 phi = random_axis(rng) * ang(rng);
    const Vec3 back = so3_log(so3_exp(phi));
    EXPECT_LT((back - phi).norm(), 1e-9) << "angle " << phi.norm();
  }
}

TEST(So3, NearIdentityAndNearPi) {
  std::mt19937 rng(2);
  for (double theta : {0.0, 1e-12, 1e-8, 1e-5, 1e-3, M_PI - 1e-2, M_PI - 1e-5, M_PI - 1e-8, M_PI}) {
    const Vec3 axis = random_axis(rng);
    const Mat3 R = so3_exp(axis * theta);
    EXPECT_LT((R * R.transpose() - Mat3::Identity()).norm(), 1e-12);
    EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
    const Vec3 back = so3_log(R);
    EXPECT_NEAR(back.norm(), theta, 1e-7) << theta;
    // At exactly pi, axis and -axis are the same rotation: compare rotations instead of vectors.
    EXPECT_LT((so3_exp(back) - R).norm(), 1e-7) << theta;
  }
}

TEST(So3, ExpMatchesEigenAngleAxis) {
  std::mt19937 rng(3);
  for (int i = 0; i < 100; ++i) {
    const Vec3 axis = random_axis(rng);
    const double theta = 3.0 * (i + 1) / 100.0;
    const Mat3 expected = Eigen::AngleAxisd(theta, axis).toRotationMatrix();
    EXPECT_LT((so3_exp(axis * theta) - expected).norm(), 1e-12);
  }
}

TEST(So3, LeftJacobianInverse) {
  std::mt19937 rng(4);
  for (double theta : {1e-9, 0.1, 1.0, 3.0}) {
    const Vec3 phi = random_axis(rng) * theta;
    EXPECT_LT((so3_left_jacobian(phi) * so3_left_jacobian_inverse(phi) - Mat3::Identity()).norm(), 1e-9);
  }
}

TEST(Se3, ExpLogRoundTrip) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-2, 2), ang(0, M_PI - 1e-6);
  for (int i = 0; i < 1000; ++i) {
    Vec6 xi;
    xi.head<3>() = Vec3(u(rng), u(rng), u(rng));
    xi.tail<3>() = random_axis(rng) * ang(rng);
    EXPECT_LT((SE3::exp(xi).log() - xi).norm(), 1e-8);
  }
}

TEST(Se3, CompositionAndInverse) {
  std::mt19937 rng(6);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 100; ++i) {
    Vec6 a, b;
    for (int k = 0; k < 6; ++k) a[k] = u(rng), b[k] = u(rng);
    const SE3 A = SE3::exp(a), B = SE3::exp(b);
    const Vec3 p(u(rng), u(rng), u(rng));
    EXPECT_LT(((A * B) * p - A * (B * p)).norm(), 1e-12);
    EXPECT_LT((A.inverse() * (A * p) - p).norm(), 1e-12);
    EXPECT_LT(((A * B).matrix() - A.matrix() * B.matrix()).norm(), 1e-12);
  }
}

TEST(Se3, AdjointMovesTangentVectors) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  Vec6 a, xi;
  for (int k = 0; k < 6; ++k) a[k] = u(rng), xi[k] = 1e-3 * u(rng);
  const SE3 T = SE3::exp(a);
  // T exp(xi) T^-1 == exp(Ad(T) xi), exactly (not only to first order).
  const SE3 lhs = T * SE3::exp(xi) * T.inverse();
  const SE3 rhs = SE3::exp(T.adjoint() * xi);
  EXPECT_LT((lhs.matrix() - rhs.matrix()).norm(), 1e-12);
}

TEST(Se3, QuaternionRoundTripWithStatedOrder) {
  // Eigen::Quaterniond(w, x, y, z): a 90 degree turn about z.
  const Eigen::Quaterniond q(std::sqrt(0.5), 0, 0, std::sqrt(0.5));
  const SE3 T(q, Vec3(1, 2, 3));
  EXPECT_LT((T * Vec3(1, 0, 0) - Vec3(1, 3, 3)).norm(), 1e-12);
  const Eigen::Quaterniond back = T.quaternion();
  EXPECT_NEAR(std::abs(back.dot(q)), 1.0, 1e-12);
  EXPECT_NEAR(T.rotation_angle_deg(), 90.0, 1e-9);
}

TEST(Se3, OrthonormalizeFixesDrift) {
  Mat3 R = so3_exp(Vec3(0.3, -0.2, 0.5));
  R(0, 1) += 1e-4;
  const Mat3 Q = orthonormalize(R);
  EXPECT_LT((Q * Q.transpose() - Mat3::Identity()).norm(), 1e-12);
  EXPECT_NEAR(Q.determinant(), 1.0, 1e-12);
  EXPECT_LT((Q - R).norm(), 1e-3);
}

TEST(LookAt, TargetOnTheOpticalAxisAndImageYDownTheWorld) {
  const Vec3 eye(1.0, -2.0, 1.5), target(0.2, 0.3, 0.4);
  const SE3 T = look_at(eye, target);
  EXPECT_LT((T.rotation().transpose() * T.rotation() - Mat3::Identity()).norm(), 1e-12);
  EXPECT_NEAR(T.rotation().determinant(), 1.0, 1e-12);
  const Vec3 p = T.inverse() * target;  // the target in the camera frame
  EXPECT_NEAR(p.x(), 0.0, 1e-12);
  EXPECT_NEAR(p.y(), 0.0, 1e-12);
  EXPECT_NEAR(p.z(), (target - eye).norm(), 1e-12);
  EXPECT_LT(T.rotation().col(1).dot(Vec3::UnitZ()), 0.0);  // camera y points down the world
  EXPECT_NEAR(T.rotation().col(0).z(), 0.0, 1e-12);          // no roll: camera x is horizontal
  // Another up vector: camera y opposes it.
  const Vec3 up(0, -1, 0);
  EXPECT_LT(look_at(eye, target, up).rotation().col(1).dot(up), 0.0);
}

TEST(LookAt, DegenerateViewsStayRotations) {
  for (const SE3& T : {look_at(Vec3(0, 0, 2), Vec3(0, 0, 0)), look_at(Vec3(1, 1, 1), Vec3(1, 1, 1))}) {
    EXPECT_TRUE(T.rotation().allFinite());
    EXPECT_NEAR(T.rotation().determinant(), 1.0, 1e-12);
  }
}

}  // namespace
}  // namespace orpe
