// End-to-end tests of `orpe eval` (the built binary, ORPE_CLI_PATH).
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <Eigen/Eigenvalues>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>

#include "orpe/eval/pose_metrics.h"
#include "orpe/io/bop_results.h"
#include "orpe/io/dataset.h"
#include "orpe/io/model_io.h"
#include "orpe/io/point_cloud_io.h"
#include "orpe/io/trajectory_io.h"
#include "orpe/render/mesh_io.h"
#include "orpe/render/primitives.h"
#include "support/test_data.h"

namespace orpe {
namespace {

struct RunResult {
  int exit_code = -1;
  std::string output;  ///< stdout and stderr
};

RunResult run_cli(const std::string& args) {
  RunResult r;
  const std::string cmd = std::string(ORPE_CLI_PATH) + " " + args + " 2>&1";
  FILE* pipe = popen(cmd.c_str(), "r");
  if (!pipe) return r;
  std::array<char, 4096> buf;
  size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), pipe)) > 0) r.output.append(buf.data(), n);
  const int status = pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

nlohmann::json read_json(const std::string& path) {
  std::ifstream is(path);
  return nlohmann::json::parse(is);
}

/// ATE RMSE by Horn's quaternion method, written independently of the library.
double ate_rmse_horn(const std::vector<Vec3>& est, const std::vector<Vec3>& gt) {
  Vec3 mp = Vec3::Zero(), mq = Vec3::Zero();
  for (size_t i = 0; i < est.size(); ++i) {
    mp += est[i];
    mq += gt[i];
  }
  mp /= double(est.size());
  mq /= double(est.size());
  Mat3 M = Mat3::Zero();
  for (size_t i = 0; i < est.size(); ++i) M += (est[i] - mp) * (gt[i] - mq).transpose();
  Eigen::Matrix4d N;
  N << M(0, 0) + M(1, 1) + M(2, 2), M(1, 2) - M(2, 1), M(2, 0) - M(0, 2), M(0, 1) - M(1, 0),
      M(1, 2) - M(2, 1), M(0, 0) - M(1, 1) - M(2, 2), M(0, 1) + M(1, 0), M(2, 0) + M(0, 2),
      M(2, 0) - M(0, 2), M(0, 1) + M(1, 0), -M(0, 0) + M(1, 1) - M(2, 2), M(1, 2) + M(2, 1),
      M(0, 1) - M(1, 0), M(2, 0) + M(0, 2), M(1, 2) + M(2, 1), -M(0, 0) - M(1, 1) + M(2, 2);
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> eig(N);
  const Eigen::Vector4d q = eig.eigenvectors().col(3);
  const Mat3 R = Eigen::Quaterniond(q(0), q(1), q(2), q(3)).normalized().toRotationMatrix();
  double sq = 0;
  for (size_t i = 0; i < est.size(); ++i) sq += ((gt[i] - mq) - R * (est[i] - mp)).squaredNorm();
  return std::sqrt(sq / est.size());
}

/// Writes a ground-truth trajectory and a perturbed, rigidly moved, time-shifted copy.
void write_pair(const std::string& gt_path, const std::string& est_path, int n) {
  std::mt19937 rng(21);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<StampedPose> gt, est;
  SE3 T;
  const SE3 offset = SE3::exp((Vec6() << 1, -2, 0.5, 0.3, -1.0, 2.0).finished());
  for (int i = 0; i < n; ++i) {
    T = T * SE3::exp((Vec6() << 0.02 * g(rng), 0.02 * g(rng), 0.02 * g(rng), 0.02 * g(rng),
                      0.02 * g(rng), 0.02 * g(rng))
                         .finished());
    gt.push_back({100.0 + i / 30.0, T});
    SE3 p = offset * T *
            SE3::exp((Vec6() << 0.01 * g(rng), 0.01 * g(rng), 0.01 * g(rng), 0.005 * g(rng),
                      0.005 * g(rng), 0.005 * g(rng))
                         .finished());
    p.translation() += Vec3(0.001 * i, 0, 0);
    est.push_back({100.0 + i / 30.0 + 0.003, p});
  }
  write_tum_trajectory(gt_path, gt);
  write_tum_trajectory(est_path, est);
}

