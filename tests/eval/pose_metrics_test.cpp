#include "orpe/eval/pose_metrics.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>

#include "orpe/core/error.h"
#include "orpe/io/dataset.h"
#include "orpe/io/model_io.h"
#include "support/in_memory_reader.h"
#include "support/test_data.h"

namespace orpe {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::vector<Vec3> cube_corners(double half_side_m) {
  std::vector<Vec3> c;
  for (int i = 0; i < 8; ++i)
    c.emplace_back(i & 1 ? half_side_m : -half_side_m, i & 2 ? half_side_m : -half_side_m,
                   i & 4 ? half_side_m : -half_side_m);
  return c;
}

SE3 random_pose(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Vec6 xi;
  xi << 0.2 * n(rng), 0.2 * n(rng), 0.8 + 0.1 * n(rng), n(rng), n(rng), n(rng);
  return SE3::exp(xi);
}

std::vector<Vec3> random_points(std::mt19937& rng, int n, Vec3 half_extent) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Vec3> p;
  for (int i = 0; i < n; ++i) p.push_back(Vec3(u(rng), u(rng), u(rng)).cwiseProduct(half_extent));
  return p;
}

/// REFERENCE.md's closed form of the VOCap area (percent).
double auc_closed_form(const std::vector<double>& d, double max_d) {
  double sum = 0, largest = -1;
  for (double x : d)
    if (x <= max_d) {
      sum += 1.0 - x / max_d;
      largest = std::max(largest, x);
    }
  if (largest < 0) return 0.0;
  return 100.0 / d.size() * (sum + largest / max_d);
}

/// The "ideal" area under the accuracy curve (no VOCap step bias), for comparison.
double auc_ideal(const std::vector<double>& d, double max_d) {
  double sum = 0;
  for (double x : d)
    if (x <= max_d) sum += 1.0 - x / max_d;
  return 100.0 / d.size() * sum;
}

// ---- ADD / ADD-S ----

TEST(AddMetrics, CubeShiftedOneCentimetre) {
  std::mt19937 rng(1);
  const auto corners = cube_corners(0.05);
  const ModelPoints model(corners);
  for (int trial = 0; trial < 10; ++trial) {
    const SE3 gt = random_pose(rng);
    const Vec3 dir = random_points(rng, 1, Vec3(1, 1, 1))[0].normalized();
    const SE3 est(gt.rotation(), gt.translation() + 0.01 * dir);
    EXPECT_NEAR(add_distance(corners, gt, est), 0.01, 1e-12);
    EXPECT_NEAR(adds_distance(model, gt, est), 0.01, 1e-12);
  }
}

TEST(AddMetrics, QuarterTurnAboutCubeAxisIsZeroForAddS) {
  std::mt19937 rng(2);
  const auto corners = cube_corners(0.05);
  const ModelPoints model(corners);
  for (const Vec3& axis : {Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)}) {
    const SE3 gt = random_pose(rng);
    const SE3 est = gt * SE3(so3_exp(M_PI / 2 * axis), Vec3::Zero());
    EXPECT_LT(adds_distance(model, gt, est), 1e-12);
    // Each corner moves on a circle of radius 0.05 * sqrt(2) by 90 degrees: 0.1 m.
    EXPECT_NEAR(add_distance(corners, gt, est), 0.1, 1e-12);
  }
  // A turn that is not a symmetry of the cube is not free.
  const SE3 gt = random_pose(rng);
  EXPECT_GT(adds_distance(model, gt, gt * SE3(so3_exp(Vec3(0, 0, 0.3)), Vec3::Zero())), 1e-3);
}

