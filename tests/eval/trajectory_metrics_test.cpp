#include "orpe/eval/trajectory_metrics.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <random>
#include <tuple>

#include "orpe/core/error.h"

namespace orpe {
namespace {

// ---- Independent references written for the tests ----

/// TUM associate.py transcribed literally: all pairs, Python tuple sort, greedy, then sort by
/// stamps.
std::vector<std::pair<double, double>> tum_associate(std::vector<double> first,
                                                     std::vector<double> second, double max_diff) {
  std::sort(first.begin(), first.end());
  first.erase(std::unique(first.begin(), first.end()), first.end());
  std::sort(second.begin(), second.end());
  second.erase(std::unique(second.begin(), second.end()), second.end());
  std::vector<std::tuple<double, double, double>> potential;
  for (double a : first)
    for (double b : second)
      if (std::abs(a - b) < max_diff) potential.emplace_back(std::abs(a - b), a, b);
  std::sort(potential.begin(), potential.end());
  std::vector<std::pair<double, double>> matches;
  std::vector<double> used_a, used_b;
  for (const auto& [d, a, b] : potential) {
    if (std::count(used_a.begin(), used_a.end(), a) || std::count(used_b.begin(), used_b.end(), b))
      continue;
    used_a.push_back(a);
    used_b.push_back(b);
    matches.emplace_back(a, b);
  }
  std::sort(matches.begin(), matches.end());
  return matches;
}

/// Horn (1987) closed-form absolute orientation with unit quaternions; scale as the least-squares
/// estimate given R (sum q'.R p' / sum |p'|^2), which is Umeyama's.
SimilarityAlignment horn_quaternion(const std::vector<Vec3>& est, const std::vector<Vec3>& gt,
                                    bool with_scale) {
  Vec3 mp = Vec3::Zero(), mq = Vec3::Zero();
  for (size_t i = 0; i < est.size(); ++i) {
    mp += est[i];
    mq += gt[i];
  }
  mp /= double(est.size());
  mq /= double(est.size());
  Mat3 M = Mat3::Zero();  // sum p' q'^T
  for (size_t i = 0; i < est.size(); ++i) M += (est[i] - mp) * (gt[i] - mq).transpose();
  const double Sxx = M(0, 0), Sxy = M(0, 1), Sxz = M(0, 2), Syx = M(1, 0), Syy = M(1, 1),
               Syz = M(1, 2), Szx = M(2, 0), Szy = M(2, 1), Szz = M(2, 2);
  Eigen::Matrix4d N;
  N << Sxx + Syy + Szz, Syz - Szy, Szx - Sxz, Sxy - Syx,  //
      Syz - Szy, Sxx - Syy - Szz, Sxy + Syx, Szx + Sxz,   //
      Szx - Sxz, Sxy + Syx, -Sxx + Syy - Szz, Syz + Szy,  //
      Sxy - Syx, Szx + Sxz, Syz + Szy, -Sxx - Syy + Szz;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> eig(N);
  const Eigen::Vector4d q = eig.eigenvectors().col(3);  // largest eigenvalue; (w, x, y, z)
  SimilarityAlignment a;
  a.R = Eigen::Quaterniond(q(0), q(1), q(2), q(3)).normalized().toRotationMatrix();
  if (with_scale) {
    double num = 0, den = 0;
    for (size_t i = 0; i < est.size(); ++i) {
      num += (gt[i] - mq).dot(a.R * (est[i] - mp));
      den += (est[i] - mp).squaredNorm();
    }
    a.scale = num / den;
  }
  a.t = mq - a.scale * a.R * mp;
  return a;
}

SE3 random_pose(std::mt19937& rng, double trans_m, double rot_rad) {
  std::normal_distribution<double> n(0.0, 1.0);
  Vec6 xi;
  xi << trans_m * n(rng), trans_m * n(rng), trans_m * n(rng), rot_rad * n(rng), rot_rad * n(rng),
      rot_rad * n(rng);
  return SE3::exp(xi);
}

/// A smooth random camera path (T_world_cam) at 30 Hz.
std::vector<StampedPose> random_trajectory(std::mt19937& rng, int n) {
  std::vector<StampedPose> traj;
  SE3 T = random_pose(rng, 1.0, 1.0);
  for (int i = 0; i < n; ++i) {
    T = T * random_pose(rng, 0.02, 0.02);
    traj.push_back({i / 30.0, T});
  }
  return traj;
}

// ---- Association ----

TEST(Association, GreedyBySmallestDifferenceOneToOne) {
  // est 0.010 is 0.010 from gt 0.000 but 0.001 from gt 0.011: it goes to 0.011, and gt 0.000 stays
  // unmatched although it has a candidate (TUM is greedy, not optimal).
  const auto m = associate_timestamps({0.0, 0.011, 1.0}, {0.010, 1.015, 1.5}, 0.02);
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(m[0].gt_index, 1u);
  EXPECT_EQ(m[0].est_index, 0u);
  EXPECT_EQ(m[1].gt_index, 2u);
  EXPECT_EQ(m[1].est_index, 1u);
}

TEST(Association, WindowIsStrict) {
  // 0.25 is exact in binary, so |1.25 - 1.0| == 0.25 exactly and must not match (TUM uses <).
  EXPECT_TRUE(associate_timestamps({1.0}, {1.25}, 0.25).empty());
  EXPECT_EQ(associate_timestamps({1.0}, {1.125}, 0.25).size(), 1u);
}

TEST(Association, RepeatedTimestampKeepsLastPose) {
  const auto m = associate_timestamps({0.0, 1.0, 1.0}, {1.0, 0.0}, 0.02);
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(m[0].gt_index, 0u);
  EXPECT_EQ(m[0].est_index, 1u);
  EXPECT_EQ(m[1].gt_index, 2u);  // the later of the two 1.0 lines
}

TEST(Association, EqualsTumAssociateOnRandomStamps) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> jitter(-0.03, 0.03);
  std::uniform_int_distribution<int> skip(0, 5);
  for (int trial = 0; trial < 30; ++trial) {
    std::vector<double> gt, est;
    for (int i = 0; i < 200; ++i) {
      if (skip(rng) == 0) continue;  // gaps on both sides
      gt.push_back(i / 30.0);
      if (skip(rng) != 0) est.push_back(i / 30.0 + jitter(rng));
      if (skip(rng) == 0) est.push_back(i / 30.0 + jitter(rng));  // extra near-duplicates
    }
    std::shuffle(est.begin(), est.end(), rng);  // input order must not matter
    const auto mine = associate_timestamps(gt, est, 0.02);
    const auto ref = tum_associate(gt, est, 0.02);
    ASSERT_EQ(mine.size(), ref.size()) << "trial " << trial;
    for (size_t k = 0; k < ref.size(); ++k) {
      EXPECT_EQ(gt[mine[k].gt_index], ref[k].first);
      EXPECT_EQ(est[mine[k].est_index], ref[k].second);
    }
  }
}

// ---- Alignment ----

TEST(Alignment, UmeyamaSvdEqualsHornQuaternion) {
  std::mt19937 rng(11);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    const SE3 T = random_pose(rng, 3.0, 2.0);
    const double s = trial % 2 ? 1.0 : 0.3 + std::abs(n(rng));
    std::vector<Vec3> est, gt;
    for (int i = 0; i < 50; ++i) {
      est.emplace_back(n(rng), 2.0 * n(rng), 0.5 * n(rng));
      gt.push_back(s * (T.rotation() * est.back()) + T.translation() +
                   0.05 * Vec3(n(rng), n(rng), n(rng)));
    }
    for (bool with_scale : {false, true}) {
      const auto a = align_umeyama(est, gt, with_scale);
      const auto h = horn_quaternion(est, gt, with_scale);
      EXPECT_LT((a.R - h.R).norm(), 1e-9) << trial;
      EXPECT_LT((a.t - h.t).norm(), 1e-9) << trial;
      EXPECT_NEAR(a.scale, h.scale, 1e-9) << trial;
      EXPECT_NEAR(a.R.determinant(), 1.0, 1e-12);
    }
  }
}

