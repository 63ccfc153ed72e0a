// Multi-view fusion gains over single view: `orpe run --mode full` on a tiny synthetic
// table scene (sensor noise, degraded gt detections, a 60-degree camera arc, boxes and cans),
// single view (DF-PM-PD-PC) and Object-RPE (the same single-view estimates fused by the EKF)
// from one pass, both scored by `orpe eval poses` over the same evaluated frames.
// The long measurement (several seeds, larger scenes) is scripts/synth_fusion.py (docs/RESULTS.md).
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>

#include "pipeline/pipeline_test_util.h"

namespace orpe {
namespace {

nlohmann::json read_json_file(const std::string& path) {
  std::ifstream is(path);
  EXPECT_TRUE(is.good()) << path;
  return nlohmann::json::parse(is);
}

int run_orpe(const std::string& args) {
  const std::string cmd = std::string("OMP_WAIT_POLICY=passive ") + ORPE_CLI_PATH + " -q " + args;
  return std::system(cmd.c_str());
}

TEST(FusionGain, FusedPosesAreNotWorseThanSingleViewOnATinyScene) {
  // Table scene (boxes and cans; the floor scene's pallets defeat the single view in every frame).
  // Checked with seeds 11-14 (before issue #13): fused - single view = +1.3, -0.5, +0.5, +6.9 ADD-S
  // AUC; the seed is fixed, so the figure below is deterministic.
  SynthParams p = test::small_scene_params(320, 240, 20, 4, 11);
  p.scene = "table";
  p.span_deg = 60;  // 3 degrees per frame: the views differ, tracking stays easy
  const std::string scene = test::synthetic_scene("fusion_gain", p);
  const std::string out = test::scratch_dir("fusion_gain");
  ASSERT_EQ(run_orpe("run --dataset " + scene + " --out " + out +
                     " --mode full --ablation DF-PM-PD-PC --ablation Object-RPE"
                     " --set pose_registration.num_rotations=120"),
            0);
  auto score = [&](const std::string& config) {
    const std::string json = out + "/eval_" + config + ".json";
    EXPECT_EQ(run_orpe("eval poses --dataset " + scene + " --result " + out + "/ablation/" +
                       config + "/poses.csv --keyframes " + out +
                       "/evaluated_frames.txt --set eval_pose.min_visible_fraction=0.1 --json " +
                       json + " > /dev/null"),
              0);
    return read_json_file(json)["all"];
  };
  const auto single = score("DF-PM-PD-PC");
  const auto fused = score("Object-RPE");
  test::print_figure("single_adds_auc", single["adds_auc"].get<double>());
  test::print_figure("fused_adds_auc", fused["adds_auc"].get<double>());
  test::print_figure("single_add_auc", single["add_auc"].get<double>());
  test::print_figure("fused_add_auc", fused["add_auc"].get<double>());
  test::print_figure("single_estimated", single["estimated"].get<double>());
  test::print_figure("fused_estimated", fused["estimated"].get<double>());
  test::print_figure("instances", single["instances"].get<double>());
  ASSERT_GT(single["instances"].get<int>(), 20);
  EXPECT_EQ(single["instances"].get<int>(), fused["instances"].get<int>());  // the same frames
  // The fused rows cover at least the objects the single view estimates.
  EXPECT_GE(fused["estimated"].get<int>(), single["estimated"].get<int>());
  // Measured on main (cbb4642, after the colour ranking and segment guards): 75 instances (synth's
  // visib_fract counts the image border since session 4; 78 before); ADD-S AUC single view 96.18,
  // fused 96.34 -- the single view is near the ceiling of ADD-S here, so the fusion gain shows in
  // the rotation: plain ADD AUC single view 90.81, fused 95.97 (+5.16). Seeds 12-14 (scripts: the
  // same scene with --seed N): ADD gains +7.9, +4.9, +1.9; ADD-S gains +0.6, -0.8, +5.7. Bounds:
  // single view ADD-S -3 points; fused ADD-S not more than 0.5 below the single view; the fusion
  // gains at least half the measured ADD gain (an EKF that passes measurements through, or fuses
  // nothing, fails).
  EXPECT_EQ(single["instances"].get<int>(), 75);
  EXPECT_GT(single["adds_auc"].get<double>(), 93.0);
  EXPECT_GT(fused["adds_auc"].get<double>(), single["adds_auc"].get<double>() - 0.5);
  // Session 6 (posefast2, the colour turn search about a can's axis, pose_registration.
  // colour_refine_turn): the single view now gets the cans' turn from their labels, single-view ADD
  // AUC 90.81 -> 93.85, fused 95.97 -> 95.60 (ADD-S unchanged; colour_refine_turn=false gives the
  // figures above exactly): the fusion gains +1.75 ADD, so the bound is half of that.
  // Session 19 (colour_evidence=lambert the default): single-view ADD 96.08 (ncc) -> 94.49, fused
  // 97.68 both: the fusion gains +3.2; with the prior fast path on by default, fused 97.56.
  EXPECT_GT(fused["add_auc"].get<double>(), single["add_auc"].get<double>() + 0.85)
      << "single view " << single["add_auc"] << ", fused " << fused["add_auc"];
}

}  // namespace
}  // namespace orpe
