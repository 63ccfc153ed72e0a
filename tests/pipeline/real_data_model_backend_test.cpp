// End to end on real data with the `model` segmentation back-end (issue #11, #13): `orpe run --mode
// full --set segmentation.backend=model` on the first 10 frames of the shared YCB-Video clip 0001
// (keyframes every 2nd frame, all 21 YCB models as candidates, tracked cameras, no ground truth
// read by the back-end), scored with `orpe eval poses` (every annotated instance of every evaluated
// frame; a missed object counts as a miss).
// Bounds sit near the figures measured on the recog branch (written beside each bound with the
// margin), so that a regression of recognition on real data fails the suite. The test prints every
// figure it checks with ORPE_PRINT_FIGURES=1. Without the data it skips; with ORPE_REQUIRE_DATA=1
// (CI) it fails.
#include <gtest/gtest.h>

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

TEST(RealDataModelBackend, RecognisesTheObjectsOfYcbvClip0001FromTheModelsAlone) {
  ORPE_REQUIRE_DATA(data, "ycbv/data/0001/000001-meta.mat");
  const std::string dataset = data + "/ycbv/data/0001";
  const std::string out = test::scratch_dir("model0001") + "/run";
  const std::string log = out + ".log";
  ASSERT_EQ(run_cli("run --mode full --dataset " + dataset + " --out " + out +
                    " --set segmentation.backend=model --set segmentation.keyframe_every_n_frames=2"
                    " --set dataset.last_frame=9 > " +
                    log + " 2>&1"),
            0)
      << "see " << log;
  ASSERT_EQ(run_cli("eval poses --dataset " + dataset + " --result " + out + "/poses.csv" +
                    " --keyframes " + out + "/evaluated_frames.txt --json " + out +
                    "/eval.json >> " + log + " 2>&1"),
            0)
      << "see " << log;
  const auto summary = read_json(out + "/summary.json");
  const auto objects = read_json(out + "/objects.json");
  const auto eval = read_json(out + "/eval.json");
  ASSERT_TRUE(summary.contains("counts"));
  EXPECT_EQ(summary["counts"]["frames"].get<int>(), 10);
  EXPECT_EQ(summary["counts"]["keyframes"].get<int>(), 5);

  // Instances. The clip shows master_chef_can, cracker_box, sugar_box, mustard_bottle. Measured
  // (session 7): all four, one instance each with the right class (the cracker box, its lower
  // part hidden by the can, is searched since the size test compares diameters); one spurious
  // instance (a tuna-can-sized piece of the table edge at the image border). Bounds: each of the
  // four exactly once, at most one instance besides them (measured 1).
  std::multiset<std::string> classes;
  for (const auto& o : objects["objects"]) classes.insert(o["class_name"].get<std::string>());
  for (const std::string c :
       {"002_master_chef_can", "003_cracker_box", "004_sugar_box", "006_mustard_bottle"})
    EXPECT_EQ(classes.count(c), 1u) << c;
  const int others = static_cast<int>(classes.size()) - 4;
  test::print_figure("model0001_instances", static_cast<double>(classes.size()));
  EXPECT_LE(others, 1) << "instances besides the four recognised objects";

  // Poses (per-frame EKF rows): measured ADD-S AUC 97.08 (ADD(-S) 56.06) over the 20 annotated
  // instances, all 20 estimated (session 6: 72.75, 15 estimated, the cracker box missed); bounds
  // -3 points, 20 estimated.
  const auto& all = eval["all"];
  const double adds = all["adds_auc"].get<double>();
  test::print_figure("model0001_adds_auc", adds);
  test::print_figure("model0001_add_s_auc", all["add_s_auc"].get<double>());
  test::print_figure("model0001_estimated", all["estimated"].get<int>());
  EXPECT_EQ(all["instances"].get<int>(), 20);
  EXPECT_GE(all["estimated"].get<int>(), 20);
  EXPECT_GT(adds, 94.0);
}

}  // namespace
}  // namespace orpe