TEST(Alignment, RecoversAnExactSimilarity) {
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0.0, 1.0);
  const SE3 T = random_pose(rng, 2.0, 1.5);
  std::vector<Vec3> est, gt;
  for (int i = 0; i < 10; ++i) {
    est.emplace_back(n(rng), n(rng), n(rng));
    gt.push_back(2.5 * (T.rotation() * est.back()) + T.translation());
  }
  const auto a = align_umeyama(est, gt, true);
  EXPECT_LT((a.R - T.rotation()).norm(), 1e-12);
  EXPECT_NEAR(a.scale, 2.5, 1e-12);
  EXPECT_LT((a.t - T.translation()).norm(), 1e-12);
  // Without scale the rotation is still exact (the shapes only differ in size).
  EXPECT_LT((align_umeyama(est, gt, false).R - T.rotation()).norm(), 1e-12);
}

TEST(Alignment, DegenerateInputsStayFinite) {
  const std::vector<Vec3> one{Vec3(1, 2, 3)}, one_gt{Vec3(-1, 0, 4)};
  const auto a = align_umeyama(one, one_gt, true);
  EXPECT_LT((a.apply(one[0]) - one_gt[0]).norm(), 1e-12);
  EXPECT_EQ(a.scale, 1.0);
  const std::vector<Vec3> line{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(2, 0, 0)};
  const std::vector<Vec3> line_gt{Vec3(0, 1, 0), Vec3(0, 2, 0), Vec3(0, 3, 0)};
  const auto b = align_umeyama(line, line_gt, false);
  for (int i = 0; i < 3; ++i) EXPECT_LT((b.apply(line[i]) - line_gt[i]).norm(), 1e-12);
  EXPECT_THROW(align_umeyama({}, {}, false), std::invalid_argument);
}

