// Synthetic textured scene end to end (issue #15): `orpe synth --symmetries appearance` (printed
// boxes and labelled cans whose labels differ front and back, so ADD(-S) scores their rotation),
// `orpe run --mode full`, `orpe eval poses`. With the colour ranking ADD(-S) stays close to ADD-S;
// with it switched off the boxes come back turned and ADD(-S) falls far below ADD-S.
// The long measurement (several seeds) is scripts/synth_textured.py (docs/RESULTS.md).
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>

#include "pipeline/pipeline_test_util.h"

namespace orpe {
namespace {

int run_orpe(const std::string& args) {
  const std::string cmd = std::string("OMP_WAIT_POLICY=passive ") + ORPE_CLI_PATH + " -q " + args;
  return std::system(cmd.c_str());
}

nlohmann::json run_and_score(const std::string& scene, const std::string& name,
                             const std::string& sets) {
  const std::string out = test::scratch_dir("synth_textured_" + name);
  EXPECT_EQ(run_orpe("run --dataset " + scene + " --out " + out + " --mode full" + sets), 0);
  const std::string json = out + "/eval.json";
  EXPECT_EQ(
      run_orpe("eval poses --dataset " + scene + " --result " + out + "/poses.csv --keyframes " +
               out + "/evaluated_frames.txt --set eval_pose.min_visible_fraction=0.1 --json " +
               json + " > /dev/null"),
      0);
  std::ifstream is(json);
  return nlohmann::json::parse(is)["all"];
}

TEST(SynthTextured, AddOrAddsCloseToAddsWithColourAndNotWithout) {
  // Seed 11: three printed boxes (001_frasvaf_box, 007_risi_frutti_box, 009_tomatpure). Labelled
  // cans are the known weak case (docs/RESULTS.md "Synthetic textured scenes"), not tested here.
  SynthParams p = test::small_scene_params(320, 240, 8, 3, 11);
  p.scene = "table";
  p.span_deg = 30;
  p.symmetries = "appearance";
  const std::string scene = test::synthetic_scene("synth_textured", p);
  const std::string fast = " --set pose_registration.num_rotations=120";
  const auto with = run_and_score(scene, "colour", fast);
  const auto without =
      run_and_score(scene, "no_colour", fast + " --set pose_registration.colour_enabled=false");
  for (const auto* r : {&with, &without}) {
    test::print_figure("adds_auc", (*r)["adds_auc"].get<double>());
    test::print_figure("add_s_auc", (*r)["add_s_auc"].get<double>());
  }
  // Measured (8 frames, 24 instances): with colour ADD-S 97.37, ADD(-S) 97.20 (gap 0.2; with the
  // plain NCC, the default until session 18, 97.40 / 93.21, gap 4.2); colour off ADD-S 96.95 (97.25
  // since), ADD(-S) 65.61 (66.27; gap 31.3). Bounds: gap below 6 with colour, above 15 without,
  // colour gains at least 15 ADD(-S).
  ASSERT_EQ(with["instances"].get<int>(), 24);
  EXPECT_GT(with["adds_auc"].get<double>(), 94.0);
  EXPECT_GT(with["add_s_auc"].get<double>(), with["adds_auc"].get<double>() - 6.0);
  EXPECT_LT(without["add_s_auc"].get<double>(), without["adds_auc"].get<double>() - 15.0);
  EXPECT_GT(with["add_s_auc"].get<double>(), without["add_s_auc"].get<double>() + 15.0);
}

}  // namespace
}  // namespace orpe
