// Loop closure (issue 19): place recognition of revisits with the relocaliser's keyframes, a loop
// constraint verified against the old part of the map, and the correction of the trajectory and the
// map by a pose graph over the fused frames (pose_graph.h). SlamSystem runs it; see docs/SLAM.md
// "Loop closure".
//
//  - Detection: every `detect_every_frames` frames, when the frame was tracked OK and fused,
//    its ORB keypoints are matched against the keyframes stored at least `min_age_frames`
//    frames ago (the relocaliser's database, slam_reloc); the best candidates give T_kf_cam by
//    3D-3D RANSAC.
//  - Verification: the map's *old* surfels (last seen at least min_age_frames ago) are rendered at
//    the candidate pose and the frame is tracked against them with every gate of the tracker; only
//    an OK alignment makes a loop constraint.
//  - Correction: one node per fused frame, odometry edges between consecutive ones, loop edges;
//    Gauss-Newton with the first node fixed. Every frame's pose and every surfel follows the
//    correction of the frame that last fused it (SurfelMap::last_seen_time); the keyframes' poses
//    too. The old surfels the frame sees are made active again (last seen now), so tracking and
//    fusion continue on one surface instead of two.
#pragma once

#include <string>

namespace orpe::slam {

/// Config section `slam_loop`.
struct LoopClosureParams {
  /// Detection, verification and correction. On by default since session 18 (the synthetic
  /// revisit that had made the end error worse no longer does, docs/SLAM.md "Loop closure"); off in
  /// the `realtime` preset (a detection costs an ORB pass and a verification render).
  bool enabled = true;
  /// A keyframe is a loop candidate only when stored at least this many frames before the current
  /// frame (frames; EF's active window is 200: older surfels are not tracked against).
  int min_age_frames = 300;
  int detect_every_frames = 10;  ///< detection attempts: every this many frames (frames)
  /// Corrections below both of these are not applied (the loop is already consistent).
  double min_correction_m = 0.002;
  double min_correction_deg = 0.1;
  /// A verified constraint implying a larger correction of the current pose is rejected (m, deg).
  double max_correction_m = 0.5;
  double max_correction_deg = 20.0;
  /// Pose graph: per-edge standard deviations of odometry (m, rad) and the loop edges' information
  /// relative to an odometry edge.
  double odometry_sigma_m = 0.01;
  double odometry_sigma_rad = 0.01;
  double loop_weight = 1.0;
  int iterations = 10;  ///< Gauss-Newton iterations per correction

  template <class V>
  void visit(V&& v) {
    v("enabled", enabled,
      "Loop closure: detect revisits of old keyframes, verify against the old map, correct the "
      "trajectory and the surfels by a pose graph; off = the drift stays");
    v("min_age_frames", min_age_frames,
      "Keyframes at least this many frames old are loop candidates (frames)");
    v("detect_every_frames", detect_every_frames, "Try a detection every this many frames");
    v("min_correction_m", min_correction_m,
      "Corrections smaller than this (m) and min_correction_deg are not applied");
    v("min_correction_deg", min_correction_deg, "... and than this (deg)");
    v("max_correction_m", max_correction_m,
      "A loop implying a larger correction of the current pose (m) is rejected");
    v("max_correction_deg", max_correction_deg, "... or this many degrees");
    v("odometry_sigma_m", odometry_sigma_m,
      "Pose graph: translation standard deviation of one odometry edge (m)");
    v("odometry_sigma_rad", odometry_sigma_rad,
      "Pose graph: rotation standard deviation of one odometry edge (rad)");
    v("loop_weight", loop_weight, "Information of a loop edge relative to an odometry edge");
    v("iterations", iterations, "Gauss-Newton iterations per correction");
  }
  bool IsValid(std::string* why) const {
    auto fail = [&](const char* m) {
      if (why) *why = m;
      return false;
    };
    if (min_age_frames < 1) return fail("min_age_frames must be >= 1");
    if (detect_every_frames < 1) return fail("detect_every_frames must be >= 1");
    if (!(min_correction_m >= 0) || !(min_correction_deg >= 0))
      return fail("min_correction_m and min_correction_deg must be >= 0");
    if (!(max_correction_m > min_correction_m) || !(max_correction_deg > min_correction_deg))
      return fail("max_correction_* must be larger than min_correction_*");
    if (!(odometry_sigma_m > 0) || !(odometry_sigma_rad > 0) || !(loop_weight > 0))
      return fail("odometry_sigma_m, odometry_sigma_rad and loop_weight must be > 0");
    if (iterations < 1 || iterations > 1000) return fail("iterations must be in [1, 1000]");
    return true;
  }
};

}  // namespace orpe::slam