// ---- ATE / RPE ----

TEST(Ate, RigidlyMovedCopyHasZeroErrors) {
  std::mt19937 rng(5);
  const auto gt = random_trajectory(rng, 300);
  const SE3 T = random_pose(rng, 5.0, 2.0);
  std::vector<StampedPose> est;
  for (const auto& p : gt) est.push_back({p.timestamp_s + 0.004, T * p.T_world_cam});
  const auto ev = evaluate_trajectory(gt, est, {});
  EXPECT_EQ(ev.matches.size(), 300u);
  EXPECT_LT(ev.ate.translation_m.rmse, 1e-9);
  EXPECT_LT(ev.ate.translation_m.max, 1e-9);
  EXPECT_LT(ev.rpe.translation_m.rmse, 1e-9);
  EXPECT_LT(ev.rpe.rotation_deg.rmse, 1e-6);
  EXPECT_EQ(ev.rpe.translation_m.count, 299u);
  // The alignment found is T (est -> gt is T^-1).
  EXPECT_LT((ev.ate.alignment.R - T.rotation().transpose()).norm(), 1e-9);
}

TEST(Ate, ScaledCopyNeedsScaleAlignment) {
  std::mt19937 rng(6);
  const auto gt = random_trajectory(rng, 200);
  const SE3 T = random_pose(rng, 1.0, 1.0);
  std::vector<StampedPose> est;
  for (const auto& p : gt) {
    SE3 q = T * p.T_world_cam;
    q.translation() *= 0.5;
    est.push_back({p.timestamp_s, q});
  }
  TrajectoryMetricsParams params;
  EXPECT_GT(evaluate_trajectory(gt, est, params).ate.translation_m.rmse, 1e-3);
  params.align_scale = true;
  const auto ev = evaluate_trajectory(gt, est, params);
  EXPECT_LT(ev.ate.translation_m.rmse, 1e-9);
  EXPECT_NEAR(ev.ate.alignment.scale, 2.0, 1e-9);
  EXPECT_LT(ev.rpe.translation_m.rmse, 1e-9);  // RPE uses the scale too
}

