#include <gtest/gtest.h>

#include "orpe/core/camera.h"

namespace orpe {
namespace {

TEST(PinholeIntrinsics, ProjectBackprojectRoundTrip) {
  PinholeIntrinsics K{640, 480, 585.0, 580.0, 320.0, 240.0};
  const Eigen::Vector3d p = K.backproject(100.25, 400.5, 2.5);
  const Eigen::Vector2d uv = K.project(p);
  EXPECT_NEAR(uv.x(), 100.25, 1e-12);
  EXPECT_NEAR(uv.y(), 400.5, 1e-12);
  EXPECT_NEAR(p.z(), 2.5, 1e-15);
}

TEST(PinholeIntrinsics, PyramidScalingKeepsRaysThroughBlockCentres) {
  PinholeIntrinsics K{640, 480, 585.0, 585.0, 320.0, 240.0};
  const PinholeIntrinsics K1 = K.scaled(1);
  EXPECT_EQ(K1.width, 320);
  EXPECT_EQ(K1.height, 240);
  // The level-1 pixel (10, 20) averages level-0 pixels (20..21, 40..41): centre (20.5, 40.5).
  const Eigen::Vector3d ray1 = K1.backproject(10, 20, 1.0);
  const Eigen::Vector3d ray0 = K.backproject(20.5, 40.5, 1.0);
  EXPECT_LT((ray1 - ray0).norm(), 1e-12);
}

TEST(PinholeIntrinsics, Validity) {
  std::string why;
  EXPECT_TRUE(PinholeIntrinsics{}.IsValid(&why));
  PinholeIntrinsics bad;
  bad.fx = 0;
  EXPECT_FALSE(bad.IsValid(&why));
  EXPECT_NE(why.find("focal"), std::string::npos);
}

}  // namespace
}  // namespace orpe
