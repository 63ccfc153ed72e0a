// End to end: `orpe run --mode full` on a small synthetic scene (orpe synth's generator, sensor noise,
// degraded gt detections), then the outputs are checked against the scene's ground truth: the fused
// world pose of every well-visible object, the per-frame rows through `orpe eval poses`, the map
// through the reconstruction error, and the file formats.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>

#include "orpe/eval/pose_metrics.h"
#include "orpe/io/bop_results.h"
#include "orpe/io/dataset.h"
#include "orpe/io/model_io.h"
#include "orpe/io/trajectory_io.h"
#include "orpe/pipeline/reconstruction_error.h"
#include "orpe/pipeline/run.h"
#include "orpe/pose/object_model.h"
#include "pipeline/pipeline_test_util.h"

namespace orpe {
namespace {

nlohmann::json read_json(const std::string& path) {
  std::ifstream is(path);
  EXPECT_TRUE(is.good()) << path;
  return nlohmann::json::parse(is);
}

int run_cli(const std::string& args) {
  const std::string cmd = std::string("OMP_WAIT_POLICY=passive ") + ORPE_CLI_PATH + " -q " + args;
  return std::system(cmd.c_str());
}

SynthParams e2e_scene() {
  SynthParams p = test::small_scene_params(320, 240, 8, 3, 4);
  p.span_deg = 24;  // 3 degrees per frame
  return p;
}

TEST(EndToEnd, FullModeRecoversObjectPosesOnASyntheticScene) {
  const std::string scene = test::synthetic_scene("e2e", e2e_scene());
  const std::string out = test::scratch_dir("run");
  ASSERT_EQ(run_cli("run --dataset " + scene + " --out " + out +
                    " --mode full --set pose_registration.num_rotations=120"),
            0);
  for (const char* f : {"trajectory.txt", "map.ply", "semantic_map.ply", "semantic_map_instances.ply",
                        "instances.json", "poses.csv", "poses_final.csv", "objects.json",
                        "summary.json", "evaluated_frames.txt"})
    EXPECT_TRUE(std::filesystem::is_regular_file(out + "/" + f)) << f;

  const auto summary = read_json(out + "/summary.json");
  EXPECT_EQ(summary["counts"]["frames"].get<int>(), 8);
  EXPECT_EQ(summary["counts"]["evaluated_frames"].get<int>(), 8);
  EXPECT_EQ(summary["single_view_estimator"].get<std::string>(), "model_registration");
  EXPECT_EQ(summary["single_view_min_mask_px"].get<int>(), 50);  // auto at 320 x 240
  EXPECT_EQ(summary["config"]["pose_registration"]["num_rotations"].get<int>(), 120);
  EXPECT_GT(summary["timing_ms"]["total"]["single_view"].get<double>(), 0);
  EXPECT_EQ(read_tum_trajectory(out + "/trajectory.txt").size(), 8u);

  // Final world poses against the ground truth (init_from_ground_truth: the map is in the scene's
  // world frame).
  const auto reader = open_dataset(scene, DatasetParams{});
  const DatasetInfo& info = reader->info();
  const RgbdFrame first = reader->read(0);
  ASSERT_TRUE(first.T_world_cam_gt.has_value());
  const auto objects = read_json(out + "/objects.json");
  int checked = 0, within_2cm = 0;
  for (const auto& g : first.objects_gt) {
    if (g.visible_fraction < 0.5) continue;  // too little of it in view
    std::vector<Vec3> pts = read_model_points(info.model_points_paths.at(g.class_id), info.model_units_per_m);
    const ModelPoints model(pts);
    const SE3 truth = *first.T_world_cam_gt * g.T_cam_obj;
    double best = 1e9;
    for (const auto& o : objects["objects"]) {
      if (o["class_id"].get<int>() != g.class_id || !o["valid"].get<bool>()) continue;
      Mat4 M;
      for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) M(r, c) = o["T_world_obj"]["matrix"][r][c].get<double>();
      best = std::min(best, adds_distance(model, truth, SE3::from_matrix(M)));
      EXPECT_EQ(o["source"].get<std::string>(), "ekf");
      EXPECT_EQ(o["covariance"].size(), 36u);
    }
    // The usual correctness criterion (ADD-S below a tenth of the object's diameter), and the
    // objects within 2 cm.
    std::vector<Eigen::Vector3f> ptsf;
    for (const auto& p : pts) ptsf.push_back(p.cast<float>());
    const double diameter = model_diameter_m(ptsf);
    EXPECT_LT(best, 0.1 * diameter) << "object of class " << g.class_id << ": fused ADD-S " << best
                                    << " m, diameter " << diameter << " m";
    ++checked;
    within_2cm += best < 0.02;
  }
  test::print_figure("checked", checked);
  test::print_figure("within_2cm", within_2cm);
  // Measured on main (8c81327): 3 objects checked, 2 within 2 cm -- the half pallet (1 m across) is
  // the estimator's hard case and is within a tenth of its diameter only; so one may miss 2 cm.
  EXPECT_EQ(checked, 3);
  EXPECT_GE(within_2cm, checked - 1);

