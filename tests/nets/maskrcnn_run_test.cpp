// `orpe run --mode full --set segmentation.backend=maskrcnn` on a small synthetic scene: the
// network runs inside the pipeline (the fixtures' tiny untrained model: the plumbing, not accuracy;
// docs/NETWORKS.md), its detections reach the semantic map, and a bad model file stops the run
// with a message naming it.
#include <gtest/gtest.h>

#include <fstream>

#include "nets/net_fixtures.h"
#include "orpe/io/dataset.h"
#include "pipeline/pipeline_test_util.h"
#include "support/cli_run.h"

namespace orpe {
namespace {

TEST(maskrcnn, RunsInsideOrpeRunFullMode) {
  ORPE_REQUIRE_TORCH();
  const std::string scene =
      test::synthetic_scene("maskrcnn", test::small_scene_params(160, 120, 4, 3, 2));
  const auto reader = open_dataset(scene, DatasetParams{});
  const std::string dir = test::scratch_dir("maskrcnn_run");
  const std::string map = dir + "/classes.txt";
  {
    std::ofstream os(map);
    int label = 1;
    for (const auto& [id, name] : reader->info().class_names) {
      if (label > 3) break;
      os << label++ << " " << name << "\n";
    }
  }
  const std::string common = " --dataset " + scene + " --mode full" +
                             " --set segmentation.backend=maskrcnn --set "
                             "segmentation.maskrcnn_class_map=" +
                             map + " --set segmentation.min_score=0.2";
  const std::string out = dir + "/run";
  ASSERT_EQ(test::run_cli("run" + common + " --out " + out + " --set segmentation.maskrcnn_model=" +
                          test::nets_data("maskrcnn_tiny.pt")),
            0);
  const auto summary = test::read_json(out + "/summary.json");
  EXPECT_EQ(summary["config"]["segmentation"]["backend"].get<std::string>(), "maskrcnn");
  EXPECT_EQ(summary["counts"]["frames"].get<int>(), 4);
  EXPECT_GT(summary["counts"]["detections"].get<int>(), 0);

  const std::string log = dir + "/bad.log";
  EXPECT_NE(test::run_cli("run" + common + " --out " + dir + "/bad" +
                          " --set segmentation.maskrcnn_model=" + dir + "/missing.pt 2> " + log),
            0);
  std::ifstream is(log);
  const std::string text((std::istreambuf_iterator<char>(is)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("missing.pt: cannot open the model file"), std::string::npos) << text;

  // The LibTorch plugin is opened on first use: an unloadable one is a message, not a crash.
  setenv("ORPE_NETS_PLUGIN", "/nonexistent/liborpe_nets_torch.so", 1);
  const int status = test::run_cli(
      "run" + common + " --out " + dir + "/noplugin" +
      " --set segmentation.maskrcnn_model=" + test::nets_data("maskrcnn_tiny.pt") + " 2> " + log);
  unsetenv("ORPE_NETS_PLUGIN");
  EXPECT_NE(status, 0);
  std::ifstream is2(log);
  const std::string text2((std::istreambuf_iterator<char>(is2)), std::istreambuf_iterator<char>());
  EXPECT_NE(text2.find("cannot load the LibTorch plugin liborpe_nets_torch.so"), std::string::npos)
      << text2;
  EXPECT_NE(text2.find("/nonexistent/liborpe_nets_torch.so: no such file"), std::string::npos);
}

}  // namespace
}  // namespace orpe
