// EKF on SE(3): hand-computed gains, wrap-around at +-180 deg, gating, restart, convergence with
// the number of measurements, and symmetric measurements that must not fight.
#include <gtest/gtest.h>

#include <random>

#include "orpe/core/error.h"
#include "orpe/pose/pose_ekf.h"

namespace orpe {
namespace {

SE3 rot_z(double deg, const Vec3& t = Vec3::Zero()) {
  return SE3(so3_exp(Vec3(0, 0, deg * M_PI / 180.0)), t);
}

PoseMeasurement meas(const SE3& T_world_obj, double mu, int frame = 0,
                     const SE3& T_world_cam = SE3()) {
  PoseMeasurement m;
  m.frame_index = frame;
  m.T_world_cam = T_world_cam;
  m.T_cam_obj = T_world_cam.inverse() * T_world_obj;
  m.mu_m = mu;
  return m;
}

TEST(PoseEkf, FirstMeasurementInitialisesWithPaperCovariance) {
  PoseEkf ekf;
  EXPECT_FALSE(ekf.initialised());
  const SE3 T_world_cam = rot_z(30, Vec3(1, 2, 3));
  const SE3 T_world_obj = rot_z(-20, Vec3(0.5, 0.1, 0.9));
  const PoseEkfStep s = ekf.update(meas(T_world_obj, 0.004, 7, T_world_cam));
  EXPECT_TRUE(s.accepted);
  EXPECT_TRUE(s.initialised);
  EXPECT_LT((ekf.T_world_obj().matrix() - T_world_obj.matrix()).norm(), 1e-12);
  EXPECT_LT((ekf.covariance() - 0.004 * Mat6::Identity()).norm(), 1e-15);  // R = mu I
  EXPECT_LT((s.T_cam_obj_fused.matrix() - (T_world_cam.inverse() * T_world_obj).matrix()).norm(),
            1e-12);
}

TEST(PoseEkf, ScalarGainTranslation) {
  // P = mu1 I after the first measurement; a second one offset by d along x with mu2 moves the
  // state by K d, K = mu1 / (mu1 + mu2), and leaves P = mu1 mu2 / (mu1 + mu2).
  PoseEkf ekf;
  const double mu1 = 0.004, mu2 = 0.012, d = 0.02;
  ekf.update(meas(SE3(), mu1));
  const PoseEkfStep s = ekf.update(meas(SE3(Mat3::Identity(), Vec3(d, 0, 0)), mu2, 1));
  ASSERT_TRUE(s.accepted);
  const double K = mu1 / (mu1 + mu2);
  EXPECT_NEAR(ekf.T_world_obj().translation().x(), K * d, 1e-12);
  EXPECT_NEAR(ekf.T_world_obj().translation().y(), 0.0, 1e-12);
  EXPECT_NEAR(ekf.T_world_obj().rotation_angle_deg(), 0.0, 1e-9);
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(ekf.covariance()(i, i), mu1 * mu2 / (mu1 + mu2), 1e-12);
  EXPECT_EQ(ekf.result().num_fused, 2);
}

TEST(PoseEkf, ScalarGainRotationAndScaledR) {
  // Rotation block scaled by 4: K_rot = mu1 s / (mu1 s + mu2 s) still equal weights when mu1 = mu2.
  PoseEkfParams p;
  p.r_rotation_scale = 4.0;
  p.gate_chi2 = 0;  // no gating: this checks the algebra only
  p.hypotheses = 1;  // a single filter (several need the gate)
  PoseEkf ekf(p);
  ekf.update(meas(rot_z(10), 0.01));
  EXPECT_NEAR(ekf.covariance()(5, 5), 0.04, 1e-15);
  EXPECT_NEAR(ekf.covariance()(0, 0), 0.01, 1e-15);
  ekf.update(meas(rot_z(40), 0.01, 1));
  EXPECT_NEAR(so3_log(ekf.T_world_obj().rotation()).z() * 180.0 / M_PI, 25.0, 1e-9);
  EXPECT_NEAR(ekf.covariance()(5, 5), 0.02, 1e-15);
}

TEST(PoseEkf, BodyFrameInnovationWithRotatedState) {
  // State rotated 90 deg about z at (1, 0, 0); a measurement translated by (0, 0.02, 0) in the
  // world is an innovation along -x of the body frame; equal noises -> half of it.
  PoseEkf ekf;
  const SE3 X = rot_z(90, Vec3(1, 0, 0));
  ekf.update(meas(X, 0.01));
  const SE3 Z = rot_z(90, Vec3(1, 0.02, 0));
  const Vec6 nu = ekf.innovation(Z);
  EXPECT_NEAR(nu(0), 0.02, 1e-12);  // world +y is body +x after a 90 deg yaw
  EXPECT_NEAR(nu(1), 0.0, 1e-12);
  ekf.update(meas(Z, 0.01, 1));
  EXPECT_LT((ekf.T_world_obj().translation() - Vec3(1, 0.01, 0)).norm(), 1e-12);
}

TEST(PoseEkf, WrapAroundFusesToNear180NotZero) {
  PoseEkf ekf;
  ekf.update(meas(rot_z(179), 0.01));
  const PoseEkfStep s = ekf.update(meas(rot_z(-179), 0.01, 1));
  ASSERT_TRUE(s.accepted) << s.mahalanobis_sq;
  const Mat3 R180 = so3_exp(Vec3(0, 0, M_PI));
  EXPECT_LT(rotation_distance_rad(ekf.T_world_obj().rotation(), R180) * 180.0 / M_PI, 0.01);
  EXPECT_GT(ekf.T_world_obj().rotation_angle_deg(), 179.9);
  // The innovation was 2 degrees, not 358.
  EXPECT_NEAR(s.mahalanobis_sq, std::pow(2.0 * M_PI / 180.0, 2) / 0.02, 1e-9);
}

TEST(PoseEkf, GatingRejectsAnOutlierAndKeepsTheState) {
  PoseEkfParams p;
  p.reinit_after_rejections = 0;
  PoseEkf ekf(p);
  const SE3 truth = rot_z(30, Vec3(0.3, 0.2, 0.8));
  for (int i = 0; i < 5; ++i) ekf.update(meas(truth, 0.002, i));
  const SE3 before = ekf.T_world_obj();
  const Mat6 P_before = ekf.covariance();
  const PoseEkfStep s =
      ekf.update(meas(truth * SE3(so3_exp(Vec3(1.2, 0, 0)), Vec3::Zero()), 0.002, 5));
  EXPECT_FALSE(s.accepted);
  EXPECT_GT(s.mahalanobis_sq, p.gate_chi2);
  EXPECT_LT((ekf.T_world_obj().matrix() - before.matrix()).norm(), 1e-15);
  EXPECT_LT((ekf.covariance() - P_before).norm(), 1e-18);
  EXPECT_EQ(ekf.result().num_rejected, 1);
  // Without the gate the same outlier drags the state.
  PoseEkfParams open = p;
  open.gate_chi2 = 0;
  open.hypotheses = 1;
  PoseEkf ungated(open);
  for (int i = 0; i < 5; ++i) ungated.update(meas(truth, 0.002, i));
  ungated.update(meas(truth * SE3(so3_exp(Vec3(1.2, 0, 0)), Vec3::Zero()), 0.002, 5));
  EXPECT_GT(rotation_distance_rad(ungated.T_world_obj().rotation(), truth.rotation()), 0.1);
}

TEST(PoseEkf, RestartsWhenConsistentMeasurementsKeepBeingRejected) {
  PoseEkfParams p;
  p.reinit_after_rejections = 4;
  PoseEkf ekf(p);
  const SE3 wrong = rot_z(100, Vec3(0.5, 0, 1));
  const SE3 truth = rot_z(0, Vec3(0.3, 0.1, 0.9));
  ekf.update(meas(wrong, 0.002, 0));
  ekf.update(meas(wrong, 0.002, 1));
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0, 0.002);
  for (int i = 0; i < 6; ++i) {
    Vec6 xi;
    for (int k = 0; k < 6; ++k) xi(k) = n(rng);
    ekf.update(meas(truth * SE3::exp(xi), 0.002, 2 + i));
  }
  const FusedObjectPose r = ekf.result();
  EXPECT_EQ(r.num_reinitialisations, 1);
  EXPECT_LT((r.T_world_obj.translation() - truth.translation()).norm(), 0.01);
  EXPECT_LT(rotation_distance_rad(r.T_world_obj.rotation(), truth.rotation()), 0.02);
  // 4 restart measurements + 2 accepted afterwards.
  EXPECT_EQ(r.num_fused, 6);
  ASSERT_EQ(r.history.size(), 8u);
  EXPECT_TRUE(r.history[5].reinitialised);
}

TEST(PoseEkf, InconsistentRejectionsDoNotRestart) {
  PoseEkfParams p;
  p.reinit_after_rejections = 3;
  PoseEkf ekf(p);
  const SE3 truth = rot_z(0, Vec3(0.3, 0.1, 0.9));
  for (int i = 0; i < 3; ++i) ekf.update(meas(truth, 0.002, i));
  // Outliers scattered all over: never three in agreement.
  for (int i = 0; i < 6; ++i)
    ekf.update(meas(rot_z(40.0 + 50.0 * i, Vec3(0.3, 0.1, 0.9)), 0.002, 3 + i));
  EXPECT_EQ(ekf.result().num_reinitialisations, 0);
  EXPECT_EQ(ekf.result().num_rejected, 6);
  EXPECT_LT(rotation_distance_rad(ekf.T_world_obj().rotation(), truth.rotation()), 1e-9);
}

TEST(PoseEkf, FusedErrorDecreasesWithTheNumberOfMeasurements) {
  // Noise drawn from R = mu I itself (mu = 1e-4: 1 cm, 0.57 deg std), so the filter is consistent.
  const double mu = 1e-4;
  const SE3 truth = SE3(so3_exp(Vec3(0.3, -0.2, 1.0)), Vec3(0.4, -0.1, 1.2));
  const std::vector<int> counts = {1, 4, 16, 64};
  std::vector<double> mean_err(counts.size(), 0.0);
  const int trials = 40;
  std::mt19937 rng(9);
  std::normal_distribution<double> n(0, std::sqrt(mu));
  for (int t = 0; t < trials; ++t) {
    PoseEkf ekf;
    int done = 0;
    for (size_t c = 0; c < counts.size(); ++c) {
      for (; done < counts[c]; ++done) {
        Vec6 xi;
        for (int k = 0; k < 6; ++k) xi(k) = n(rng);
        const SE3 cam = rot_z(done * 3.0, Vec3(0.01 * done, 0, 0));
        ekf.update(meas(truth * SE3::exp(xi), mu, done, cam));
      }
      mean_err[c] += (truth.inverse() * ekf.T_world_obj()).log().norm() / trials;
    }
  }
  for (size_t c = 1; c < counts.size(); ++c)
    EXPECT_LT(mean_err[c], 0.7 * mean_err[c - 1]) << "n = " << counts[c];
  // ~1/sqrt(n): 64 views should be ~8x better than one.
  EXPECT_LT(mean_err.back(), mean_err.front() / 4.0);
}

TEST(PoseEkf, ContinuousSymmetryMeasurementsDoNotFight) {
  // A can: any rotation about its z axis is equivalent. Measurements spin randomly about the axis.
  ObjectSymmetry can;
  can.continuous = true;
  can.axis_obj = Vec3::UnitZ();
  can.discrete.push_back(SE3(so3_exp(Vec3(M_PI, 0, 0)), Vec3::Zero()));  // end-over-end flip
  const SE3 truth = SE3(so3_exp(Vec3(0.5, 0.2, 0.1)), Vec3(0.2, 0.3, 1.0));
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> spin(-M_PI, M_PI);
  std::normal_distribution<double> n(0, 0.003);
  auto run = [&](bool use_symmetry, int* rejected) {
    PoseEkfParams p;
    p.use_symmetry = use_symmetry;
    p.reinit_after_rejections = 0;
    PoseEkf ekf(p, can);
    for (int i = 0; i < 20; ++i) {
      Vec6 xi;
      for (int k = 0; k < 6; ++k) xi(k) = n(rng);
      SE3 z = truth * can.continuous_element(spin(rng)) * SE3::exp(xi);
      if (i % 3 == 1) z = z * can.discrete[0];
      ekf.update(meas(z, 0.001, i));
    }
    *rejected = ekf.result().num_rejected;
    return ekf.T_world_obj();
  };
  int rejected_sym = 0, rejected_plain = 0;
  const SE3 fused = run(true, &rejected_sym);
  run(false, &rejected_plain);
  EXPECT_EQ(rejected_sym, 0);
  EXPECT_GT(rejected_plain, 5);  // without the snap they disagree all the time
  // The fused axis matches the truth's (up to the flip) and so does the position.
  EXPECT_GT(std::abs(fused.rotation().col(2).dot(truth.rotation().col(2))), std::cos(0.02));
  EXPECT_LT((fused.translation() - truth.translation()).norm(), 0.005);
}

TEST(PoseEkf, DiscreteSymmetryPicksTheClosestEquivalent) {
  ObjectSymmetry box;  // 180 deg about x, y, z through a point off the origin
  const Vec3 c(0.01, 0.0, 0.02);
  for (int k = 0; k < 3; ++k) {
    const Mat3 R = so3_exp(Vec3::Unit(k) * M_PI);
    box.discrete.push_back(SE3(R, c - R * c));
  }
  PoseEkf ekf({}, box);
  const SE3 truth = SE3(so3_exp(Vec3(0.1, 0.7, -0.3)), Vec3(0.1, 0.2, 0.7));
  ekf.update(meas(truth, 0.002));
  for (int i = 0; i < 3; ++i) {
    const PoseEkfStep s =
        ekf.update(meas(truth * box.discrete[static_cast<size_t>(i)], 0.002, i + 1));
    EXPECT_TRUE(s.accepted);
    EXPECT_LT(s.mahalanobis_sq, 1e-12);
    EXPECT_LT((s.T_world_obj_measured.matrix() - truth.matrix()).norm(), 1e-9);
  }
  EXPECT_LT((ekf.T_world_obj().matrix() - truth.matrix()).norm(), 1e-9);
}

TEST(PoseEkf, InvalidParamsThrow) {
  PoseEkfParams p;
  p.r_mu_exponent = 0;
  EXPECT_THROW(PoseEkf{p}, ConfigError);
  p = {};
  p.min_mu_m = -1;
  std::string why;
  EXPECT_FALSE(p.IsValid(&why));
  EXPECT_FALSE(why.empty());
}

}  // namespace
}  // namespace orpe
