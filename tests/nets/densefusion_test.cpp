// DenseFusion in LibTorch against the reference implementation (lib/network.py of j96w/DenseFusion
// run under Debian's python3-torch by scripts/nets/densefusion_fixtures.py, seeded weights drawn
// from the same LibTorch generator on both sides): the parameter names and shapes, the per-point
// outputs of PoseNet, the best-confidence pose and the pose after 2 refiner iterations.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "nets/net_fixtures.h"
#include "orpe/nets/densefusion.h"
#include "support/test_data.h"

namespace orpe {
namespace {

using nets::HostTensor;

void expect_reference_outputs(const nets::DenseFusionNetwork& net,
                              const std::map<std::string, HostTensor>& f) {
  const std::vector<float>& meta = f.at("meta").values;
  const int h = int(meta[2]), w = int(meta[3]), obj = int(meta[4]);
  std::vector<std::int64_t> choose;
  for (float c : f.at("choose").values) choose.push_back(std::int64_t(c));
  const auto pts = net.estimate(f.at("img").values, h, w, f.at("cloud").values, choose, obj);
  double worst = 0;
  for (const char* key : {"rotation", "translation", "confidence", "embedding"}) {
    const std::vector<float>& ref = f.at(key).values;
    const std::vector<float>& got = std::string(key) == "rotation"      ? pts.rotation
                                    : std::string(key) == "translation" ? pts.translation
                                    : std::string(key) == "confidence"  ? pts.confidence
                                                                        : pts.embedding;
    ASSERT_EQ(got.size(), ref.size()) << key;
    const double e = test::max_relative_error(got, ref, ref.size());
    EXPECT_LE(e, 1e-4) << key;
    worst = std::max(worst, e);
  }
  nets::DenseFusionPose before;
  const nets::DenseFusionPose final_pose = net.pose(pts, f.at("cloud").values, obj, 2, &before);
  std::vector<double> b(before.quaternion.begin(), before.quaternion.end());
  b.insert(b.end(), before.translation.begin(), before.translation.end());
  const double e_before = test::max_relative_error(b, f.at("before_refinement").values, 7);
  EXPECT_LE(e_before, 1e-4);
  const auto& q = final_pose.quaternion;
  const Eigen::Matrix3d R =
      Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized().toRotationMatrix();
  std::vector<double> got_R(R.data(), R.data() + 9);  // column-major
  std::vector<float> ref_R(9);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) ref_R[c * 3 + r] = f.at("final_R").values[r * 3 + c];
  const double e_R = test::max_relative_error(got_R, ref_R, 9);
  const double e_t = test::max_relative_error(final_pose.translation, f.at("final_t").values, 3);
  EXPECT_LE(e_R, 1e-4);
  EXPECT_LE(e_t, 1e-4);
  std::printf(
      "densefusion equivalence: per-point max error %.2g, pose before refinement %.2g, after 2 "
      "refinements R %.2g t %.2g\n",
      worst, e_before, e_R, e_t);
}

TEST(densefusion, MatchesTheReferenceImplementationWithSeededWeights) {
  ORPE_REQUIRE_TORCH();
  const auto f = nets::read_tensor_file(test::nets_data("densefusion_small.pt"));
  const std::vector<float>& meta = f.at("meta").values;
  const int n = int(meta[0]);
  nets::DenseFusionSpec spec;
  spec.num_points = n;
  spec.num_objects = int(meta[1]);
  spec.random_seed = int(meta[5]);
  const nets::DenseFusionNetwork net(spec);

  // Names and shapes, in the reference's state_dict order.
  std::ifstream names(test::nets_data("densefusion_small.names.txt"));
  const auto params = net.parameters();
  std::string line;
  size_t i = 0;
  for (; std::getline(names, line); ++i) {
    ASSERT_LT(i, params.size());
    std::ostringstream mine;
    mine << params[i].first;
    for (auto d : params[i].second) mine << " " << d;
    EXPECT_EQ(mine.str(), line) << "tensor " << i;
  }
  EXPECT_EQ(i, params.size());
  EXPECT_EQ(i, 101u);  // PoseNet 77 + PoseRefineNet 24

  expect_reference_outputs(net, f);
}

/// Converted official-format checkpoints (scripts/nets/densefusion_fixtures.py seeded-checkpoints,
/// then convert) holding the fixture's weights load by name and give the reference's outputs.
/// Needs /usr/bin/python3 with Debian's torch at test time (skips without it; never at run time).
TEST(densefusion, LoadsConvertedCheckpoints) {
  ORPE_REQUIRE_TORCH();
  if (std::system("/usr/bin/python3 -c 'import torch' 2> /dev/null") != 0)
    GTEST_SKIP() << "no /usr/bin/python3 with torch (python3-torch)";
  const auto f = nets::read_tensor_file(test::nets_data("densefusion_small.pt"));
  const std::string dir = test::scratch_dir("densefusion_convert");
  const std::string script = std::string(ORPE_SOURCE_DIR) + "/scripts/nets/densefusion_fixtures.py";
  const std::string py = "/usr/bin/python3 " + script + " ";
  ASSERT_EQ(
      std::system(
          (py + "seeded-checkpoints --names " + test::nets_data("densefusion_small.names.txt") +
           " --seed " + std::to_string(int(f.at("meta").values[5])) + " --posenet " + dir +
           "/pose_model.pth --refiner " + dir + "/pose_refine_model.pth && " + py + "convert " +
           dir + "/pose_model.pth --out " + dir + "/posenet.pt > /dev/null && " + py + "convert " +
           dir + "/pose_refine_model.pth --out " + dir + "/refiner.pt > /dev/null")
              .c_str()),
      0);
  nets::DenseFusionSpec spec;
  spec.num_points = int(f.at("meta").values[0]);
  spec.num_objects = int(f.at("meta").values[1]);
  spec.posenet_path = dir + "/posenet.pt";
  spec.refiner_path = dir + "/refiner.pt";
  expect_reference_outputs(nets::DenseFusionNetwork(spec), f);

  spec.posenet_path = dir + "/refiner.pt";  // the wrong network's file
  try {
    nets::DenseFusionNetwork wrong(spec);
    ADD_FAILURE() << "no error";
  } catch (const std::exception& e) {
    EXPECT_NE(
        std::string(e.what()).find("refiner.pt: no tensor cnn.model.module.feats.conv1.weight"),
        std::string::npos)
        << e.what();
  }
}

TEST(densefusion, RefusesInputsOfTheWrongSize) {
  ORPE_REQUIRE_TORCH();
  nets::DenseFusionSpec spec;
  spec.num_points = 10;
  spec.num_objects = 2;
  spec.random_seed = 1;
  const nets::DenseFusionNetwork net(spec);
  const std::vector<float> crop(3 * 16 * 16), cloud(30);
  const std::vector<std::int64_t> choose(10, 0);
  EXPECT_THROW(net.estimate(crop, 16, 12, cloud, choose, 0), std::invalid_argument);  // 12 % 8
  EXPECT_THROW(net.estimate(crop, 16, 16, cloud, choose, 2), std::invalid_argument);  // obj
  EXPECT_THROW(net.estimate(crop, 16, 16, std::vector<float>(27), choose, 0),
               std::invalid_argument);
  EXPECT_NO_THROW(net.estimate(crop, 16, 16, cloud, choose, 1));
}

}  // namespace
}  // namespace orpe