TEST(AddMetrics, KdTreeEqualsBruteForce) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 5; ++trial) {
    const auto pts = random_points(rng, 500, Vec3(0.05, 0.03, 0.08));
    const ModelPoints model(pts);
    const SE3 gt = random_pose(rng);
    const SE3 est = gt * SE3::exp((Vec6() << 0.01, -0.02, 0.005, 0.1, 0.2, -0.1).finished());
    EXPECT_NEAR(adds_distance(model, gt, est), adds_distance_brute_force(pts, gt, est), 1e-12);
    // ADD-S never exceeds ADD (the point's own image is one of the candidates).
    EXPECT_LE(adds_distance(model, gt, est), add_distance(pts, gt, est) + 1e-15);
  }
}

TEST(AddMetrics, ModelPointsSurviveMoves) {
  std::mt19937 rng(4);
  const auto pts = random_points(rng, 100, Vec3(0.05, 0.05, 0.05));
  std::map<int, ModelPoints> models;
  models.emplace(1, ModelPoints(pts));
  ModelPoints moved = std::move(models.at(1));
  models.clear();
  const SE3 gt = random_pose(rng);
  const SE3 est = gt * SE3(so3_exp(Vec3(0.2, 0, 0)), Vec3(0.01, 0, 0));
  EXPECT_NEAR(adds_distance(moved, gt, est), adds_distance_brute_force(pts, gt, est), 1e-12);
  EXPECT_THROW(ModelPoints(std::vector<Vec3>{}), std::invalid_argument);
}

TEST(AddMetrics, RealModelKdTreeEqualsBruteForce) {
  ORPE_REQUIRE_DATA(data, "ycbv/models/061_foam_brick/points.xyz");
  const auto pts = read_xyz_points(data + "/ycbv/models/061_foam_brick/points.xyz");
  const ModelPoints model(pts);
  std::mt19937 rng(5);
  const SE3 gt = random_pose(rng);
  const SE3 est = gt * SE3::exp((Vec6() << 0.003, 0.002, -0.004, 0.05, -0.03, 0.2).finished());
  EXPECT_NEAR(adds_distance(model, gt, est), adds_distance_brute_force(pts, gt, est), 1e-12);
}

// ---- AUC ----

TEST(YcbAuc, SingleHandComputedCases) {
  // n = 1, d = 0.05: mrec = [0, .05, .1], mpre = [0, 1, 1] -> area 0.1 -> x10 -> 100 %.
  EXPECT_NEAR(ycb_auc_percent({0.05}), 100.0, 1e-12);
  // n = 2, d = {0.02, miss}: mrec = [0, .02, .1], mpre = [0, .5, .5] -> 0.05 -> 50 %.
  EXPECT_NEAR(ycb_auc_percent({0.02, kInf}), 50.0, 1e-12);
  // n = 4, d = {0.01, 0.03, 0.2, miss}: mrec = [0, .01, .03, .1], mpre = [0, .25, .5, .5]
  //   area = .01*.25 + .02*.5 + .07*.5 = 0.0475 -> 47.5 %.
  EXPECT_NEAR(ycb_auc_percent({0.03, 0.2, 0.01, kInf}), 47.5, 1e-12);
  EXPECT_NEAR(ycb_auc_percent({0.0, 0.0}), 100.0, 1e-12);
}

TEST(YcbAuc, EqualsReferenceClosedFormNotTheIdealArea) {
  std::mt19937 rng(6);
  std::uniform_real_distribution<double> u(0.0, 0.15);
  std::uniform_int_distribution<int> miss(0, 4);
  for (int trial = 0; trial < 200; ++trial) {
    std::vector<double> d;
    const int n = 1 + trial % 37;
    for (int i = 0; i < n; ++i) d.push_back(miss(rng) == 0 ? kInf : u(rng));
    if (trial % 5 == 0) d.push_back(0.1);  // exactly the maximum counts as found
    if (trial % 7 == 0) d.push_back(std::numeric_limits<double>::quiet_NaN());  // a miss
    const double vocap = ycb_auc_percent(d);
    EXPECT_NEAR(vocap, auc_closed_form(d, 0.1), 1e-9) << "trial " << trial;
    bool any_finite = false;
    for (double x : d) any_finite |= x <= 0.1;
    if (any_finite) {
      EXPECT_GT(vocap, auc_ideal(d, 0.1) + 1e-9);  // VOCap adds (100/n) d_max/0.1
    }
  }
}

