// Relocalisation after tracking loss (issue 19): a database of keyframes -- ORB keypoints of
// tracked frames with their 3D points in the keyframe's camera frame, and the keyframe's
// T_world_cam -- queried with a lost frame. Each of the keyframes sharing the most descriptor
// matches with the frame gives a candidate T_world_cam from a 3D-3D RANSAC (Kabsch on three
// matches, then all inliers).
//
// The relocaliser only proposes: SlamSystem verifies every candidate by tracking the frame against
// the map rendered at it, with the tracker's usual quality gates and free-space check, and resumes
// only on an OK alignment (a wrong candidate is never fused). OpenCV stays inside relocaliser.cpp.
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "orpe/core/se3.h"
#include "orpe/slam/preprocess.h"
#include "orpe/slam/tracker.h"

namespace orpe::slam {

/// Config section `slam_reloc`.
struct RelocaliserParams {
  bool enabled = true;  ///< off: a lost camera re-acquires only from its held pose (as before)
  /// A tracked (OK) frame becomes a keyframe when its camera is at least this far from every stored
  /// keyframe's, in translation or rotation. Typical 0.10 m / 10 deg: ~1 keyframe per 10 cm of
  /// path.
  double keyframe_min_translation_m = 0.10;
  double keyframe_min_rotation_deg = 10.0;
  int max_keyframes = 2000;  ///< older keyframes are dropped beyond this (memory: ~40 kB each)
  int orb_features = 600;    ///< ORB keypoints detected per frame (full resolution)
  /// Lowe's ratio test on the two nearest descriptors (Hamming); typical 0.75-0.8.
  double match_ratio = 0.8;
  int candidates = 3;    ///< keyframes (most matches first) whose pose is estimated and verified
  int min_inliers = 20;  ///< 3D-3D RANSAC inliers a candidate needs
  /// RANSAC inlier distance between a keyframe point and the frame's point moved into it (m).
  double inlier_distance_m = 0.03;
  int ransac_iterations = 300;  ///< fixed seed: deterministic
  /// Tracking rounds that verify a candidate: the frame is tracked against the map rendered at the
  /// candidate; when that alignment is not OK, the map is rendered again at its estimate and the
  /// frame tracked again, up to this many rounds in all (fewer when a round moves the pose by less
  /// than the tracker's max_final_step, or when the estimate leaves the tracker's jump limits of
  /// the candidate). The last round's gates decide, every one as for a tracked frame. A candidate
  /// several cm off is verified against a view rendered there, whose occlusions and silhouettes
  /// are not the camera's: the round from the corrected pose is the one to judge. 1 = one round
  /// (before session 24).
  int verify_rounds = 3;

  template <class V>
  void visit(V&& v) {
    v("enabled", enabled,
      "Relocalise a LOST camera against stored keyframes (ORB + 3D-3D RANSAC, verified by "
      "tracking against the map); off = re-acquire from the held pose only");
    v("keyframe_min_translation_m", keyframe_min_translation_m,
      "A tracked frame is stored as a keyframe when its camera is at least this far (m) ...");
    v("keyframe_min_rotation_deg", keyframe_min_rotation_deg,
      "... or this many degrees from every stored keyframe's");
    v("max_keyframes", max_keyframes, "Keyframes kept (the oldest are dropped beyond this)");
    v("orb_features", orb_features, "ORB keypoints per frame");
    v("match_ratio", match_ratio, "Ratio test of the descriptor matches (nearest / second)");
    v("candidates", candidates, "Keyframes (most matches first) tried per lost frame");
    v("min_inliers", min_inliers, "3D-3D RANSAC inliers a candidate pose needs");
    v("inlier_distance_m", inlier_distance_m, "RANSAC inlier distance (m)");
    v("ransac_iterations", ransac_iterations, "RANSAC iterations per candidate (fixed seed)");
    v("verify_rounds", verify_rounds,
      "Tracking rounds verifying a candidate: a round that is not OK is followed by one against "
      "the map rendered at its estimate; the last round's gates decide (1 = one round)");
  }
  bool IsValid(std::string* why) const;
};

/// A candidate camera pose for a lost frame.
struct RelocCandidate {
  SE3 T_world_cam;
  int keyframe_frame_index = -1;    ///< RgbdFrame::index of the keyframe it came from
  std::int32_t keyframe_time = -1;  ///< the keyframe's time stamp (maybe_add's `time`)
  SE3 T_kf_cam;                     ///< the RANSAC estimate: the camera in the keyframe's frame
  int matches = 0;                  ///< descriptor matches with that keyframe
  int inliers = 0;                  ///< RANSAC inliers among them
};

class Relocaliser {
 public:
  explicit Relocaliser(const RelocaliserParams& params = {});
  ~Relocaliser();
  Relocaliser(Relocaliser&&) noexcept;
  Relocaliser& operator=(Relocaliser&&) noexcept;

  const RelocaliserParams& params() const { return params_; }
  /// Stores `level0` (intensity + vertex map, full resolution) as a keyframe at `T_world_cam` when
  /// it is far enough from every stored keyframe (RelocaliserParams). Returns whether it was
  /// stored.
  /// `time`: the caller's clock (SlamSystem's frame counter); -1 = frame_index.
  bool maybe_add(const FrameLevel& level0, const SE3& T_world_cam, int frame_index,
                 std::int32_t time = -1);
  /// Candidate poses of `level0`'s camera, best first (most inliers); empty when no keyframe
  /// shares enough matches. Only keyframes stored at a time <= max_time are searched (loop
  /// closure looks for old places only). Deterministic.
  std::vector<RelocCandidate> query(
      const FrameLevel& level0,
      std::int32_t max_time = std::numeric_limits<std::int32_t>::max()) const;
  /// Replaces every keyframe's T_world_cam by f(time, T_world_cam) (after a loop correction).
  void update_poses(const std::function<SE3(std::int32_t, const SE3&)>& f);
  size_t size() const;
  void clear();

 private:
  struct Impl;
  RelocaliserParams params_;
  std::unique_ptr<Impl> impl_;
};

/// T_a_b minimising sum |a_i - T_a_b b_i|^2 (Kabsch / Umeyama without scale); needs >= 3
/// non-collinear pairs. Exposed for tests.
SE3 fit_rigid(const std::vector<Vec3>& a, const std::vector<Vec3>& b);

/// A candidate pose verified by tracking (RelocaliserParams::verify_rounds).
struct TrackingVerification {
  SE3 T_world_cam;            ///< the last round's estimate
  AlignmentResult alignment;  ///< the last round's (its gates are the verdict)
  int rounds = 0;             ///< rounds run
  bool ok() const { return !alignment.failed && !alignment.weak; }
};
/// One round: the frame tracked against the map rendered at T_world_ref (T_ref_cam: the estimate
/// in that reference's frame).
using TrackFrom = std::function<AlignmentResult(const SE3& T_world_ref)>;
/// Verifies `T_world_guess` in up to `rounds` rounds of `track_from` (RelocaliserParams::
/// verify_rounds; `gates` gives the no-progress step and the jump limits). Stops at the first OK
/// round.
TrackingVerification verify_by_tracking(const SE3& T_world_guess, int rounds,
                                        const TrackerParams& gates, const TrackFrom& track_from);

}  // namespace orpe::slam