  // Per-frame rows through orpe eval poses, over the evaluated frames.
  const std::string eval_json = out + "/eval.json";
  ASSERT_EQ(run_cli("eval poses --dataset " + scene + " --result " + out + "/poses.csv --keyframes " +
                    out + "/evaluated_frames.txt --json " + eval_json + " > /dev/null"),
            0);
  const auto ev = read_json(eval_json);
  test::print_figure("adds_auc", ev["all"]["adds_auc"].get<double>());
  test::print_figure("estimated", ev["all"]["estimated"].get<double>());
  test::print_figure("instances", ev["all"]["instances"].get<double>());
  // Measured on main (cbb4642): ADD-S AUC 80.07 over 24 instances, all 24 estimated; bound -3
  // points. (85.18 on 8c81327; the session-4 changes cost it 5 points, traced by switching each off:
  // the segment guards 2.1 points -- the half pallet, 1 m across, at ~5 cm ADD-S in every frame, loses
  // edge pixels -- the skip rule, the prior and the colour ranking none; one wrong-class degraded
  // detection in frame 3 scores 0.79 m.)
  EXPECT_GT(ev["all"]["adds_auc"].get<double>(), 77.0);
  EXPECT_EQ(ev["all"]["estimated"].get<int>(), ev["all"]["instances"].get<int>());
  EXPECT_EQ(ev["all"]["instances"].get<int>(), 24);
  const auto rows = read_bop_results(out + "/poses.csv");
  ASSERT_FALSE(rows.empty());
  for (const auto& r : rows) {
    EXPECT_EQ(r.scene_id, info.scene_id);
    EXPECT_GE(r.im_id, 0);
    EXPECT_LT(r.im_id, 8);
    EXPECT_GT(r.time_s, 0);
  }

  // The semantic map's objects lie on their models.
  const ReconstructionEvaluation recon = [&] {
    std::map<int, ModelSurface> surfaces;
    std::map<int, const ModelSurface*> ptrs;
    const auto gt = ground_truth_objects_in_map(*reader, read_tum_trajectory(out + "/trajectory.txt"));
    for (const auto& o : gt)
      if (!surfaces.count(o.class_id)) {
        surfaces.emplace(o.class_id, load_model_surface(info, o.class_id));
        ptrs[o.class_id] = &surfaces.at(o.class_id);
      }
    return evaluate_reconstruction(read_semantic_map_ply(out + "/semantic_map.ply"), gt, ptrs,
                                   info.class_names);
  }();
  test::print_figure("recon_objects", recon.objects.size());
  test::print_figure("recon_mm", recon.mean_m * 1000);
  // Measured: 3 objects, reconstruction error 2.16 mm; bound 1.5x.
  EXPECT_EQ(recon.objects.size(), 3u);
  EXPECT_LT(recon.mean_m, 0.0032);
  ASSERT_EQ(run_cli("eval recon --dataset " + scene + " --run " + out + " --json " + out +
                    "/recon.json > /dev/null"),
            0);
  EXPECT_NEAR(read_json(out + "/recon.json")["mean_mm"].get<double>(), recon.mean_m * 1000, 1e-6);
}

TEST(EndToEnd, SemanticModeAndBadInputs) {
  const std::string scene = test::synthetic_scene("e2e", e2e_scene());
  const std::string out = test::scratch_dir("semantic");
  ASSERT_EQ(run_cli("run --dataset " + scene + " --out " + out +
                    " --mode semantic --set dataset.last_frame=2"),
            0);
  EXPECT_TRUE(std::filesystem::exists(out + "/semantic_map.ply"));
  EXPECT_TRUE(std::filesystem::exists(out + "/instances.json"));
  EXPECT_FALSE(std::filesystem::exists(out + "/poses.csv"));
  EXPECT_EQ(read_json(out + "/summary.json")["mode"].get<std::string>(), "semantic");

  const std::string bad = test::scratch_dir("bad");
  EXPECT_NE(run_cli("run --dataset " + bad + "/missing --out " + bad + "/o 2> /dev/null"), 0);
  EXPECT_NE(run_cli("run --dataset " + scene + " --out " + bad + "/o --mode semantic --ablation DF "
                    "2> /dev/null"),
            0);
  EXPECT_NE(run_cli("run --dataset " + scene + " --out " + bad +
                    "/o --set pipeline.pose_every_n_keyframes=0 2> /dev/null"),
            0);
  EXPECT_FALSE(std::filesystem::exists(bad + "/o/summary.json")) << "no output after a bad start";
}

// The CLI makes OpenMP's idle threads wait passively unless the user chose (apps/orpe/main.cpp,
// docs/PIPELINE.md "Threads"); summary.json records the policy the run had.
TEST(EndToEnd, TheCliWaitsPassivelyUnlessTheUserChoseAWaitPolicy) {
  const std::string scene = test::synthetic_scene("e2e", e2e_scene());
  // (environment, the policy the run had): unset -> passive; the user's policy, or a spin count
  // of the user's (the runtime's own default policy), is kept.
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"-u OMP_WAIT_POLICY -u GOMP_SPINCOUNT", "passive"},
      {"-u GOMP_SPINCOUNT OMP_WAIT_POLICY=active", "active"},
      {"-u OMP_WAIT_POLICY GOMP_SPINCOUNT=300000", "unset"}};
  int k = 0;
  for (const auto& [env, policy] : cases) {
    const std::string out = test::scratch_dir("wait_policy_" + std::to_string(k++));
    const std::string cmd = "env " + env + " " + ORPE_CLI_PATH + " -q run --dataset " + scene +
                            " --out " + out + " --mode slam --set dataset.last_frame=2";
    ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
    EXPECT_EQ(read_json(out + "/summary.json")["provenance"]["omp_wait_policy"].get<std::string>(),
              policy)
        << env;
  }
}

}  // namespace
}  // namespace orpe
