// Loop closure (issue 19, docs/SLAM.md "Loop closure"): a camera that comes back to a place it
// mapped long ago recognises it, and the correction moves the trajectory (and what hangs from it)
// onto the old map.
//
// The revisit is made cheap and its drift known: frames 0-44 of the synthetic room loop (30
// degrees of turning) are tracked, frames 45-59 are fused at poses that drift away from the truth
// by up to kDrift (process_at_known_pose: a controlled tracking drift), and the camera then comes
// back over frames 59..0, tracked. The surfels of the first frames have long left the active
// window, so tracking alone keeps much of the drift; loop closure finds the first frames' place
// again.
//
// History: disabled from 2026-12-04 to 12-06 as a known failure (with loop closure the end error was
// 7.4 cm against 1.9 cm without, kDrift 4.6 cm). Since the photometric edge margin of session 17 the
// same scene gives 0.9 cm with against 1.6 cm without (tracking itself now takes back most of that
// drift), so the drift was doubled to 9.2 cm / 2.3 deg: 2.4 cm without, below 0.7 cm with (session
// 18, docs/SLAM.md "Loop closure"). With the tracking prediction's surface band (session 19)
// tracking took back most of that too (0.7 cm without, 0.08 cm with), so the drift was doubled
// again to 18.3 cm / 4.6 deg: 3.9 cm without, 0.7 cm with (3 closures). ~11 s on two idle cores.

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <map>

#include "orpe/pipeline/object_fusion.h"
#include "orpe/slam/slam_system.h"
#include "orpe/synth/generator.h"

