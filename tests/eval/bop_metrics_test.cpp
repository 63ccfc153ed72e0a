// BOP pose errors (VSD, MSSD, MSPD) and their average recall against hand-computed cases.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "orpe/core/error.h"
#include "orpe/eval/bop_pose_errors.h"
#include "orpe/eval/bop_pose_metrics.h"
#include "support/test_data.h"

namespace orpe {
namespace {

SE3 translate(double x, double y, double z) {
  return SE3(Mat3::Identity(), Vec3(x, y, z));
}
SE3 rot_z(double a) {
  return SE3(Eigen::AngleAxisd(a, Vec3::UnitZ()).toRotationMatrix(), Vec3::Zero());
}

std::vector<Vec3> box_corners(double sx, double sy, double sz) {
  std::vector<Vec3> c;
  for (int i = 0; i < 8; ++i)
    c.emplace_back((i & 1 ? 0.5 : -0.5) * sx, (i & 2 ? 0.5 : -0.5) * sy, (i & 4 ? 0.5 : -0.5) * sz);
  return c;
}

TEST(BopPoseErrors, KnownShift) {
  const std::vector<Vec3> pts{{0, 0, 0}, {0, 0, 0.1}, {0.05, 0, 0}};
  const SE3 T_gt = translate(0, 0, 1.0);
  const SE3 T_est = translate(0.01, 0, 0) * T_gt;  // 1 cm to the right, in the camera frame
  const std::vector<SE3> identity{SE3()};
  EXPECT_NEAR(mssd_m(pts, T_est, T_gt, identity), 0.01, 1e-12);
  // Projections move by fx * 0.01 / z: 5 px at z = 1 (the nearest points), 4.55 px at z = 1.1.
  PinholeIntrinsics K;
  K.fx = K.fy = 500;
  EXPECT_NEAR(mspd_px(pts, K, T_est, T_gt, identity), 5.0, 1e-9);
  EXPECT_NEAR(mspd_px(pts, K, T_gt, T_gt, identity), 0.0, 1e-12);
}

TEST(BopPoseErrors, SymmetricFlipCostsNothingOnlyWithItsSymmetry) {
  const auto pts = box_corners(0.2, 0.1, 0.05);
  const SE3 T_gt = SE3(Eigen::AngleAxisd(0.4, Vec3(1, 2, 3).normalized()).toRotationMatrix(),
                       Vec3(0.1, -0.05, 0.9));
  const SE3 T_est = T_gt * rot_z(M_PI);  // turned about its z axis: the box looks the same
  BopModelInfo info;
  info.diameter_m = std::sqrt(0.2 * 0.2 + 0.1 * 0.1 + 0.05 * 0.05);
  const auto no_sym = bop_symmetry_transformations(info);
  ASSERT_EQ(no_sym.size(), 1u);
  // Without the symmetry every corner moves to the opposite one in x and y: 2 * sqrt(0.1^2 +
  // 0.05^2).
  EXPECT_NEAR(mssd_m(pts, T_est, T_gt, no_sym), 2 * std::sqrt(0.01 + 0.0025), 1e-12);
  info.symmetries_discrete.push_back(rot_z(M_PI));
  const auto syms = bop_symmetry_transformations(info);
  ASSERT_EQ(syms.size(), 2u);
  EXPECT_NEAR(mssd_m(pts, T_est, T_gt, syms), 0.0, 1e-12);
  PinholeIntrinsics K;
  EXPECT_NEAR(mspd_px(pts, K, T_est, T_gt, syms), 0.0, 1e-9);
  EXPECT_GT(mspd_px(pts, K, T_est, T_gt, no_sym), 50.0);
}

TEST(BopPoseErrors, ContinuousSymmetryIsDiscretisedAsTheToolkit) {
  // A ring of radius 5 cm about an axis through (0.1, 0, 0) along z, turned 0.3 rad about it.
  std::vector<Vec3> pts;
  const Vec3 c(0.1, 0, 0);
  for (int i = 0; i < 36; ++i)
    for (double z : {-0.05, 0.05})
      pts.push_back(c + Vec3(0.05 * std::cos(i * M_PI / 18), 0.05 * std::sin(i * M_PI / 18), z));
  BopModelInfo info;
  info.diameter_m = std::sqrt(0.1 * 0.1 + 0.1 * 0.1);
  info.symmetries_continuous.push_back({Vec3::UnitZ(), c});
  const auto syms = bop_symmetry_transformations(info, 0.01);
  const int steps = static_cast<int>(std::ceil(M_PI / 0.01));  // 315
  ASSERT_EQ(syms.size(), static_cast<size_t>(steps));
  info.symmetries_discrete.push_back(
      SE3(Eigen::AngleAxisd(M_PI, Vec3::UnitX()).toRotationMatrix(), Vec3(0, 0, 0)));
  EXPECT_EQ(bop_symmetry_transformations(info, 0.01).size(), 2u * steps);
  const SE3 T_gt = translate(0, 0, 1);
  const SE3 turn(Eigen::AngleAxisd(0.3, Vec3::UnitZ()).toRotationMatrix(),
                 c - Eigen::AngleAxisd(0.3, Vec3::UnitZ()).toRotationMatrix() * c);
  const SE3 T_est = T_gt * turn;
  // The nearest discrete step is at most half a step (pi / 315) away: a chord of at most
  // 2 r sin(pi / 630); without the symmetry, the chord of 0.3 rad.
  const double e = mssd_m(pts, T_est, T_gt, syms);
  EXPECT_LE(e, 2 * 0.05 * std::sin(M_PI / (2 * steps)) + 1e-12);
  EXPECT_NEAR(mssd_m(pts, T_est, T_gt, {SE3()}), 2 * 0.05 * std::sin(0.15), 1e-12);
}

/// 10 x 10 images, principal point at the centre: columns [c0, c1) at depth z, else 0.
DepthImage columns(int c0, int c1, float z) {
  DepthImage d(10, 10, 0.0f);
  for (int v = 0; v < 10; ++v)
    for (int u = c0; u < c1; ++u) d.at(u, v) = z;
  return d;
}

PinholeIntrinsics small_camera() {
  PinholeIntrinsics K;
  K.width = K.height = 10;
  K.fx = K.fy = 1000;
  K.cx = K.cy = 4.5;
  return K;
}

std::vector<double> taus_m(double diameter_m) {
  std::vector<double> t;
  for (double tau : bop_vsd_taus()) t.push_back(tau * diameter_m);
  return t;
}

TEST(BopPoseErrors, VsdHandComputed) {
  const PinholeIntrinsics K = small_camera();
  const double delta = 0.015, diameter = 0.1;
  // The test scene: the object (columns 0-5 at 1 m) in front of a wall at 2 m.
  DepthImage test = columns(0, 10, 2.0f);
  for (int v = 0; v < 10; ++v)
    for (int u = 0; u < 6; ++u) test.at(u, v) = 1.0f;
  const DepthImage gt = columns(0, 6, 1.0f);
  // Perfect estimate: 0.
  for (double e : vsd_errors(test, gt, gt, K, delta, taus_m(diameter))) EXPECT_NEAR(e, 0.0, 1e-12);
  // Shifted two columns: V_gt = columns 0-5, V_est = 2-7 (in front of the wall), intersection 2-5
  // (same distances), union 0-7: (0 + 80 - 40) / 80.
  for (double e : vsd_errors(test, columns(2, 8, 1.0f), gt, K, delta, taus_m(diameter)))
    EXPECT_NEAR(e, 0.5, 1e-12);
  // Same silhouette 3.2 cm farther (behind the test surface, but visible where V_gt is): every
  // pixel differs by 0.032 x (ray length / z) >= 0.32 diameters: error 1 for tau <= 0.30, 0 above.
  const auto far = vsd_errors(test, columns(0, 6, 1.032f), gt, K, delta, taus_m(diameter));
  ASSERT_EQ(far.size(), 10u);
  for (size_t i = 0; i < far.size(); ++i) EXPECT_NEAR(far[i], i < 6 ? 1.0 : 0.0, 1e-12) << i;
  // An occluder at 0.5 m over columns 0-2: the hidden part is in neither mask. The estimate
  // shifted into the occluded part is then half wrong: V_gt = 3-5; V_est (columns 1-6 at 1 m) =
  // 3-6 (1-2 are hidden, 6 is in front of the wall); union 3-6 = 40 px, intersection 30 px.
  DepthImage occluded = test;
  for (int v = 0; v < 10; ++v)
    for (int u = 0; u < 3; ++u) occluded.at(u, v) = 0.5f;
  for (double e : vsd_errors(occluded, gt, gt, K, delta, taus_m(diameter)))
    EXPECT_NEAR(e, 0.0, 1e-12);
  for (double e : vsd_errors(occluded, columns(1, 7, 1.0f), gt, K, delta, taus_m(diameter)))
    EXPECT_NEAR(e, 10.0 / 40.0, 1e-12);
  // Missing test depth counts as visible (bop19): with no depth at all the estimate in the wrong
  // place is wrong everywhere outside the overlap.
  const DepthImage none(10, 10, 0.0f);
  for (double e : vsd_errors(none, columns(3, 9, 1.0f), gt, K, delta, taus_m(diameter)))
    EXPECT_NEAR(e, 6.0 * 10 / 90.0, 1e-12);  // union 0-8 (90 px), intersection 3-5 (30 px)
  // Nothing visible at all: 1.
  for (double e : vsd_errors(test, none, none, K, delta, taus_m(diameter))) EXPECT_EQ(e, 1.0);
}

TEST(BopPoseErrors, ModelsInfoIsReadInMetresAndBadEntriesNamed) {
  const std::string dir = test::scratch_dir("info");
  const std::string good = dir + "/models_info.json";
  std::ofstream(good) << R"({"1": {"diameter": 250.5, "symmetries_discrete": [[-1, 0, 0, 10,
    0, -1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]]}, "7": {"diameter": 80, "symmetries_continuous":
    [{"axis": [0, 0, 2], "offset": [0, 5, 0]}]}})";
  const auto info = read_bop_models_info(good);
  ASSERT_EQ(info.size(), 2u);
  EXPECT_DOUBLE_EQ(info.at(1).diameter_m, 0.2505);
  ASSERT_EQ(info.at(1).symmetries_discrete.size(), 1u);
  EXPECT_NEAR((info.at(1).symmetries_discrete[0].translation() - Vec3(0.01, 0, 0)).norm(), 0,
              1e-12);
  ASSERT_EQ(info.at(7).symmetries_continuous.size(), 1u);
  EXPECT_NEAR((info.at(7).symmetries_continuous[0].axis - Vec3::UnitZ()).norm(), 0, 1e-12);
  EXPECT_NEAR(info.at(7).symmetries_continuous[0].offset_m.y(), 0.005, 1e-12);
  const std::string bad = dir + "/bad.json";
  std::ofstream(bad) << R"({"1": {"diameter": 10}, "3": {"size_x": 4}})";
  try {
    read_bop_models_info(bad);
    FAIL() << "no error";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find(bad), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("object 3"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("diameter"), std::string::npos) << e.what();
  }
  std::ofstream(bad) << R"({"2": {"diameter": 10, "symmetries_discrete": [[2, 0, 0, 0, 0, 1, 0,
    0, 0, 0, 1, 0, 0, 0, 0, 1]]}})";
  EXPECT_THROW(read_bop_models_info(bad), IoError);
  EXPECT_THROW(read_bop_models_info(dir + "/missing.json"), IoError);
}