TEST(CliEvalTraj, PrintsTheDefinitionsAte) {
  const std::string dir = test::scratch_dir("traj");
  write_pair(dir + "/gt.txt", dir + "/est.txt", 150);
  const auto r =
      run_cli("eval traj " + dir + "/gt.txt " + dir + "/est.txt --json " + dir + "/out/ate.json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  // Independent computation from the files as written (all poses pair up: 3 ms apart, 33 ms
  // spacing).
  const auto gt = read_tum_trajectory(dir + "/gt.txt");
  const auto est = read_tum_trajectory(dir + "/est.txt");
  std::vector<Vec3> g, e;
  for (size_t i = 0; i < gt.size(); ++i) {
    g.push_back(gt[i].T_world_cam.translation());
    e.push_back(est[i].T_world_cam.translation());
  }
  const double expected = ate_rmse_horn(e, g);
  ASSERT_GT(expected, 0.005);
  const auto j = read_json(dir + "/out/ate.json");
  EXPECT_EQ(j["pairs"].get<int>(), 150);
  EXPECT_NEAR(j["ate"]["translation_m"]["rmse"].get<double>(), expected, 1e-9);
  EXPECT_NE(r.output.find(fmt::format("rmse {:.6f} m", expected)), std::string::npos) << r.output;

  // RPE with delta 1: the definition applied directly to the files' poses.
  double sq = 0;
  for (size_t i = 0; i + 1 < gt.size(); ++i) {
    const SE3 E = (gt[i].T_world_cam.inverse() * gt[i + 1].T_world_cam).inverse() *
                  (est[i].T_world_cam.inverse() * est[i + 1].T_world_cam);
    sq += E.translation().squaredNorm();
  }
  EXPECT_NEAR(j["rpe"]["translation_m"]["rmse"].get<double>(), std::sqrt(sq / (gt.size() - 1)),
              1e-12);
  EXPECT_EQ(j["rpe"]["translation_m"]["count"].get<int>(), 149);
}

TEST(CliEvalTraj, DeltaAndScaleOptions) {
  const std::string dir = test::scratch_dir("delta");
  write_pair(dir + "/gt.txt", dir + "/est.txt", 60);
  auto r = run_cli("eval traj " + dir + "/gt.txt " + dir + "/est.txt --delta 5 --json " + dir +
                   "/d.json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(read_json(dir + "/d.json")["rpe"]["translation_m"]["count"].get<int>(), 55);
  r = run_cli("eval traj " + dir + "/gt.txt " + dir + "/est.txt --scale --json " + dir + "/s.json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto s = read_json(dir + "/s.json");
  EXPECT_EQ(s["ate"]["alignment"], "sim3");
  EXPECT_NE(s["ate"]["scale"].get<double>(), 1.0);
  // A similarity fits at least as well as a rigid motion.
  EXPECT_LE(s["ate"]["translation_m"]["rmse"].get<double>(),
            read_json(dir + "/d.json")["ate"]["translation_m"]["rmse"].get<double>() + 1e-12);
  r = run_cli("eval traj " + dir + "/gt.txt " + dir + "/est.txt --delta 0");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("rpe_delta_frames"), std::string::npos) << r.output;
}

TEST(CliEvalTraj, BadInputNamesTheFile) {
  const std::string dir = test::scratch_dir("bad");
  write_pair(dir + "/gt.txt", dir + "/est.txt", 10);
  auto r = run_cli("eval traj " + dir + "/missing.txt " + dir + "/est.txt");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("missing.txt"), std::string::npos) << r.output;

  std::ofstream(dir + "/broken.txt") << "0 1 2 3 0 0 0 1\n1 2 3\n";
  r = run_cli("eval traj " + dir + "/gt.txt " + dir + "/broken.txt --json " + dir + "/never.json");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("broken.txt"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("line 2"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir + "/never.json"));

  std::ofstream(dir + "/late.txt") << "5000 0 0 0 0 0 0 1\n";  // no timestamp near the ground truth
  r = run_cli("eval traj " + dir + "/gt.txt " + dir + "/late.txt");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("late.txt"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("no timestamp within"), std::string::npos) << r.output;

  std::ofstream(dir + "/empty.txt") << "# nothing\n";
  r = run_cli("eval traj " + dir + "/empty.txt " + dir + "/est.txt");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("empty.txt"), std::string::npos) << r.output;

  // Issue 12: one pose gave "ATE 0"; equal timestamps were accepted; trailing junk was ignored.
  std::ofstream(dir + "/one.txt") << "100 0 0 0 0 0 0 1\n";
  r = run_cli("eval traj " + dir + "/gt.txt " + dir + "/one.txt");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("only 1 pose"), std::string::npos) << r.output;
  std::ofstream(dir + "/dup.txt") << "0 0 0 0 0 0 0 1\n1 0 0 0 0 0 0 1\n1 0 0 0 0 0 0 1\n";
  r = run_cli("eval traj " + dir + "/gt.txt " + dir + "/dup.txt");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("line 3"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("timestamps must increase"), std::string::npos) << r.output;
  std::ofstream(dir + "/junk.txt") << "0 0 0 0 0 0 0 1 7\n";
  r = run_cli("eval traj " + dir + "/gt.txt " + dir + "/junk.txt");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("after the 8 numbers"), std::string::npos) << r.output;
}

