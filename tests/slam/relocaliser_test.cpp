// The relocaliser's pieces (issue 19): the rigid fit it verifies candidates with, and the keyframe
// rule. The end-to-end behaviour (a gap of frames, a wrong place) is in
// tests/pipeline/relocalisation_test.cpp.
#include <gtest/gtest.h>

#include <random>

#include "orpe/slam/relocaliser.h"

namespace orpe::slam {
namespace {

TEST(Relocaliser, FitRigidRecoversAKnownTransform) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 20; ++trial) {
    const SE3 T_a_b(so3_exp(Vec3(u(rng), u(rng), u(rng)) * 1.5), Vec3(u(rng), u(rng), u(rng)));
    std::vector<Vec3> a, b;
    for (int i = 0; i < 3 + trial; ++i) {
      b.emplace_back(u(rng), u(rng), 1 + u(rng));
      a.push_back(T_a_b * b.back());
    }
    const SE3 T = fit_rigid(a, b);
    EXPECT_LT((T.translation() - T_a_b.translation()).norm(), 1e-9);
    EXPECT_LT((T.rotation() - T_a_b.rotation()).norm(), 1e-9);
  }
}

TEST(Relocaliser, ParamsAreChecked) {
  RelocaliserParams p;
  std::string why;
  EXPECT_TRUE(p.IsValid(&why)) << why;
  p.min_inliers = 2;
  EXPECT_FALSE(p.IsValid(&why));
  EXPECT_NE(why.find("min_inliers"), std::string::npos);
  p = RelocaliserParams();
  p.match_ratio = 1.5;
  EXPECT_FALSE(p.IsValid(&why));
}

}  // namespace
}  // namespace orpe::slam