BopEstimate estimate(int im, int obj, double score, std::map<int, double> mssd_fraction) {
  BopEstimate e{0, im, obj, score, {}};
  for (const auto& [gt, f] : mssd_fraction) {
    BopPoseErrors err;
    err.vsd.assign(bop_vsd_taus().size(), f);
    err.mssd_m = f * 0.2;   // diameter 0.2 m
    err.mspd_px = f * 100;  // 640 px wide: thresholds 5..50 px
    e.errors[gt] = err;
  }
  return e;
}

TEST(BopRecall, GreedyMatchingByScoreAndSmallestError) {
  const std::map<int, double> diam{{1, 0.2}, {2, 0.2}};
  const std::map<int, int> width{{0, 640}};
  // Image 0: two instances of object 1. One estimate, far from gt 0 (0.12 diameters), close to gt 1
  // (0.02): it takes gt 1 at every threshold, so recall 1 / 2 everywhere.
  std::vector<BopTarget> targets{{0, 0, 1, 0, true}, {0, 0, 1, 1, true}};
  std::vector<BopEstimate> ests{estimate(0, 1, 0.9, {{0, 0.12}, {1, 0.02}})};
  BopRecalls r = bop_recalls(targets, ests, diam, width);
  EXPECT_NEAR(r.ar_mssd, 0.5, 1e-12);
  EXPECT_NEAR(r.ar_vsd, 0.5, 1e-12);
  EXPECT_NEAR(r.ar_mspd, 0.5, 1e-12);  // 2 px < 5 px
  EXPECT_NEAR(r.ar, 0.5, 1e-12);
  // gt 1 not a target (too hidden): the estimate can only match gt 0, below thresholds 0.15..0.5
  // (8 of 10; the threshold is strict), and there is one target.
  targets[1].valid = false;
  r = bop_recalls(targets, ests, diam, width);
  EXPECT_NEAR(r.ar_mssd, 0.8, 1e-12);
  EXPECT_NEAR(r.ar_vsd, 0.8, 1e-12);
  // MSPD 12 px < 15 px..50 px: 8 of 10 too; at width 1280 the pixel errors count half (6 px <
  // 10..50 px: 9 of 10).
  EXPECT_NEAR(r.ar_mspd, 0.8, 1e-12);
  EXPECT_NEAR(bop_recalls(targets, ests, diam, {{0, 1280}}).ar_mspd, 0.9, 1e-12);
  // Estimates are matched by decreasing score: B (0.8) takes gt 0 (0.02 < its 0.4 to gt 1), so A
  // (0.4, only close to gt 0) matches nothing: recall 1 / 2 everywhere. Matched in the other order
  // A would take gt 0 and B gt 1 at thresholds 0.45 and 0.5: AR 0.6.
  targets = {{0, 3, 2, 0, true}, {0, 3, 2, 1, true}};
  ests = {estimate(3, 2, 0.4, {{0, 0.01}}), estimate(3, 2, 0.8, {{0, 0.02}, {1, 0.4}})};
  r = bop_recalls(targets, ests, diam, width);
  EXPECT_NEAR(r.ar_mssd, 0.5, 1e-12);
  // No estimates: recall 0; no targets: 0.
  EXPECT_EQ(bop_recalls(targets, {}, diam, width).ar, 0.0);
  EXPECT_EQ(bop_recalls({}, {}, diam, width).ar, 0.0);
}

TEST(BopRecall, ThresholdsAreTheToolkits) {
  ASSERT_EQ(bop_vsd_taus().size(), 10u);
  EXPECT_NEAR(bop_vsd_taus().front(), 0.05, 1e-12);
  EXPECT_NEAR(bop_vsd_taus().back(), 0.5, 1e-12);
  ASSERT_EQ(bop_fraction_thresholds().size(), 10u);
  ASSERT_EQ(bop_mspd_thresholds_px().size(), 10u);
  EXPECT_NEAR(bop_mspd_thresholds_px().front(), 5, 1e-12);
  EXPECT_NEAR(bop_mspd_thresholds_px().back(), 50, 1e-12);
}

}  // namespace
}  // namespace orpe