TEST(CliEvalPoses, MissingResultFileIsNamed) {
  const std::string dir = test::scratch_dir("poses");
  const auto r = run_cli("eval poses --dataset " + dir + " --result " + dir + "/none.csv");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("none.csv"), std::string::npos) << r.output;
  std::ofstream(dir + "/bad.csv") << "scene_id,im_id,obj_id,score,R,t,time\n1,2,3\n";
  const auto r2 = run_cli("eval poses --dataset " + dir + " --result " + dir + "/bad.csv");
  EXPECT_NE(r2.exit_code, 0);
  EXPECT_NE(r2.output.find("bad.csv"), std::string::npos) << r2.output;
}

TEST(CliEvalMap, ScoresAMapAgainstAMeshAndNamesBadInput) {
  // A wall (the plane x = 0.05 of a 0.1 m thick box) and a map of surfels on it plus one 3 cm off.
  const std::string dir = test::scratch_dir("eval_map");
  PlyWriteOptions mesh_options;
  mesh_options.units_per_metre = 1.0;
  write_ply(dir + "/scene.ply", make_box(Eigen::Vector3f(0.1f, 2.0f, 2.0f), 0.5f), mesh_options);
  PointCloudData map;
  for (int i = 0; i < 3; ++i) map.positions_m.emplace_back(0.05f, 0.1f * i, 0.0f);
  map.positions_m.emplace_back(0.08f, 0.0f, 0.0f);
  map.confidences = {20.0f, 20.0f, 20.0f, 1.0f};
  write_point_cloud_ply(dir + "/map.ply", map);
  const auto ok =
      run_cli("eval map " + dir + "/map.ply " + dir + "/scene.ply --json " + dir + "/map.json");
  ASSERT_EQ(ok.exit_code, 0) << ok.output;
  const auto j = nlohmann::json::parse(std::ifstream(dir + "/map.json"));
  EXPECT_EQ(j["surfels"].get<int>(), 4);
  EXPECT_NEAR(j["far_fraction"].get<double>(), 0.25, 1e-9);
  const auto stable = run_cli("eval map " + dir + "/map.ply " + dir +
                              "/scene.ply --min-confidence 10 --json " + dir + "/stable.json");
  ASSERT_EQ(stable.exit_code, 0) << stable.output;
  EXPECT_EQ(
      nlohmann::json::parse(std::ifstream(dir + "/stable.json"))["far_fraction"].get<double>(),
      0.0);
  // A missing file, and a threshold no surfel reaches: errors naming the file.
  const auto missing = run_cli("eval map " + dir + "/none.ply " + dir + "/scene.ply");
  EXPECT_NE(missing.exit_code, 0);
  EXPECT_NE(missing.output.find("none.ply: map does not exist"), std::string::npos)
      << missing.output;
  const auto empty =
      run_cli("eval map " + dir + "/map.ply " + dir + "/scene.ply --min-confidence 50");
  EXPECT_NE(empty.exit_code, 0);
  EXPECT_NE(empty.output.find("map.ply"), std::string::npos) << empty.output;
  EXPECT_NE(empty.output.find("confidence >= 50"), std::string::npos) << empty.output;
}

