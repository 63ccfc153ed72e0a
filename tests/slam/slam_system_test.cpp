// End-to-end SLAM on a small synthetic sequence (analytic room rendered at known poses), tracking
// loss and re-acquisition.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <set>

#include "orpe/core/error.h"
#include "orpe/slam/slam_system.h"
#include "synthetic_scene.h"

namespace orpe::slam {
namespace {

using test::SyntheticScene;

SlamParams small_params() {
  SlamParams p;
  p.preprocess.bilateral_radius_px = 1;
  p.options.reserve_surfels = 0;
  return p;
}

struct RunStats {
  double max_translation_error_m = 0;
  double max_rotation_error_deg = 0;
  std::vector<SlamFrameResult> results;
  std::vector<double> translation_error_m;  ///< per frame (0 for LOST frames)
};

RunStats run(SlamSystem& slam, const SyntheticScene& scene, int frames,
             const std::function<RgbdFrame(int)>& frame_for = nullptr) {
  RunStats s;
  const PinholeIntrinsics K = test::small_intrinsics();
  for (int i = 0; i < frames; ++i) {
    const SE3 gt = test::trajectory_pose(i);
    if (i == 0) slam.set_initial_pose(gt);
    const RgbdFrame f = frame_for ? frame_for(i) : scene.render(gt, K, i);
    const SlamFrameResult r = slam.process(f);
    s.results.push_back(r);
    s.translation_error_m.push_back(0);
    if (r.status == TrackingStatus::kLost) continue;
    const SE3 err = gt.inverse() * r.T_world_cam;
    s.translation_error_m.back() = err.translation().norm();
    s.max_translation_error_m = std::max(s.max_translation_error_m, err.translation().norm());
    s.max_rotation_error_deg = std::max(s.max_rotation_error_deg, err.rotation_angle_deg());
  }
  return s;
}

TEST(SlamSystem, TracksASyntheticSequenceWithinMillimetres) {
  const SyntheticScene scene = SyntheticScene::room();
  SlamSystem slam(small_params());
  const RunStats s = run(slam, scene, 40);
  for (const auto& r : s.results) EXPECT_EQ(r.status, TrackingStatus::kOk) << r.report();
  EXPECT_LT(s.max_translation_error_m, 0.01);
  EXPECT_LT(s.max_rotation_error_deg, 0.5);
  EXPECT_GT(slam.map().size(), 5000u);
  EXPECT_EQ(slam.frame_count(), 40);
  // The hook data for the semantic stage: every fused pixel maps to a live surfel.
  const IndexImage& ps = slam.last_pixel_surfel();
  ASSERT_EQ(ps.width(), 160);
  size_t mapped = 0;
  for (const auto i : ps) {
    ASSERT_LT(i, static_cast<std::int32_t>(slam.map().size()));
    mapped += i >= 0;
  }
  EXPECT_GT(mapped, ps.size() / 2);
}

TEST(SlamSystem, ReportsLossHoldsThePoseAndReacquires) {
  const SyntheticScene scene = SyntheticScene::room();
  const PinholeIntrinsics K = test::small_intrinsics();
  SlamSystem slam(small_params());
  // Frames 15-17 look the opposite way (as if the sensor were covered / swapped): alignment fails.
  auto frame_for = [&](int i) {
    SE3 pose = test::trajectory_pose(i);
    if (i >= 15 && i <= 17) pose = pose * SE3(so3_exp(Vec3(0, 2.5, 0)), Vec3::Zero());
    return scene.render(pose, K, i);
  };
  const RunStats s = run(slam, scene, 30, frame_for);
  const SE3 held = s.results[14].T_world_cam;
  for (int i = 15; i <= 17; ++i) {
    EXPECT_EQ(s.results[i].status, TrackingStatus::kLost) << s.results[i].report();
    EXPECT_FALSE(s.results[i].fused);
    EXPECT_LT((s.results[i].T_world_cam.translation() - held.translation()).norm(), 1e-12);
    EXPECT_FALSE(s.results[i].reason.empty());
  }
  EXPECT_EQ(s.results[18].status, TrackingStatus::kOk) << s.results[18].report();
  EXPECT_EQ(s.results[29].status, TrackingStatus::kOk);
  EXPECT_LT(s.max_translation_error_m, 0.01);
  EXPECT_LT(s.max_rotation_error_deg, 0.5);
}

/// The frame with depth only on the room's far wall (world z = 3): one plane, so the ICP normal
/// matrix is degenerate (translation along the wall unconstrained by depth) while the frame still
/// aligns with the map -- a DEGRADED frame.
RgbdFrame far_wall_only(const RgbdFrame& full, const SE3& T_world_cam) {
  RgbdFrame f = full;
  const PinholeIntrinsics& K = f.intrinsics;
  for (int v = 0; v < K.height; ++v)
    for (int u = 0; u < K.width; ++u) {
      const float z = f.depth.at(u, v);
      if (z <= 0) continue;
      const Vec3 p = T_world_cam * Vec3((u - K.cx) / K.fx * z, (v - K.cy) / K.fy * z, z);
      if (std::fabs(p.z() - 3.0) > 1e-3) f.depth.at(u, v) = 0.0f;
    }
  return f;
}

/// 30 frames of the room; frames in `degenerate` see only the far wall.
RunStats run_with_degenerate_frames(SlamSystem& slam, const std::set<int>& degenerate) {
  const SyntheticScene scene = SyntheticScene::room();
  const PinholeIntrinsics K = test::small_intrinsics();
  return run(slam, scene, 30, [&](int i) {
    const SE3 pose = test::trajectory_pose(i);
    const RgbdFrame f = scene.render(pose, K, i);
    return degenerate.count(i) ? far_wall_only(f, pose) : f;
  });
}

/// Camera error per frame: measured up to 1.8 cm on the one-plane frames (depth fixes only the
/// distance to the wall) and the frame after (1.25 cm), up to 0.9 cm on the others; bounds 2.5 /
/// 1.2 cm.
void expect_tracked(const RunStats& s, const std::set<int>& degenerate) {
  for (int i = 0; i < static_cast<int>(s.translation_error_m.size()); ++i) {
    const bool near_degenerate = degenerate.count(i) || degenerate.count(i - 1);
    EXPECT_LT(s.translation_error_m[i], near_degenerate ? 0.025 : 0.012) << "frame " << i;
  }
}

TEST(SlamSystem, WeakFramesAreDegradedFusedAndCountedTowardsLoss) {
  // Frames 10-11 and 20-22 see one plane: DEGRADED, pose updated, fused (fuse_degraded); the
  // counter restarts on the good frames between, so three in a row (20-22) are still within
  // max_bad_frames.
  SlamParams p = small_params();
  p.tracker.max_bad_frames = 3;
  SlamSystem slam(p);
  const std::set<int> degenerate = {10, 11, 20, 21, 22};
  const RunStats s = run_with_degenerate_frames(slam, degenerate);
  for (int i : {10, 11, 20, 21, 22}) {
    EXPECT_EQ(s.results[i].status, TrackingStatus::kDegraded)
        << "frame " << i << ": " << s.results[i].report();
    EXPECT_TRUE(s.results[i].fused) << "frame " << i;
    EXPECT_NE(s.results[i].reason.find("degenerate"), std::string::npos) << s.results[i].reason;
  }
  for (int i : {9, 12, 19, 23, 29})
    EXPECT_EQ(s.results[i].status, TrackingStatus::kOk) << "frame " << i;
  expect_tracked(s, degenerate);
  EXPECT_LT(s.max_rotation_error_deg, 0.5);
}

TEST(SlamSystem, MoreThanMaxBadFramesInARowIsLost) {
  SlamParams p = small_params();
  p.tracker.max_bad_frames = 2;
  SlamSystem slam(p);
  const std::set<int> degenerate = {10, 11, 12, 13};
  const RunStats s = run_with_degenerate_frames(slam, degenerate);
  EXPECT_EQ(s.results[10].status, TrackingStatus::kDegraded) << s.results[10].report();
  EXPECT_EQ(s.results[11].status, TrackingStatus::kDegraded) << s.results[11].report();
  const SE3 held = s.results[11].T_world_cam;
  for (int i :
       {12, 13}) {  // the third weak frame in a row is LOST; a weak frame does not re-acquire
    EXPECT_EQ(s.results[i].status, TrackingStatus::kLost)
        << "frame " << i << ": " << s.results[i].report();
    EXPECT_FALSE(s.results[i].fused) << "frame " << i;
    EXPECT_LT((s.results[i].T_world_cam.translation() - held.translation()).norm(), 1e-12);
  }
  EXPECT_EQ(s.results[14].status, TrackingStatus::kOk)
      << "a good frame re-acquires: " << s.results[14].report();
  expect_tracked(s, degenerate);
}

TEST(SlamSystem, DegradedFramesAreNotFusedWhenFuseDegradedIsOff) {
  SlamParams p = small_params();
  p.options.fuse_degraded = false;
  SlamSystem slam(p);
  const std::set<int> degenerate = {10, 20};
  const RunStats s = run_with_degenerate_frames(slam, degenerate);
  for (int i : {10, 20}) {
    EXPECT_EQ(s.results[i].status, TrackingStatus::kDegraded) << s.results[i].report();
    EXPECT_FALSE(s.results[i].fused) << "frame " << i;
    EXPECT_EQ(s.results[i].fusion.surfels, s.results[i - 1].fusion.surfels)
        << "the map is unchanged";
  }
  EXPECT_TRUE(s.results[11].fused);
  EXPECT_TRUE(s.results[21].fused);
  expect_tracked(s, degenerate);
}

TEST(SlamSystem, RejectsFramesOfADifferentSize) {
  SlamSystem slam(small_params());
  const SyntheticScene scene = SyntheticScene::room();
  slam.process(scene.render(test::trajectory_pose(0), test::small_intrinsics(), 0));
  PinholeIntrinsics K2 = test::small_intrinsics();
  K2.width = 80;
  K2.height = 60;
  EXPECT_THROW(slam.process(scene.render(test::trajectory_pose(1), K2, 1)), ConfigError);
}

// The scene's brightness rises by 1 % per frame (an exposure or lighting drift): the tracker finds
// each frame's gain against the map, and the map keeps the first frame's brightness (colours are
// fused at the map's brightness). Without the gain (slam_tracking.rgb_estimate_gain=false) the
// map's colours follow the drift and the pose error grows (measured: map brightness 1.052, largest
// error 5.4 mm; with the gain 1.000 and 1.4 mm).
TEST(SlamSystem, ABrightnessDriftIsEstimatedAndTheMapKeepsItsBrightness) {
  const SyntheticScene scene = SyntheticScene::room();
  const PinholeIntrinsics K = test::small_intrinsics();
  const int frames = 12;
  auto brightness = [](int i) { return 1.0 + 0.01 * i; };
  auto frame_for = [&](int i) {
    RgbdFrame f = scene.render(test::trajectory_pose(i), K, i);
    for (Rgb8& c : f.color) {
      auto s = [&](std::uint8_t x) {
        return static_cast<std::uint8_t>(std::clamp(x * brightness(i) + 0.5, 0.0, 255.0));
      };
      c = Rgb8{s(c.r), s(c.g), s(c.b)};
    }
    return f;
  };
  SlamSystem slam(small_params());
  const RunStats s = run(slam, scene, frames, frame_for);
  // The map's brightness: its colours over the scene's true colours at the surfels.
  double map_sum = 0, true_sum = 0;
  const SurfelMap& m = slam.map();
  for (size_t k = 0; k < m.size(); ++k) {
    const Rgb8 c = m.color[k], t = scene.texture(m.position_world[k].cast<double>());
    map_sum += c.r + c.g + c.b;
    true_sum += t.r + t.g + t.b;
  }
  const SlamFrameResult& last = s.results.back();
  EXPECT_NEAR(last.rgb_gain, 1 / brightness(frames - 1), 0.01) << last.report();
  EXPECT_NEAR(map_sum / true_sum, 1.0, 0.01);
  EXPECT_LT(s.max_translation_error_m, 0.003);
}

TEST(SlamSystem, FusesAtKnownPosesAndReportsTheTrackingEstimate) {
  SlamSystem slam(small_params());
  const SyntheticScene scene = SyntheticScene::room();
  const PinholeIntrinsics K = test::small_intrinsics();
  for (int i = 0; i <= 10; ++i) {
    const SE3 gt = test::trajectory_pose(i);
    // The last known pose is 2 cm off the truth: the state follows the given pose, while the
    // tracker (from the previous pose, against the map of the exact frames) reports where the frame
    // aligns.
    const SE3 given = i < 10 ? gt : SE3(gt.rotation(), gt.translation() + Vec3(0.02, 0, 0));
    const SlamFrameResult r = slam.process_at_known_pose(scene.render(gt, K, i), given);
    EXPECT_NE(r.status, TrackingStatus::kLost) << r.report();
    EXPECT_TRUE(r.fused);
    EXPECT_LT((r.T_world_cam.translation() - given.translation()).norm(), 1e-12);
    EXPECT_LT((r.tracked_T_world_cam.translation() - gt.translation()).norm(), 0.006)
        << "frame " << i;
  }
  EXPECT_EQ(slam.frame_count(), 11);
}

}  // namespace
}  // namespace orpe::slam