TEST(YcbAuc, OtherMaximumScalesTheCurve) {
  // The same distances relative to the maximum give the same area.
  const std::vector<double> d{0.01, 0.02, 0.07, kInf, 0.3};
  std::vector<double> d2;
  for (double x : d) d2.push_back(2 * x);
  EXPECT_NEAR(ycb_auc_percent(d, 0.1), ycb_auc_percent(d2, 0.2), 1e-9);
}

TEST(YcbAuc, DegenerateCases) {
  EXPECT_EQ(ycb_auc_percent({}), 0.0);
  EXPECT_EQ(ycb_auc_percent({kInf, kInf, 0.5}), 0.0);
  EXPECT_EQ(fraction_below({}, 0.02), 0.0);
  EXPECT_DOUBLE_EQ(fraction_below({0.01, 0.02, kInf, 0.019}, 0.02), 0.5);  // strict <
}

// ---- Matching results to ground truth ----

struct Scene {
  std::vector<Vec3> pts_a, pts_b;  // class 1 (plain) and class 2 (symmetric)
  std::map<int, ModelPoints> models;
  std::vector<PoseGroundTruthInstance> gt;
};

Scene make_scene(std::mt19937& rng) {
  Scene s;
  s.pts_a = random_points(rng, 300, Vec3(0.04, 0.02, 0.06));
  s.pts_b = cube_corners(0.03);
  s.models.emplace(1, ModelPoints(s.pts_a));
  s.models.emplace(2, ModelPoints(s.pts_b));
  for (int im = 0; im < 6; ++im) {
    s.gt.push_back({48, im, 1, random_pose(rng)});
    s.gt.push_back({48, im, 2, random_pose(rng)});
  }
  return s;
}

PoseResultRow row(int im, int obj, double score, const SE3& T) {
  PoseResultRow r;
  r.scene_id = 48;
  r.im_id = im;
  r.obj_id = obj;
  r.score = score;
  r.T_cam_obj = T;
  return r;
}