TEST(CliEvalPoses, RealYcbVideoScene) {
  ORPE_REQUIRE_DATA(data, "ycbv/data/0000");
  const std::string dir = test::scratch_dir("ycb");
  DatasetParams params;
  params.scene = "0000";
  const auto reader = open_dataset(data + "/ycbv", params);
  const DatasetInfo& info = reader->info();
  // Estimates 1 cm off along the camera x axis, the 5th frame missed, plus a low-score decoy row.
  std::vector<PoseResultRow> rows;
  std::vector<PoseGroundTruthInstance> gt;
  int missed_frame = -1;
  for (size_t i = 0; i < reader->size(); ++i) {
    const RgbdFrame f = reader->read(i);
    if (i == 4) missed_frame = f.index;
    for (const auto& o : f.objects_gt) {
      gt.push_back({info.scene_id, f.index, o.class_id, o.T_cam_obj});
      if (i == 4) continue;
      PoseResultRow r;
      r.scene_id = info.scene_id;
      r.im_id = f.index;
      r.obj_id = o.class_id;
      r.score = 0.9;
      r.T_cam_obj = SE3(o.T_cam_obj.rotation(), o.T_cam_obj.translation() + Vec3(0.01, 0, 0));
      rows.push_back(r);
      r.score = 0.1;
      r.T_cam_obj = SE3(Mat3::Identity(), Vec3(0, 0, 2));
      rows.push_back(r);
    }
  }
  ASSERT_GT(gt.size(), 10u);
  write_bop_results(dir + "/r.csv", rows);
  // Expected distances from the rows as written (mm text), brute-force ADD-S.
  const auto written = read_bop_results(dir + "/r.csv");
  std::vector<double> expected_add_s;
  for (const auto& g : gt) {
    if (g.im_id == missed_frame) {
      expected_add_s.push_back(std::numeric_limits<double>::infinity());
      continue;
    }
    const auto it = std::find_if(written.begin(), written.end(), [&](const PoseResultRow& r) {
      return r.im_id == g.im_id && r.obj_id == g.class_id && r.score > 0.5;
    });
    ASSERT_NE(it, written.end());
    const auto pts = read_xyz_points(info.model_points_paths.at(g.class_id));
    const bool symmetric =
        std::count(info.symmetric_classes.begin(), info.symmetric_classes.end(), g.class_id) > 0;
    expected_add_s.push_back(symmetric ? adds_distance_brute_force(pts, g.T_cam_obj, it->T_cam_obj)
                                       : add_distance(pts, g.T_cam_obj, it->T_cam_obj));
    if (!symmetric) {
      EXPECT_NEAR(expected_add_s.back(), 0.01, 1e-6);
    }
  }
  auto r = run_cli("eval poses --dataset " + data + "/ycbv --scene 0000 --result " + dir +
                   "/r.csv --json " + dir + "/p.json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  auto j = read_json(dir + "/p.json");
  EXPECT_EQ(j["all"]["instances"].get<size_t>(), gt.size());
  EXPECT_EQ(j["all"]["estimated"].get<size_t>(), gt.size() - gt.size() / reader->size());
  EXPECT_NEAR(j["all"]["add_s_auc"].get<double>(), ycb_auc_percent(expected_add_s), 1e-6);
  EXPECT_NE(r.output.find("ALL"), std::string::npos);
  EXPECT_NE(r.output.find(info.class_names.at(gt.front().class_id)), std::string::npos) << r.output;

  // Only two keyframes, one of them the missed frame.
  std::ofstream(dir + "/kf.txt") << fmt::format("{:04d}/{:06d}\n{:04d}/{:06d}\n", info.scene_id,
                                                missed_frame, info.scene_id, missed_frame + 1);
  r = run_cli("eval poses --dataset " + data + "/ycbv --keyframes " + dir + "/kf.txt --result " +
              dir + "/r.csv --markdown --json " + dir + "/k.json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  j = read_json(dir + "/k.json");
  const size_t per_frame = gt.size() / reader->size();
  EXPECT_EQ(j["all"]["instances"].get<size_t>(), 2 * per_frame);
  EXPECT_EQ(j["all"]["estimated"].get<size_t>(), per_frame);
  EXPECT_NE(r.output.find("| **ALL** |"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace orpe
