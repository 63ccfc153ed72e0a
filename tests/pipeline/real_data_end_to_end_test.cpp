// End to end on the shared real data (../shared/data, docs/DATASETS.md), through the `orpe` CLI:
//  - SLAM on the first 150 frames of the 7-Scenes sequence, ATE against its ground truth;
//  - `orpe run --mode full` on a YCB-Video clip with tracked cameras (started at the first frame's
//    ground-truth pose) and degraded gt detections (the default), scored with `orpe eval poses` and
//    `orpe eval recon`.
// Bounds sit near the figures measured on main (written beside each bound with the margin), so that
// a regression of the pipeline on real data fails the suite. Re-measure after a change that moves
// them on purpose: the test prints every figure it checks (ORPE_PRINT_FIGURES=1 prints them also
// when it passes). Without the data the tests skip; with ORPE_REQUIRE_DATA=1 (CI) they fail.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <string>

#include "support/cli_run.h"
#include "support/test_data.h"

namespace orpe {
namespace {

using test::read_json;
using test::run_cli;

TEST(RealDataEndToEnd, SlamTracksTheFirst150SevenScenesFrames) {
  ORPE_REQUIRE_DATA(data, "7scenes-seq/rgb.txt");
  const std::string out = test::scratch_dir("slam") + "/run";
  ASSERT_EQ(run_cli("run --mode slam --dataset " + data + "/7scenes-seq --out " + out +
                    " --set dataset.last_frame=149 > " + out + ".log 2>&1"),
            0)
      << "see " << out << ".log";
  const auto summary = read_json(out + "/summary.json");
  EXPECT_EQ(summary["counts"]["frames"].get<int>(), 150);
  const int lost = summary["counts"]["tracking_lost"].get<int>();
  const int degraded = summary["counts"]["tracking_degraded"].get<int>();
  ASSERT_TRUE(summary.contains("trajectory_eval")) << "7-Scenes has camera ground truth";
  const auto& ev = summary["trajectory_eval"];
  EXPECT_EQ(ev["pairs"].get<int>(), 150);
  const double ate = ev["ate"]["translation_m"]["rmse"].get<double>();
  const double rpe_rot = ev["rpe"]["rotation_deg"]["rmse"].get<double>();
  test::print_figure("ate_rmse_m", ate);
  test::print_figure("rpe_rotation_rmse_deg", rpe_rot);
  test::print_figure("lost", lost);
  test::print_figure("degraded", degraded);
  // Measured on main (8c81327): ATE RMSE 0.0169 m over the 150 frames; bound 1.5x.
  EXPECT_LT(ate, 0.025) << "ATE RMSE over the first 150 frames";
  // Measured: 0 frames lost, 0 degraded on 8c81327; with the tracker's depth self-check (below 0.9
  // of the overlap agreeing with the map = DEGRADED, docs/SLAM.md) 2 degraded, 0 lost. Bound: 4.
  EXPECT_EQ(lost, 0);
  EXPECT_LE(degraded, 4);
  // Measured: RPE (1 frame) rotation RMSE 0.206 deg; bound 1.5x.
  EXPECT_LT(rpe_rot, 0.31);
}

struct YcbvRun {
  std::string dir;
  nlohmann::json summary, eval, recon, objects, instances;
};

/// `orpe run --mode full` on YCB-Video clip `clip` (tracked cameras, degraded gt detections), then
/// `orpe eval poses` and `orpe eval recon`.
YcbvRun run_ycbv(const std::string& data, const std::string& clip, const std::string& extra) {
  YcbvRun r;
  const std::string dataset = data + "/ycbv/data/" + clip;
  r.dir = test::scratch_dir("ycbv" + clip) + "/run";
  const std::string log = r.dir + ".log";
  EXPECT_EQ(run_cli("run --mode full --dataset " + dataset + " --out " + r.dir + " " + extra +
                    " > " + log + " 2>&1"),
            0)
      << "see " << log;
  EXPECT_EQ(
      run_cli("eval poses --dataset " + dataset + " --result " + r.dir + "/poses.csv --keyframes " +
              r.dir + "/evaluated_frames.txt --json " + r.dir + "/eval.json >> " + log + " 2>&1"),
      0);
  EXPECT_EQ(run_cli("eval recon --dataset " + dataset + " --run " + r.dir + " --json " + r.dir +
                    "/recon.json >> " + log + " 2>&1"),
            0);
  r.summary = read_json(r.dir + "/summary.json");
  r.eval = read_json(r.dir + "/eval.json");
  r.recon = read_json(r.dir + "/recon.json");
  r.objects = read_json(r.dir + "/objects.json");
  return r;
}

TEST(RealDataEndToEnd, FullModeOnYcbvClip0000WithTrackedCamerasAndDegradedDetections) {
  ORPE_REQUIRE_DATA(data, "ycbv/data/0000/000001-meta.mat");
  const YcbvRun r = run_ycbv(data, "0000", "");
  ASSERT_FALSE(r.summary.empty());
  ASSERT_TRUE(r.summary.contains("counts"));
  EXPECT_EQ(r.summary["counts"]["frames"].get<int>(), 20);
  EXPECT_EQ(r.summary["counts"]["tracking_lost"].get<int>(), 0);
  EXPECT_EQ(r.summary["single_view_estimator"].get<std::string>(), "model_registration");

  // Camera: measured ATE RMSE 0.0011 m against meta.mat's poses; bound 2x + 0.3 mm.
  const double ate = r.summary["trajectory_eval"]["ate"]["translation_m"]["rmse"].get<double>();
  test::print_figure("ycbv0000_ate_rmse_m", ate);
  EXPECT_LT(ate, 0.0025);

  // Instances: the clip shows gelatin_box (9), mug (14), foam_brick (21); measured: exactly these
  // three, one object each (the degraded detector's spurious blobs and wrong classes do not survive
  // as confirmed objects).
  std::multiset<std::string> classes;
  int valid = 0, rejected = 0, rejected_symmetric = 0;
  for (const auto& o : r.objects["objects"]) {
    classes.insert(o["class_name"].get<std::string>());
    valid += o["valid"].get<bool>();
    rejected += o["num_rejected"].get<int>();
    if (o["class_name"].get<std::string>() == "061_foam_brick")
      rejected_symmetric += o["num_rejected"].get<int>();
  }
  EXPECT_EQ(r.summary["counts"]["instances"].get<int>(), 3);
  const std::multiset<std::string> expected = {"009_gelatin_box", "025_mug", "061_foam_brick"};
  EXPECT_EQ(classes, expected);
  EXPECT_EQ(valid, 3);
  test::print_figure("ycbv0000_rejected_views", rejected);
  test::print_figure("ycbv0000_rejected_views_foam_brick", rejected_symmetric);
  // Gated measurements (objects.json num_rejected): measured 14 in all (mug 11: its handle hidden,
  // it flips; foam brick 3; gelatin box 0); bound +4. The foam brick is the clip's symmetric class
  // (the EKF fuses its flips as one pose): measured 3, bound +2.
  EXPECT_LE(rejected, 18);
  EXPECT_LE(rejected_symmetric, 5);

  // Poses (per-frame EKF rows, poses.csv): measured ADD-S AUC 96.26 over the 60 instances, 59
  // estimated; bound -2.75 points. ADD(-S) per class: the mug's handle stays hidden in this clip, so
  // which of its two modes (the handle ~90 degrees apart) the views settle on is a coin toss that a
  // float rounding flips (session 22: the pooled ADD(-S) 72.58 with one mode, 64.36 with the other;
  // docs/RESULTS.md): only its ADD-S is bounded (measured 97.15, bound -2.75). The gelatin box and the
  // foam brick (symmetric: ADD-S): measured ADD(-S) 49.03 and 98.44, bound -7.5 points.
  const auto& all = r.eval["all"];
  const double adds = all["adds_auc"].get<double>();
  const double add_s = all["add_s_auc"].get<double>();
  test::print_figure("ycbv0000_adds_auc", adds);
  test::print_figure("ycbv0000_add_s_auc", add_s);
  EXPECT_EQ(all["instances"].get<int>(), 60);
  EXPECT_GE(all["estimated"].get<int>(), 59);
  EXPECT_GT(adds, 93.5);
  std::map<std::string, std::pair<double, double>> per_class;  // name -> (ADD-S, ADD(-S)) AUC
  for (const auto& c : r.eval["classes"])
    per_class[c["name"].get<std::string>()] = {c["adds_auc"].get<double>(),
                                               c["add_s_auc"].get<double>()};
  ASSERT_EQ(per_class.size(), 3u);
  for (const auto& [name, auc] : per_class) {
    test::print_figure("ycbv0000_adds_auc_" + name, auc.first);
    test::print_figure("ycbv0000_add_s_auc_" + name, auc.second);
  }
  EXPECT_GT(per_class["025_mug"].first, 94.4);
  EXPECT_GT(per_class["009_gelatin_box"].second, 41.5);
  EXPECT_GT(per_class["061_foam_brick"].second, 90.9);

  // Map: measured reconstruction error 1.42 mm (mean over the 3 objects of the per-object mean
  // surfel distance to the model at the ground-truth pose: 2.27 / 1.00 / 0.99 mm); bound 1.5x.
  const double recon_mm = r.recon["mean_mm"].get<double>();
  test::print_figure("ycbv0000_recon_mm", recon_mm);
  EXPECT_LT(recon_mm, 2.15);
  EXPECT_EQ(r.recon["objects"].size(), 3u);
}

}  // namespace
}  // namespace orpe
