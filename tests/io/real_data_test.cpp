// Every file of the shared real data loads through the readers; ground truth is consistent.
#include <gtest/gtest.h>

#include <cmath>

#include "orpe/io/dataset.h"
#include "support/test_data.h"

namespace orpe {
namespace {

size_t count_valid_depth(const DepthImage& d) {
  size_t n = 0;
  for (float z : d) n += z > 0;
  return n;
}

TEST(RealSevenScenes, AllFramesLoadThroughBothLayoutsWithTheSameGroundTruth) {
  ORPE_REQUIRE_DATA(data, "7scenes-seq/rgb.txt");
  const std::string dir = data + "/7scenes-seq";
  EXPECT_EQ(detect_dataset_format(dir), "tum");  // the TUM index takes precedence
  DatasetParams tum_params;
  tum_params.format = "tum";
  DatasetParams native_params;
  native_params.format = "7scenes";
  auto tum = open_dataset(dir, tum_params);
  auto native = open_dataset(dir, native_params);
  ASSERT_EQ(tum->size(), 500u);
  ASSERT_EQ(native->size(), 500u);
  // 7-Scenes origin detected: millimetres, not TUM's 5000, and 7-Scenes' intrinsics.
  EXPECT_DOUBLE_EQ(tum->info().depth_units_per_m, 1000.0);
  EXPECT_EQ(tum->info().intrinsics, native->info().intrinsics);
  EXPECT_DOUBLE_EQ(native->info().intrinsics.fx, 585.0);
  EXPECT_EQ(native->info().intrinsics.width, 640);

  FrameStream tum_stream(*tum), native_stream(*native);
  RgbdFrame a, b;
  size_t n = 0;
  double max_dt = 0, max_dR = 0, max_dt_m = 0;
  while (tum_stream.next(a)) {
    ASSERT_TRUE(native_stream.next(b));
    ASSERT_EQ(a.index, b.index);
    max_dt = std::max(max_dt, std::abs(a.timestamp_s - b.timestamp_s));
    ASSERT_EQ(a.depth.width(), 640);
    ASSERT_EQ(a.depth.height(), 480);
    // Same file pair: identical pixels.
    ASSERT_TRUE(std::equal(a.depth.begin(), a.depth.end(), b.depth.begin()));
    ASSERT_TRUE(a.color.at(100, 200) == b.color.at(100, 200));
    // Plausible metric depth for an indoor Kinect: median-ish check via the mean of valid pixels.
    const size_t valid = count_valid_depth(a.depth);
    ASSERT_GT(valid, a.depth.size() / 4) << a.name;
    double sum = 0;
    for (float z : a.depth) sum += z;
    const double mean = sum / valid;
    EXPECT_GT(mean, 0.3) << a.name;
    EXPECT_LT(mean, 5.0) << a.name;
    ASSERT_TRUE(a.T_world_cam_gt && b.T_world_cam_gt) << a.name;
    max_dR = std::max(
        max_dR, rotation_distance_rad(a.T_world_cam_gt->rotation(), b.T_world_cam_gt->rotation()));
    max_dt_m = std::max(max_dt_m,
                        (a.T_world_cam_gt->translation() - b.T_world_cam_gt->translation()).norm());
    ++n;
  }
  EXPECT_FALSE(native_stream.next(b));
  EXPECT_EQ(n, 500u);
  EXPECT_EQ(tum_stream.skipped(), 0u);
  EXPECT_EQ(native_stream.skipped(), 0u);
  EXPECT_LT(max_dt, 1e-5);
  // pose.txt rotations are orthonormal only to ~4e-4 (KinectFusion output); the quaternions of
  // groundtruth.txt and our SVD projection round them differently, by ~2e-5 rad.
  EXPECT_LT(max_dR, 1e-4);
  EXPECT_LT(max_dt_m, 1e-6);
  EXPECT_EQ(tum->ground_truth_trajectory().size(), 500u);
  EXPECT_EQ(native->ground_truth_trajectory().size(), 500u);
}

}  // namespace
}  // namespace orpe