TEST(PoseResults, MatchesByKeyTakesHighestScoreAndCountsMisses) {
  std::mt19937 rng(7);
  Scene s = make_scene(rng);
  std::vector<PoseResultRow> rows;
  std::vector<double> adds_1, add_1, adds_2, add_2;  // expected, per class
  for (const auto& g : s.gt) {
    if (g.im_id == 5) continue;  // image 5: all missed
    const auto& pts = g.class_id == 1 ? s.pts_a : s.pts_b;
    const SE3 est =
        g.T_cam_obj *
        SE3::exp((Vec6() << 0.002 * g.im_id, 0.01, -0.004, 0.05 * g.im_id, 0.02, 0.1).finished());
    rows.push_back(row(g.im_id, g.class_id, 0.9, est));
    // A worse and a better-fitting row with lower scores are ignored.
    rows.push_back(row(g.im_id, g.class_id, 0.5, g.T_cam_obj));
    rows.push_back(row(g.im_id, g.class_id, 0.1, random_pose(rng)));
    (g.class_id == 1 ? adds_1 : adds_2).push_back(adds_distance_brute_force(pts, g.T_cam_obj, est));
    (g.class_id == 1 ? add_1 : add_2).push_back(add_distance(pts, g.T_cam_obj, est));
  }
  for (auto* v : {&adds_1, &add_1, &adds_2, &add_2}) v->push_back(kInf);  // image 5
  rows.push_back(row(9, 1, 1.0, SE3()));  // no such image: unmatched
  PoseResultRow other = row(0, 1, 1.0, SE3());
  other.scene_id = 7;
  rows.push_back(other);

  const auto ev = evaluate_pose_results(s.gt, rows, s.models, {2}, {{1, "plain"}}, {});
  ASSERT_EQ(ev.classes.size(), 2u);
  EXPECT_EQ(ev.classes[0].name, "plain");
  EXPECT_EQ(ev.classes[1].name, "class_2");
  EXPECT_FALSE(ev.classes[0].symmetric);
  EXPECT_TRUE(ev.classes[1].symmetric);
  EXPECT_EQ(ev.classes[0].instances, 6u);
  EXPECT_EQ(ev.classes[0].estimated, 5u);
  EXPECT_NEAR(ev.classes[0].adds_auc, ycb_auc_percent(adds_1), 1e-9);
  EXPECT_NEAR(ev.classes[0].add_s_auc, ycb_auc_percent(add_1), 1e-9);  // plain: ADD
  EXPECT_NEAR(ev.classes[1].adds_auc, ycb_auc_percent(adds_2), 1e-9);
  EXPECT_NEAR(ev.classes[1].add_s_auc, ycb_auc_percent(adds_2), 1e-9);  // symmetric: ADD-S
  EXPECT_NEAR(ev.classes[1].add_auc, ycb_auc_percent(add_2), 1e-9);
  EXPECT_NEAR(ev.classes[0].adds_below, fraction_below(adds_1, 0.02), 1e-12);
  // ALL pools the instances (not the mean of the class figures).
  std::vector<double> all_adds = adds_1;
  all_adds.insert(all_adds.end(), adds_2.begin(), adds_2.end());
  std::vector<double> all_add_s = add_1;
  all_add_s.insert(all_add_s.end(), adds_2.begin(), adds_2.end());
  EXPECT_EQ(ev.all.instances, 12u);
  EXPECT_EQ(ev.all.name, "ALL");
  EXPECT_NEAR(ev.all.adds_auc, ycb_auc_percent(all_adds), 1e-9);
  EXPECT_NEAR(ev.all.add_s_auc, ycb_auc_percent(all_add_s), 1e-9);
  EXPECT_EQ(ev.unmatched_rows, 1u);
  EXPECT_EQ(ev.other_scene_rows, 1u);
  EXPECT_EQ(ev.result_rows, rows.size());
  // The tables name every class and the pooled row.
  for (const std::string& table : {ev.report(), ev.markdown(), ev.to_json()}) {
    EXPECT_NE(table.find("plain"), std::string::npos);
    EXPECT_NE(table.find("ALL"), std::string::npos);
  }
}

TEST(PoseResults, SeveralInstancesOfOneClassMatchOneToOne) {
  std::mt19937 rng(8);
  const auto pts = random_points(rng, 200, Vec3(0.03, 0.03, 0.05));
  std::map<int, ModelPoints> models;
  models.emplace(3, ModelPoints(pts));
  const SE3 g1(Mat3::Identity(), Vec3(-0.2, 0, 0.8)), g2(Mat3::Identity(), Vec3(0.2, 0, 0.8));
  const std::vector<PoseGroundTruthInstance> gt{{1, 0, 3, g1}, {1, 0, 3, g2}};
  const SE3 e1(Mat3::Identity(), Vec3(-0.2, 0.005, 0.8)), e2(Mat3::Identity(), Vec3(0.21, 0, 0.8));
  // Listed in the "wrong" order, and a third low-score row that would fit g1 perfectly.
  std::vector<PoseResultRow> rows{row(0, 3, 0.8, e2), row(0, 3, 0.9, e1), row(0, 3, 0.1, g1)};
  for (auto& r : rows) r.scene_id = 1;
  const auto ev = evaluate_pose_results(gt, rows, models, {}, {}, {});
  ASSERT_EQ(ev.instances.size(), 2u);
  EXPECT_NEAR(ev.instances[0].add_m, 0.005, 1e-12);
  EXPECT_NEAR(ev.instances[1].add_m, 0.01, 1e-12);
  EXPECT_TRUE(ev.instances[0].estimated && ev.instances[1].estimated);
}

