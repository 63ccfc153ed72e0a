// Relocalisation after tracking loss (issue 19, docs/SLAM.md "Relocalisation"): a camera that jumps
// over a gap of frames is found again against the stored keyframes, verified by tracking; a frame
// of another scene is never relocalised.
#include <gtest/gtest.h>

#include "orpe/io/dataset.h"
#include "orpe/slam/slam_system.h"
#include "pipeline/pipeline_test_util.h"

namespace orpe {
namespace {

struct Step {
  slam::SlamFrameResult r;
  double err_m = 0, err_deg = 0;  // of the reported pose against the ground truth
};

/// Tracks the frames of `scene` whose positions are in [0, gap_first) and [gap_last + 1, end):
/// the camera moves through the gap unseen (a kidnapping). `other`: frames of another scene
/// replace those after the gap (a place the map has never seen).
std::vector<Step> track_with_gap(const std::string& scene, int gap_first, int gap_last,
                                 const slam::SlamParams& params, const std::string& other = "") {
  const auto reader = open_dataset(scene, DatasetParams{});
  const auto after = open_dataset(other.empty() ? scene : other, DatasetParams{});
  slam::SlamSystem slam(params);
  std::vector<Step> out;
  for (int i = 0; i < static_cast<int>(reader->size()); ++i) {
    if (i >= gap_first && i <= gap_last) continue;
    const RgbdFrame f = i < gap_first ? reader->read(i) : after->read(i);
    if (i == 0) slam.set_initial_pose(*f.T_world_cam_gt);
    Step s;
    s.r = slam.process(f);
    const SE3 e = f.T_world_cam_gt->inverse() * s.r.T_world_cam;
    s.err_m = e.translation().norm();
    s.err_deg = e.rotation_angle_deg();
    out.push_back(s);
  }
  return out;
}

slam::SlamParams with_reloc(bool on) {
  slam::SlamParams p;
  p.reloc.enabled = on;
  return p;
}

// 36 frames over 72 degrees around a table of objects; frames 12-21 (20 degrees, ~0.3 s) are cut.
SynthParams gap_scene_params(int seed) {
  SynthParams p = test::small_scene_params(320, 240, 36, 8, seed);
  p.scene = "table";
  return p;
}

TEST(Relocalisation, AfterAGapTheCameraIsFoundAgainAndTracked) {
  const std::string scene = test::synthetic_scene("reloc_gap", gap_scene_params(3));
  const auto steps = track_with_gap(scene, 12, 21, with_reloc(true));
  ASSERT_EQ(steps.size(), 26u);
  int first_ok = -1;
  for (size_t k = 12; k < steps.size(); ++k) {
    const Step& s = steps[k];
    if (s.r.status == slam::TrackingStatus::kOk && first_ok < 0) first_ok = static_cast<int>(k);
    if (s.r.status == slam::TrackingStatus::kOk) {
      EXPECT_LT(s.err_m, 0.05) << s.r.report();
      EXPECT_LT(s.err_deg, 5.0) << s.r.report();
    }
  }
  ASSERT_GE(first_ok, 12);
  EXPECT_LE(first_ok, 12 + 3) << "relocalised only " << first_ok - 12 << " frames after the gap";
  EXPECT_TRUE(steps[first_ok].r.relocalised) << steps[first_ok].r.report();
  EXPECT_EQ(steps.back().r.status, slam::TrackingStatus::kOk) << steps.back().r.report();
}

// Without relocalisation the same cut loses the camera: it stays LOST (re-acquiring only from the
// held pose, which the 20-degree jump put out of reach).
TEST(Relocalisation, WithoutItTheSameGapStaysLost) {
  const std::string scene = test::synthetic_scene("reloc_gap", gap_scene_params(3));
  const auto steps = track_with_gap(scene, 12, 21, with_reloc(false));
  int lost = 0;
  for (size_t k = 12; k < steps.size(); ++k)
    lost += steps[k].r.status == slam::TrackingStatus::kLost;
  EXPECT_GE(lost, 8);
}

// Frames of another scene after the gap: the relocaliser may propose poses, but none verifies, so
// nothing is fused and the map does not change.
TEST(Relocalisation, AWrongPlaceIsNeverRelocalisedNorFused) {
  const std::string scene = test::synthetic_scene("reloc_gap", gap_scene_params(3));
  const std::string other = test::synthetic_scene("reloc_other", gap_scene_params(7));
  const auto steps = track_with_gap(scene, 12, 21, with_reloc(true), other);
  for (size_t k = 12; k < steps.size(); ++k) {
    EXPECT_FALSE(steps[k].r.relocalised) << steps[k].r.report();
    EXPECT_FALSE(steps[k].r.fused) << steps[k].r.report();
  }
}

}  // namespace
}  // namespace orpe