namespace orpe {
namespace {

const SE3 kDrift(so3_exp(Vec3(0.0, 0.0, 0.08)), Vec3(0.16, -0.08, 0.04));  // 18.3 cm, 4.6 deg

slam::SlamParams loop_params(bool on) {
  slam::SlamParams p;
  p.loop.enabled = on;  // on by default
  p.loop.min_age_frames = 30;
  p.loop.detect_every_frames = 5;
  p.fusion.active_window_frames = 20;
  return p;
}

struct Revisit {
  std::vector<slam::SlamFrameResult> results;
  std::vector<SE3> gt;          // per processed frame
  std::vector<SE3> trajectory;  // the system's (corrected)
  std::vector<SE3> trajectory_before_last_closure;
  int closures = 0;
  double end_error_m = 0;
};

Revisit run_revisit_uncached(bool loop_on) {
  static const synth::SyntheticSceneGenerator gen([] {
    SynthParams p;
    p.seed = 5;
    p.scene = "room";
    p.trajectory = "loop";
    p.frames = 600;  // 0.65 degrees per frame
    p.objects = 24;
    p.width = 320;
    p.height = 240;
    p.model_points = 100;
    p.threads = 1;
    return p;
  }());
  static std::vector<RgbdFrame> frames;
  if (frames.empty())
    for (int i = 0; i < 60; ++i)
      frames.push_back(synth::to_rgbd_frame(gen.render_frame(i, 1), gen));
  slam::SlamSystem slam(loop_params(loop_on));
  Revisit r;
  auto step = [&](int i, const SE3* known) {
    const RgbdFrame& f = frames[static_cast<size_t>(i)];
    if (r.results.empty()) slam.set_initial_pose(*f.T_world_cam_gt);
    const std::vector<SE3> before = slam.trajectory();
    r.results.push_back(known ? slam.process_at_known_pose(f, *known) : slam.process(f));
    if (r.results.back().loop_closed) r.trajectory_before_last_closure = before;
    r.gt.push_back(*f.T_world_cam_gt);
  };
  for (int i = 0; i < 45; ++i) step(i, nullptr);
  for (int i = 45; i < 60; ++i) {
    const double s = (i - 44) / 15.0;
    const SE3 drifted = SE3::exp(s * kDrift.log()) * *frames[static_cast<size_t>(i)].T_world_cam_gt;
    step(i, &drifted);
  }
  for (int i = 59; i >= 0; --i) step(i, nullptr);
  r.trajectory = slam.trajectory();
  r.closures = slam.loop_closures();
  r.end_error_m = (r.trajectory.back().translation() - r.gt.back().translation()).norm();
  return r;
}

const Revisit& run_revisit(bool loop_on) {
  static std::map<bool, Revisit> runs;
  auto it = runs.find(loop_on);
  if (it == runs.end()) it = runs.emplace(loop_on, run_revisit_uncached(loop_on)).first;
  return it->second;
}

TEST(LoopClosure, ARevisitIsRecognisedAndTheDriftCorrected) {
  const Revisit& off = run_revisit(false);
  const Revisit& on = run_revisit(true);
  EXPECT_EQ(off.closures, 0);
  EXPECT_GT(off.end_error_m, 0.015) << "much of the drift should stay without loop closure";
  ASSERT_GE(on.closures, 1);
  double corrected_m = 0;
  for (size_t k = 0; k < on.results.size(); ++k) {
    const auto& res = on.results[k];
    if (!res.loop_closed) continue;
    // Only on the way back, against a keyframe of the first, undrifted frames.
    EXPECT_GE(k, 60u) << res.report();
    EXPECT_LT(res.loop_keyframe, 45) << res.report();
    corrected_m += res.loop_correction_m;
  }
  std::cout << "end error without / with loop closure: " << off.end_error_m << " / "
            << on.end_error_m << " m; " << on.closures << " closures moving the camera by "
            << corrected_m << " m in all\n";
  EXPECT_GT(corrected_m, 0.01) << "the closures should have moved the camera by the drift left";
  EXPECT_LT(on.end_error_m, 0.012)
      << "end error with loop closure " << on.end_error_m << " m, without " << off.end_error_m;
  EXPECT_LT(on.end_error_m, 0.4 * off.end_error_m)
      << "end error with loop closure " << on.end_error_m << " m, without " << off.end_error_m;
}

// The correction is one rigid motion per frame: the corrected trajectory is loop_correction(t)
// times the one before, and an object state in the world frame, moved by the same correction, keeps
// its pose relative to the corrected camera of the frame that saw it.
TEST(LoopClosure, PosesAndObjectStatesMoveWithTheMap) {
  const Revisit& on = run_revisit(true);
  ASSERT_GE(on.closures, 1);
  ASSERT_FALSE(on.trajectory_before_last_closure.empty());
  // The last closure's correction, replayed: before * C(t) for the frames that existed then.
  const std::vector<SE3>& before = on.trajectory_before_last_closure;
  double moved = 0;
  for (size_t t = 0; t < before.size(); ++t)
    moved = std::max(moved, (on.trajectory[t].translation() - before[t].translation()).norm());
  EXPECT_GT(moved, 0.002) << "the closure should have moved earlier poses";

  // An EKF state placed by a frame, corrected with that frame's correction.
  PoseEkfParams ep;
  ObjectPoseFusion fusion(ep, ObjectSymmetry{}, 1);
  PoseMeasurement m;
  m.T_world_cam = before.back();
  m.T_cam_obj = SE3(so3_exp(Vec3(0.1, 0.2, 0.3)), Vec3(0.1, -0.05, 1.0));
  m.mu_m = 0.005;
  fusion.add(m, 1.0);
  fusion.flush();
  ASSERT_TRUE(fusion.has_estimate());
  const SE3 C = on.trajectory[before.size() - 1] * before.back().inverse();
  fusion.apply_world_correction(C);
  const SE3 rel = fusion.T_cam_obj(on.trajectory[before.size() - 1]);
  EXPECT_LT((rel.translation() - m.T_cam_obj.translation()).norm(), 1e-6);
  EXPECT_LT(rotation_distance_rad(rel.rotation(), m.T_cam_obj.rotation()), 1e-6);
}

}  // namespace
}  // namespace orpe