TEST(PoseResults, NoResultsMeansAllMissesAndNoInstancesIsEmpty) {
  std::mt19937 rng(9);
  Scene s = make_scene(rng);
  const auto ev = evaluate_pose_results(s.gt, {}, s.models, {}, {}, {});
  EXPECT_EQ(ev.all.instances, s.gt.size());
  EXPECT_EQ(ev.all.estimated, 0u);
  EXPECT_EQ(ev.all.adds_auc, 0.0);
  EXPECT_EQ(ev.all.adds_below, 0.0);
  const auto empty = evaluate_pose_results({}, {}, s.models, {}, {}, {});
  EXPECT_EQ(empty.all.instances, 0u);
  EXPECT_TRUE(empty.classes.empty());
  EXPECT_EQ(empty.all.adds_auc, 0.0);
  // Ground truth of a class without model points is a usage error.
  EXPECT_THROW(evaluate_pose_results({{0, 0, 99, SE3()}}, {}, s.models, {}, {}, {}),
               std::invalid_argument);
  PoseMetricsParams bad;
  bad.auc_max_distance_m = 0;
  EXPECT_THROW(evaluate_pose_results(s.gt, {}, s.models, {}, {}, bad), ConfigError);
}

// ---- Through the DatasetReader interface ----

using FakeReader = test::InMemoryReader;

TEST(PoseResults, ReadsGroundTruthAndModelsFromTheDataset) {
  const std::string dir = test::scratch_dir("ds");
  {
    std::ofstream os(dir + "/cube_mm.xyz");
    for (const Vec3& c : cube_corners(50.0)) os << c.x() << " " << c.y() << " " << c.z() << "\n";
  }
  DatasetInfo info;
  info.root = dir;
  info.scene_id = 3;
  info.model_units_per_m = 1000.0;  // the file is in mm
  info.model_points_paths[5] = dir + "/cube_mm.xyz";
  info.class_names[5] = "cube";
  info.symmetric_classes = {5};
  std::vector<RgbdFrame> frames(2);
  std::mt19937 rng(10);
  for (int i = 0; i < 2; ++i) {
    frames[i].index = 10 + i;
    ObjectGroundTruth o;
    o.class_id = 5;
    o.T_cam_obj = random_pose(rng);
    frames[i].objects_gt.push_back(o);
  }
  // Frame 10: 1 cm off; frame 11: a quarter turn (ADD-S 0, ADD 0.1).
  PoseResultRow r1 = row(10, 5, 1.0,
                         SE3(frames[0].objects_gt[0].T_cam_obj.rotation(),
                             frames[0].objects_gt[0].T_cam_obj.translation() + Vec3(0.01, 0, 0)));
  PoseResultRow r2 =
      row(11, 5, 1.0,
          frames[1].objects_gt[0].T_cam_obj * SE3(so3_exp(Vec3(0, 0, M_PI / 2)), Vec3::Zero()));
  r1.scene_id = r2.scene_id = 3;
  const FakeReader reader(info, frames);
  const auto ev = evaluate_pose_results(reader, {r1, r2}, {});
  ASSERT_EQ(ev.instances.size(), 2u);
  EXPECT_EQ(ev.instances[0].im_id, 10);
  EXPECT_NEAR(ev.instances[0].adds_m, 0.01, 1e-12);
  EXPECT_NEAR(ev.instances[1].adds_m, 0.0, 1e-12);
  EXPECT_NEAR(ev.instances[1].add_m, 0.1, 1e-12);
  EXPECT_EQ(ev.classes.at(0).name, "cube");
  EXPECT_NEAR(ev.all.add_s_auc, ycb_auc_percent({0.01, 0.0}), 1e-9);

  DatasetInfo no_model = info;
  no_model.model_points_paths.erase(5);
  no_model.model_points_paths[6] = dir + "/cube_mm.xyz";
  try {
    evaluate_pose_results(FakeReader(no_model, frames), {}, {});
    FAIL();
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("class 5"), std::string::npos) << e.what();
  }
  DatasetInfo no_models_at_all = info;
  no_models_at_all.model_points_paths.clear();
  no_models_at_all.format = "tum";
  try {
    evaluate_pose_results(FakeReader(no_models_at_all, frames), {}, {});
    FAIL();
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("no object models"), std::string::npos) << e.what();
  }
  DatasetInfo missing_file = info;
  missing_file.model_points_paths[5] = dir + "/nope.xyz";
  try {
    evaluate_pose_results(FakeReader(missing_file, frames), {}, {});
    FAIL();
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("nope.xyz"), std::string::npos) << e.what();
  }
}