TEST(Ate, KnownPerturbationGivesHandComputedStatistics) {
  // Every position is visited twice; the estimate is off by +e_k on the first visit and -e_k on
  // the second. The errors then have zero mean and no correlation with the positions, so the best
  // alignment is the identity and ATE_k = |e_k| exactly.
  std::mt19937 rng(8);
  std::normal_distribution<double> n(0.0, 1.0);
  std::uniform_real_distribution<double> mag(0.001, 0.05);
  const int K = 60;
  std::vector<Vec3> pos, offsets;
  for (int k = 0; k < K; ++k) {
    pos.emplace_back(2 * n(rng), n(rng), 0.5 * n(rng));
    offsets.push_back(mag(rng) * Vec3(n(rng), n(rng), n(rng)).normalized());
  }
  std::vector<StampedPose> gt, est;
  std::vector<double> expected;
  for (int visit = 0; visit < 2; ++visit)
    for (int k = 0; k < K; ++k) {
      const double t = (visit * K + k) * 0.1;
      const Mat3 R = so3_exp(Vec3(0.1 * k, -0.05 * k, 0.2));
      gt.push_back({t, SE3(R, pos[k])});
      est.push_back({t, SE3(R, pos[k] + (visit ? -1.0 : 1.0) * offsets[k])});
      expected.push_back(offsets[k].norm());
    }
  const auto ev = evaluate_trajectory(gt, est, {});
  double sum_sq = 0, sum = 0;
  for (double e : expected) {
    sum_sq += e * e;
    sum += e;
  }
  EXPECT_NEAR(ev.ate.translation_m.rmse, std::sqrt(sum_sq / expected.size()), 1e-12);
  EXPECT_NEAR(ev.ate.translation_m.mean, sum / expected.size(), 1e-12);
  EXPECT_NEAR(ev.ate.translation_m.max, *std::max_element(expected.begin(), expected.end()), 1e-12);
  std::sort(expected.begin(), expected.end());
  EXPECT_NEAR(ev.ate.translation_m.median, 0.5 * (expected[K - 1] + expected[K]), 1e-12);
  EXPECT_LT((ev.ate.alignment.R - Mat3::Identity()).norm(), 1e-12);

  // RPE with a translation-only perturbation: E_i = (I, R_i^T (e_{i+d} - e_i)), so the error is
  // |e_{i+d} - e_i| and the rotation error is 0.
  for (int d : {1, 3}) {
    TrajectoryMetricsParams params;
    params.rpe_delta_frames = d;
    const auto r = evaluate_trajectory(gt, est, params);
    double rpe_sq = 0;
    int count = 0;
    for (size_t i = 0; i + d < gt.size(); ++i, ++count) {
      const Vec3 ei = est[i].T_world_cam.translation() - gt[i].T_world_cam.translation();
      const Vec3 ej = est[i + d].T_world_cam.translation() - gt[i + d].T_world_cam.translation();
      rpe_sq += (ej - ei).squaredNorm();
    }
    EXPECT_EQ(r.rpe.translation_m.count, static_cast<size_t>(count));
    EXPECT_NEAR(r.rpe.translation_m.rmse, std::sqrt(rpe_sq / count), 1e-12);
    EXPECT_LT(r.rpe.rotation_deg.max, 1e-6);
  }
}

