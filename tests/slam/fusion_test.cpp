// Surfel fusion rules: plateau on a static scene, confidence-weighted averaging, new surfels, stale
// unstable removal, free-space violations, depth cut-off, active window, merging, pixel->surfel map.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "orpe/core/error.h"
#include "orpe/slam/fusion.h"
#include "synthetic_scene.h"

namespace orpe::slam {
namespace {

using test::SyntheticScene;

FramePyramid preprocess(const RgbdFrame& f) {
  PreprocessParams p;
  p.bilateral_radius_px = 1;
  FramePyramid out;
  FramePreprocessor(p).process(f, &out);
  return out;
}

RgbdFrame wall_frame(double z, int index = 0) {
  return SyntheticScene::wall(z).render(SE3(), test::small_intrinsics(), index, 1);
}

RgbdFrame empty_frame(int index) {
  RgbdFrame f = wall_frame(1.0, index);
  f.depth.fill(0.0f);
  return f;
}

// The observation weight a of pixel (u, v) (FusionParams defaults, 160x120: g normaliser 100 px).
double weight(double u, double v) {
  const PinholeIntrinsics K = test::small_intrinsics();
  const double g = std::hypot(u - K.cx, v - K.cy) / (0.5 * std::hypot(K.width, K.height));
  return std::exp(-g * g / (2 * 0.6 * 0.6));
}

TEST(SurfelFusion, SurfelCountPlateausOnAStaticNoisyView) {
  const SyntheticScene scene = SyntheticScene::room();
  const RgbdFrame clean = scene.render(test::trajectory_pose(0), test::small_intrinsics(), 0, 1);
  std::mt19937 rng(3);
  SurfelMap map;
  SurfelFusion fusion;
  std::vector<size_t> counts;
  for (int t = 0; t < 40; ++t) {
    RgbdFrame f = clean;
    std::normal_distribution<float> noise(0.0f, 0.002f);  // 2 mm depth noise, new every frame
    for (auto& z : f.depth)
      if (z > 0) z += noise(rng);
    const FusionStats st = fusion.fuse(preprocess(f), test::trajectory_pose(0), t, &map);
    counts.push_back(st.surfels);
    EXPECT_EQ(st.surfels, map.size());
  }
  EXPECT_GT(counts[0], 10000u);
  // No unbounded growth: after the first frames the count stays put.
  EXPECT_LE(counts[39], counts[4] * 101 / 100) << "first " << counts[0] << " at 5: " << counts[4];
  EXPECT_LE(counts[39], counts[29] + counts[29] / 200);
  size_t stable = 0;
  for (float c : map.confidence) stable += c >= 10.0f;
  EXPECT_GT(stable, map.size() * 8 / 10);
}

TEST(SurfelFusion, UpdatesAreConfidenceWeightedAverages) {
  SurfelMap map;
  SurfelFusion fusion;
  IndexImage pixel_surfel;
  fusion.fuse(preprocess(wall_frame(1.00)), SE3(), 0, &map, &pixel_surfel);
  const int u = 80, v = 60;
  const std::int32_t s0 = pixel_surfel.at(u, v);
  ASSERT_GE(s0, 0);
  const double a = weight(u, v);
  EXPECT_NEAR(map.confidence[s0], a, 1e-5);
  const double r0 = std::sqrt(2.0) * 1.0 / test::small_intrinsics().fx;  // fronto-parallel radius
  EXPECT_NEAR(map.radius_m[s0], r0, 1e-5);
  EXPECT_NEAR(map.position_world[s0].z(), 1.0, 1e-5);

  const FusionStats st = fusion.fuse(preprocess(wall_frame(1.02)), SE3(), 1, &map, &pixel_surfel);
  EXPECT_EQ(st.created, 0u);  // 2 cm is inside the 5 cm association window
  const std::int32_t s1 = pixel_surfel.at(u, v);
  ASSERT_GE(s1, 0);
  // (a * 1.00 + a * 1.02) / (2a) with equal weights at the same pixel.
  EXPECT_NEAR(map.position_world[s1].z(), 1.01, 2e-4);
  EXPECT_NEAR(map.confidence[s1], 2 * a, 1e-4);
  EXPECT_EQ(map.last_seen_time[s1], 1);
  EXPECT_EQ(map.init_time[s1], 0);
}

TEST(SurfelFusion, ASurfaceBehindCreatesSurfelsAndClearsFreeSpace) {
  SurfelMap map;
  SurfelFusion fusion;
  const FusionStats first = fusion.fuse(preprocess(wall_frame(1.0)), SE3(), 0, &map);
  EXPECT_GT(first.created, 10000u);
  const FusionStats second = fusion.fuse(preprocess(wall_frame(1.3)), SE3(), 1, &map);
  EXPECT_GT(second.created, first.created * 9 / 10);  // 0.3 m is outside the association window
  EXPECT_EQ(second.updated, 0u);
  // The unstable 1.0 m surfels lie in front of the new measurement: free-space violations.
  EXPECT_GT(second.removed_free_space, first.created * 9 / 10);
  for (const Vec3f& p : map.position_world) EXPECT_NEAR(p.z(), 1.3, 0.01);
}

TEST(SurfelFusion, StaleUnstableSurfelsAreRemovedStableOnesKept) {
  FusionParams p;
  p.remove_free_space_violations = false;
  SurfelFusion fusion(p);
  SurfelMap map;
  // 12 observations make the central surfels stable (a ~ 1 there), the corners stay unstable.
  for (int t = 0; t < 12; ++t) fusion.fuse(preprocess(wall_frame(1.0, t)), SE3(), t, &map);
  size_t stable = 0;
  for (float c : map.confidence) stable += c >= 10.0f;
  const size_t before = map.size();
  ASSERT_GT(stable, 1000u);
  ASSERT_LT(stable, before);
  // Nothing observed any more: unstable surfels age out when older than 20 frames, stable ones stay.
  size_t removed = 0;
  for (int t = 12; t <= 20; ++t) removed += fusion.fuse(preprocess(empty_frame(t)), SE3(), t, &map).removed_unstable;
  EXPECT_EQ(map.size(), before) << "removed too early";
  removed += fusion.fuse(preprocess(empty_frame(21)), SE3(), 21, &map).removed_unstable;
  EXPECT_EQ(map.size(), stable);
  EXPECT_EQ(removed, before - stable);
}

TEST(SurfelFusion, DepthBeyondTheCutOffIsNotFused) {
  SurfelMap map;
  SurfelFusion fusion;
  EXPECT_EQ(fusion.fuse(preprocess(wall_frame(3.5)), SE3(), 0, &map).created, 0u);
  EXPECT_TRUE(map.empty());
  FusionParams far;
  far.max_depth_m = 4.0;
  SurfelFusion fusion_far(far);
  EXPECT_GT(fusion_far.fuse(preprocess(wall_frame(3.5)), SE3(), 0, &map).created, 10000u);
}

TEST(SurfelFusion, InactiveSurfelsAreNotFusedInto) {
  FusionParams p;
  p.active_window_frames = 5;
  p.remove_free_space_violations = false;
  SurfelFusion fusion(p);
  SurfelMap map;
  const size_t n0 = fusion.fuse(preprocess(wall_frame(1.0)), SE3(), 0, &map).created;
  // Seen again within the window: updated, nothing new.
  EXPECT_EQ(fusion.fuse(preprocess(wall_frame(1.0)), SE3(), 3, &map).created, 0u);
  // Seen again after the window (last seen at 3, now 10): a second layer is created.
  const FusionStats late = fusion.fuse(preprocess(wall_frame(1.0)), SE3(), 10, &map);
  EXPECT_GT(late.created, n0 * 9 / 10);
  EXPECT_EQ(late.updated, 0u);
  // Unless they are marked always active (object surfels).
  SurfelMap map2;
  SurfelFusion fusion2(p);
  fusion2.fuse(preprocess(wall_frame(1.0)), SE3(), 0, &map2);
  std::fill(map2.always_active.begin(), map2.always_active.end(), 1);
  EXPECT_EQ(fusion2.fuse(preprocess(wall_frame(1.0)), SE3(), 10, &map2).created, 0u);
}

TEST(SurfelFusion, MergesNearDuplicateUnstableSurfels) {
  FusionParams p;
  p.index_supersample = 2;  // duplicates half a pixel apart land in different cells
  p.remove_free_space_violations = false;
  SurfelFusion fusion(p);
  SurfelMap map;
  fusion.fuse(preprocess(wall_frame(1.0)), SE3(), 0, &map);
  const size_t n = map.size();
  // A lower-confidence copy of every surfel, shifted sideways by 0.45 radius (merge limit 0.5): the
  // copy lands in the next index cell. (Copies in the same cell are hidden by the z-buffer; they are
  // never updated and age out as unstable surfels instead.)
  for (size_t i = 0; i < n; ++i) {
    Surfel s = map.get(i);
    s.position_world.x() += 0.45f * s.radius_m;
    s.confidence *= 0.5f;
    map.push_back(s);
  }
  const FusionStats st = fusion.fuse(preprocess(empty_frame(1)), SE3(), 1, &map);
  EXPECT_GT(st.merged, n / 2);
  EXPECT_EQ(map.size(), 2 * n - st.merged);
}

TEST(SurfelFusion, PixelSurfelMapPointsAtTheObservedSurface) {
  const SyntheticScene scene = SyntheticScene::room();
  const SE3 pose = test::trajectory_pose(5);
  const RgbdFrame f = scene.render(pose, test::small_intrinsics(), 0, 1);
  SurfelMap map;
  SurfelFusion fusion;
  IndexImage ps;
  for (int t = 0; t < 3; ++t) fusion.fuse(preprocess(f), pose, t, &map, &ps);
  size_t mapped = 0;
  for (int v = 0; v < ps.height(); ++v)
    for (int u = 0; u < ps.width(); ++u) {
      const std::int32_t s = ps.at(u, v);
      if (s < 0) continue;
      ASSERT_LT(static_cast<size_t>(s), map.size());
      ++mapped;
      const Vec3 p = pose * test::small_intrinsics().backproject(u, v, f.depth.at(u, v));
      // Within the association window (5 cm along the ray) plus a disc radius.
      EXPECT_LT((map.position_world[s].cast<double>() - p).norm(), 0.08) << u << "," << v;
    }
  EXPECT_GT(mapped, ps.size() * 7 / 10);  // pixels without a normal (borders, edges) are not fused
}

TEST(SurfelFusion, HalfResolutionFusionMakesFewerLargerSurfels) {
  FusionParams p;
  p.fusion_level = 1;
  SurfelFusion half(p);
  SurfelFusion full;
  SurfelMap a, b;
  IndexImage ps;
  full.fuse(preprocess(wall_frame(1.0)), SE3(), 0, &a);
  half.fuse(preprocess(wall_frame(1.0)), SE3(), 0, &b, &ps);
  EXPECT_NEAR(double(b.size()) / a.size(), 0.25, 0.03);
  EXPECT_NEAR(b.radius_m[b.size() / 2] / a.radius_m[a.size() / 2], 2.0, 0.05);
  EXPECT_EQ(ps.width(), 160);  // the pixel map is still per full-resolution pixel
  EXPECT_GE(ps.at(80, 60), 0);
}

TEST(FusionParams, ValidationNamesTheProblem) {
  FusionParams p;
  std::string why;
  EXPECT_TRUE(p.IsValid(&why));
  p.index_supersample = 9;
  EXPECT_FALSE(p.IsValid(&why));
  EXPECT_NE(why.find("index_supersample"), std::string::npos);
  EXPECT_THROW(SurfelFusion{p}, ConfigError);
}

}  // namespace
}  // namespace orpe::slam