TEST(PoseResults, KeyframeFilterAndSeveralScenes) {
  const std::string dir = test::scratch_dir("kf");
  {
    std::ofstream os(dir + "/cube.xyz");
    for (const Vec3& c : cube_corners(0.05)) os << c.x() << " " << c.y() << " " << c.z() << "\n";
  }
  auto make_info = [&](int scene) {
    DatasetInfo info;
    info.root = dir;
    info.format = "ycbv";
    info.scene_id = scene;
    info.model_points_paths[1] = dir + "/cube.xyz";
    return info;
  };
  std::vector<RgbdFrame> frames(3);
  for (int i = 0; i < 3; ++i) {
    frames[i].index = i + 1;
    ObjectGroundTruth o;
    o.class_id = 1;
    o.T_cam_obj = SE3(Mat3::Identity(), Vec3(0, 0, 1));
    frames[i].objects_gt.push_back(o);
  }
  const FakeReader a(make_info(48), frames), b(make_info(49), frames);
  // Scene 48 frame 2 is estimated 1 cm off; everything else is missed.
  PoseResultRow r = row(2, 1, 1.0, SE3(Mat3::Identity(), Vec3(0.01, 0, 1)));
  const auto all = evaluate_pose_results({&a, &b}, {r}, {});
  EXPECT_EQ(all.all.instances, 6u);
  EXPECT_EQ(all.all.estimated, 1u);
  const FrameSet keyframes{{48, 2}, {49, 3}, {50, 1}};
  const auto kf = evaluate_pose_results({&a, &b}, {r}, {}, &keyframes);
  EXPECT_EQ(kf.all.instances, 2u);
  EXPECT_EQ(kf.all.estimated, 1u);
  EXPECT_NEAR(kf.all.adds_auc, ycb_auc_percent({0.01, kInf}), 1e-9);
  EXPECT_NE(kf.to_json().find("\"instances\""), std::string::npos);
}

TEST(KeyframeList, ReadsYcbFormatAndRejectsBadLines) {
  const std::string dir = test::scratch_dir("kl");
  std::ofstream(dir + "/kf.txt") << "0048/000001\r\n# comment\n\n0059/001234\n";
  const FrameSet kf = read_keyframe_list(dir + "/kf.txt");
  EXPECT_EQ(kf, (FrameSet{{48, 1}, {59, 1234}}));
  std::ofstream(dir + "/bad.txt") << "0048/000001\n0048-000002\n";
  try {
    read_keyframe_list(dir + "/bad.txt");
    FAIL();
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("line 2"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("bad.txt"), std::string::npos) << e.what();
  }
  std::ofstream(dir + "/empty.txt") << "# nothing\n";
  EXPECT_THROW(read_keyframe_list(dir + "/empty.txt"), IoError);
  EXPECT_THROW(read_keyframe_list(dir + "/missing.txt"), IoError);
}

TEST(KeyframeList, SharedYcbKeyframesParse) {
  ORPE_REQUIRE_DATA(data, "ycbv/keyframe.txt");
  const FrameSet kf = read_keyframe_list(data + "/ycbv/keyframe.txt");
  EXPECT_EQ(kf.size(), 2949u);  // the official YCB-Video test keyframes (README)
  EXPECT_EQ(kf.begin()->first, 48);
  EXPECT_EQ(kf.rbegin()->first, 59);
}

}  // namespace
}  // namespace orpe