TEST(Rpe, RotationPerturbationGivesAngleDifferences) {
  // Ground truth without rotation; the estimate turns about z by theta_i. Then
  // E_i = (Rz(theta_{i+d} - theta_i), (Rz(-theta_i) - I)(t_{i+d} - t_i)).
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> ang(-0.2, 0.2);
  std::normal_distribution<double> n(0.0, 0.1);
  std::vector<StampedPose> gt, est;
  std::vector<double> theta;
  for (int i = 0; i < 80; ++i) {
    const Vec3 t(i * 0.05, n(rng), n(rng));
    theta.push_back(ang(rng));
    gt.push_back({i / 30.0, SE3(Mat3::Identity(), t)});
    est.push_back({i / 30.0, SE3(so3_exp(Vec3(0, 0, theta.back())), t)});
  }
  TrajectoryMetricsParams params;
  params.rpe_delta_frames = 2;
  params.rpe_all_pairs = false;  // pairs (0,2), (2,4), ...
  const auto ev = evaluate_trajectory(gt, est, params);
  double rot_sq = 0, trans_sq = 0;
  int count = 0;
  for (size_t i = 0; i + 2 < gt.size(); i += 2, ++count) {
    const double dtheta = (theta[i + 2] - theta[i]) * 180.0 / M_PI;
    rot_sq += dtheta * dtheta;
    const Vec3 dt = gt[i + 2].T_world_cam.translation() - gt[i].T_world_cam.translation();
    trans_sq += ((so3_exp(Vec3(0, 0, -theta[i])) - Mat3::Identity()) * dt).squaredNorm();
  }
  EXPECT_EQ(ev.rpe.rotation_deg.count, static_cast<size_t>(count));
  EXPECT_NEAR(ev.rpe.rotation_deg.rmse, std::sqrt(rot_sq / count), 1e-9);
  EXPECT_NEAR(ev.rpe.translation_m.rmse, std::sqrt(trans_sq / count), 1e-12);
}

TEST(Ate, EqualsIndependentHornComputationOnNoisyTrajectories) {
  std::mt19937 rng(10);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int trial = 0; trial < 5; ++trial) {
    const auto gt = random_trajectory(rng, 400);
    const SE3 T = random_pose(rng, 2.0, 2.0);
    std::vector<StampedPose> est;
    for (size_t i = 0; i < gt.size(); i += 1 + (i % 7 == 0)) {  // some frames dropped
      SE3 p = T * gt[i].T_world_cam * random_pose(rng, 0.01, 0.01);
      p.translation() += Vec3(0.002 * i, 0, 0);  // drift
      est.push_back({gt[i].timestamp_s + 0.01 * n(rng) * 0.5, p});
    }
    const auto ev = evaluate_trajectory(gt, est, {});
    ASSERT_GT(ev.matches.size(), 300u);
    std::vector<Vec3> e_xyz, g_xyz;
    for (const auto& m : ev.matches) {
      e_xyz.push_back(est[m.est_index].T_world_cam.translation());
      g_xyz.push_back(gt[m.gt_index].T_world_cam.translation());
    }
    const auto h = horn_quaternion(e_xyz, g_xyz, false);
    double sq = 0;
    for (size_t i = 0; i < e_xyz.size(); ++i) sq += (g_xyz[i] - h.apply(e_xyz[i])).squaredNorm();
    EXPECT_NEAR(ev.ate.translation_m.rmse, std::sqrt(sq / e_xyz.size()), 1e-9);
    EXPECT_GT(ev.ate.translation_m.rmse, 1e-3);  // the test case is not trivial
  }
}

TEST(ErrorStatsTest, NumpyConventions) {
  const auto s = compute_error_stats({3.0, 1.0, 2.0, 4.0});
  EXPECT_DOUBLE_EQ(s.median, 2.5);
  EXPECT_DOUBLE_EQ(s.mean, 2.5);
  EXPECT_DOUBLE_EQ(s.rmse, std::sqrt(30.0 / 4));
  EXPECT_DOUBLE_EQ(s.std, std::sqrt(1.25));  // population std
  EXPECT_DOUBLE_EQ(s.min, 1.0);
  EXPECT_DOUBLE_EQ(s.max, 4.0);
  EXPECT_EQ(compute_error_stats({}).count, 0u);
}

TEST(Ate, NoAssociationAndBadParams) {
  std::vector<StampedPose> gt{{0.0, SE3()}}, est{{1.0, SE3()}};
  const auto ev = evaluate_trajectory(gt, est, {});
  EXPECT_TRUE(ev.matches.empty());
  EXPECT_EQ(ev.ate.translation_m.count, 0u);
  TrajectoryMetricsParams bad;
  bad.rpe_delta_frames = 0;
  EXPECT_THROW(evaluate_trajectory(gt, est, bad), ConfigError);
  bad = {};
  bad.max_time_difference_s = -1;
  EXPECT_THROW(evaluate_trajectory(gt, est, bad), ConfigError);
}

}  // namespace
}  // namespace orpe
