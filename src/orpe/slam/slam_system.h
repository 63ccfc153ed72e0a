// Dense surfel SLAM on the CPU (ElasticFusion without loop closure): per frame, preprocessing,
// frame-to-model tracking against the map rendered at the previous pose, and surfel fusion.
//
// Tracking states:
//  - OK: the alignment passed every quality gate; the pose is updated and the frame fused.
//  - DEGRADED: usable but weak (low inlier fraction, high residual or degenerate geometry); the
//  pose is
//    updated and the frame fused. More than TrackerParams::max_bad_frames in a row -> LOST.
//  - LOST: the alignment failed (or too many degraded frames), or the frame had too little valid
//  depth
//    (SlamFrameResult::no_depth; also on the first frames, before there is a map). The system holds
//    its last good pose, does not fuse, and tries each following frame against the map rendered at
//    that pose; the first frame that aligns well (OK) re-acquires tracking.
//
// Hook for later stages (semantic mapping): call process(), then read/write map() (indices valid
// until the next process()), use renderer() to render the map at any pose, and last_pixel_surfel()
// for which surfel each pixel of the frame updated or created.
#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "orpe/core/frame.h"
#include "orpe/core/se3.h"
#include "orpe/slam/fusion.h"
#include "orpe/slam/loop_closure.h"
#include "orpe/slam/map_renderer.h"
#include "orpe/slam/pose_graph.h"
#include "orpe/slam/preprocess.h"
#include "orpe/slam/relocaliser.h"
#include "orpe/slam/surfel_map.h"
#include "orpe/slam/tracker.h"

namespace orpe::slam {

enum class TrackingStatus { kOk, kDegraded, kLost };
const char* to_string(TrackingStatus s);

/// System-level options (the stage Params are separate config sections).
struct SlamOptions {
  /// Track unstable surfels that the last fused frame created or updated, in addition to stable
  /// ones (otherwise new parts of the scene are unusable for ~10 frames).
  bool track_recent_unstable = true;
  /// Initial surfel capacity reserved (surfels), to avoid reallocations.
  int reserve_surfels = 500000;
  /// Fuse frames whose tracking is DEGRADED (ElasticFusion fuses every frame that is not lost).
  bool fuse_degraded = true;
  /// Splat radius scale of the model prediction used for tracking (1 = ElasticFusion).
  double prediction_radius_scale = 1.0;
  /// Pyramid level at which the model prediction is rendered: 0 = full resolution (ElasticFusion),
  /// 1 = half (4x fewer pixels to splat; full-resolution frame pixels are aligned against it).
  int prediction_level = 1;
  /// Photometric term against the previous frame's intensities and depth (as DVO / OpenCV's
  /// RgbdOdometry) instead of the colours rendered from the map (ElasticFusion). Useful when colour
  /// and depth are not registered (7-Scenes), which blurs the map's colours.
  bool rgb_against_previous_frame = false;
  /// A frame with fewer full-resolution pixels of valid depth in [min_depth_m, max_depth_m] than
  /// this fraction of its pixels, or than min_valid_depth_px, is not tracked nor fused
  /// (SlamFrameResult::no_depth).
  double min_valid_depth_fraction = 0.02;
  int min_valid_depth_px = 100;
  /// The tracking prediction's surface band (m; RenderOptions::surface_band_m): a pixel shows,
  /// among the discs within this depth of the nearest, the one whose centre is nearest the pixel,
  /// not the nearest disc, which among noisy recent surfels is biased towards the camera and
  /// biases tracking (docs/SLAM.md, "Session 23: the tracking prediction's surface band").
  /// Default: fusion's association window (FusionParams::assoc_max_depth_diff_m, 0.05 m), the
  /// depth range fusion treats as one surface. 0 = the nearest disc (ElasticFusion).
  double prediction_surface_band_m = 0.05;

  template <class V>
  void visit(V&& v) {
    v("track_recent_unstable", track_recent_unstable,
      "Track against unstable surfels seen by the last fused frame too (else stable ones only)");
    v("reserve_surfels", reserve_surfels, "Surfel capacity reserved up front");
    v("fuse_degraded", fuse_degraded, "Fuse frames whose tracking is DEGRADED");
    v("prediction_radius_scale", prediction_radius_scale,
      "Splat radius scale of the tracking prediction (1 = EF; < 1 trims disc overhang at depth "
      "edges)");
    v("prediction_level", prediction_level,
      "Resolution level of the tracking prediction: 0 = full (EF), 1 = half (faster)");
    v("rgb_against_previous_frame", rgb_against_previous_frame,
      "Photometric term against the previous frame (intensity + depth) instead of the map's "
      "colours (EF)");
    v("min_valid_depth_fraction", min_valid_depth_fraction,
      "Frames with less valid depth (in range) than this fraction of their pixels are not tracked "
      "(LOST)");
    v("min_valid_depth_px", min_valid_depth_px, "... or than this many pixels");
    v("prediction_surface_band_m", prediction_surface_band_m,
      "Tracking prediction: among discs within this depth (m) of the nearest, the one centred "
      "nearest the pixel wins (default 0.05, fusion's association window); 0 = the nearest disc "
      "(EF)");
  }
  bool IsValid(std::string* why) const;
};

struct SlamParams {
  PreprocessParams preprocess;
  TrackerParams tracker;
  FusionParams fusion;
  SlamOptions options;
  RelocaliserParams reloc;  ///< relocalisation of a LOST camera (config section slam_reloc)
  LoopClosureParams
      loop;  ///< loop closure (config section slam_loop; needs slam_reloc's keyframes)
  bool IsValid(std::string* why) const;
};

/// Per-frame result.
struct SlamFrameResult {
  int frame_index = 0;  ///< RgbdFrame::index
  TrackingStatus status = TrackingStatus::kOk;
  SE3 T_world_cam;  ///< the pose after this frame (held pose when LOST)
  /// What the alignment of this frame gave (also when it was not accepted); with
  /// process_at_known_pose() the tracking estimate to compare with the known pose.
  SE3 tracked_T_world_cam;
  bool fused = false;
  std::string reason;  ///< why DEGRADED / LOST
  int icp_inliers = 0;
  double inlier_fraction = 0;
  double icp_rms_m = 0;
  double rgb_rms = 0;
  double rgb_gain = 1;  ///< the map's brightness over the frame's (AlignmentResult::rgb_gain)
  int iterations = 0;
  double overlap_fraction = 0;     ///< self-check (AlignmentResult)
  double consistent_fraction = 0;  ///< self-check (AlignmentResult)
  double in_front_fraction = 0;    ///< self-check (AlignmentResult): free-space violations
  double behind_fraction = 0;      ///< self-check (AlignmentResult)
  double final_step = 0;
  /// Too little valid depth in range (SlamOptions::min_valid_depth_fraction): not tracked, not
  /// fused.
  bool no_depth = false;
  /// The camera was LOST and was found again by relocalisation on this frame (RelocaliserParams):
  /// the candidate from keyframe `reloc_keyframe` passed the tracker's gates from there.
  bool relocalised = false;
  int reloc_keyframe = -1;   ///< RgbdFrame::index of that keyframe
  int reloc_candidates = 0;  ///< candidate poses tried on this frame (0 = none proposed)
  /// Loop closure on this frame (LoopClosureParams): a revisit of keyframe `loop_keyframe` was
  /// verified and the trajectory and map corrected; the current pose moved by
  /// loop_correction_m / loop_correction_deg (T_world_cam is the corrected pose).
  bool loop_closed = false;
  int loop_keyframe = -1;   ///< RgbdFrame::index of the revisited keyframe
  int loop_candidates = 0;  ///< candidate revisits tried on this frame
  double loop_correction_m = 0, loop_correction_deg = 0;
  int valid_depth_px = 0;  ///< level-0 pixels with depth in [min_depth_m, max_depth_m]
  FusionStats fusion;
  // Stage timings, milliseconds.
  double preprocess_ms = 0, predict_ms = 0, track_ms = 0, fuse_ms = 0, reloc_ms = 0, loop_ms = 0,
         total_ms = 0;
  std::string report() const;
};

class SlamSystem {
 public:
  explicit SlamSystem(const SlamParams& params = {});

  /// Sets the pose of the first frame (default identity). Call before the first process().
  void set_initial_pose(const SE3& T_world_cam0) { T_world_cam_ = T_world_cam0; }
  /// Tracks and fuses one frame. Throws ConfigError when the frame's size or intrinsics change.
  SlamFrameResult process(const RgbdFrame& frame);
  /// Mapping with known poses (motion capture, a ground-truth trajectory): tracks the frame as
  /// process() does, from the previous pose, and reports that alignment in tracked_T_world_cam, but
  /// fuses the frame at `T_world_cam` and continues from it. The status still reports the
  /// alignment's quality (never LOST: the pose is known).
  SlamFrameResult process_at_known_pose(const RgbdFrame& frame, const SE3& T_world_cam);

  const SE3& T_world_cam() const { return T_world_cam_; }
  SurfelMap& map() { return map_; }
  const SurfelMap& map() const { return map_; }
  MapRenderer& renderer() { return renderer_; }
  const SlamParams& params() const { return params_; }
  /// Frames processed so far (the map's time stamps count these).
  std::int32_t frame_count() const { return frame_count_; }
  /// Frame counter of the last process() (the `now` of its surfel updates).
  std::int32_t last_time() const { return frame_count_ - 1; }
  /// Preprocessed last frame. With slam_fusion.fusion_level > 0 (the realtime preset) level 0's
  /// normals are computed only at the tracker's level0_pixel_step (the other pixels are zero):
  /// nothing else reads them then (FramePreprocessor, `level0_normal_step`).
  const FramePyramid& last_frame() const { return pyramid_; }
  /// Per pixel of the last frame: surfel it updated or created, -1 none (empty if not fused).
  const IndexImage& last_pixel_surfel() const { return pixel_surfel_; }
  TrackingStatus status() const { return status_; }
  /// Keyframes stored for relocalisation so far.
  size_t keyframes() const { return relocaliser_.size(); }
  /// T_world_cam of every frame processed so far, by frame counter (index = the frame's time),
  /// corrected by every loop closure since (the per-frame results keep the pose as it was then).
  const std::vector<SE3>& trajectory() const { return frame_pose_; }
  /// Loop closures applied so far.
  int loop_closures() const { return loop_closures_; }
  /// The world-frame correction the last loop closure applied to what frame `time` placed in the
  /// world (a pose, a surfel, an object): new = loop_correction(time) * old. Identity when none.
  SE3 loop_correction(std::int32_t time) const;

 private:
  SlamFrameResult process_impl(const RgbdFrame& frame, const SE3* known_T_world_cam);
  // The steps of process_impl, in order.
  /// The first frame's intrinsics are the sequence's; a later frame must have the same (else
  /// ConfigError naming the frame).
  void check_intrinsics(const RgbdFrame& frame);
  /// Counts the preprocessed frame's valid depth; too little: the frame is LOST (with a map),
  /// the pose held, and true returned.
  bool too_little_depth(SlamFrameResult& res);
  /// Predicts the map at the current pose and aligns the frame (relocalising a LOST camera);
  /// updates the status and the pose. Returns whether the frame may be fused (with a known pose:
  /// always; the caller then sets the pose).
  bool track(std::int32_t now, bool known_pose, SlamFrameResult& res);
  /// Fuses the frame at T_world_cam_ (and offers it to the relocaliser as a keyframe), or clears
  /// the pixel->surfel image when it is not fused.
  void fuse_frame(const RgbdFrame& frame, std::int32_t now, bool fuse, SlamFrameResult& res);
  /// Renders the map at T_world_cam into prediction_ / model_ (the tracking reference).
  /// `seen_until` < now renders only the surfels last seen at or before it, all of them active (the
  /// old part of the map, for loop verification).
  void predict(const SE3& T_world_cam, std::int32_t now,
               std::int32_t seen_until = std::numeric_limits<std::int32_t>::max());
  /// Aligns the current frame against model_ from `init`; copies the figures into `res`.
  AlignmentResult align_into(const SE3& init, SlamFrameResult& res);
  /// LOST: tries the relocaliser's candidates, each verified by an OK alignment from it. On
  /// success sets T_world_cam_, status_ OK and res.relocalised; returns whether it succeeded.
  bool try_relocalise(std::int32_t now, SlamFrameResult& res);
  /// Records the frame's pose (a pose-graph node when it was fused).
  void record_frame(std::int32_t now, bool fused);
  /// Loop detection, verification and correction on a fused OK frame; returns whether it closed.
  bool try_close_loop(std::int32_t now, SlamFrameResult& res);

  SlamParams params_;
  FramePreprocessor preprocessor_;
  Tracker tracker_;
  SurfelFusion fusion_;
  MapRenderer renderer_;  // for users
  MapRenderer predict_renderer_;
  Relocaliser relocaliser_;
  SurfelMap map_;
  FramePyramid pyramid_;
  FramePyramid prev_pyramid_;
  bool prev_frame_at_pose_ = false;  // the previous frame was accepted at T_world_cam_
  RenderedView prediction_;
  ModelPyramid model_;
  IndexImage pixel_surfel_;
  PinholeIntrinsics intrinsics_;
  SE3 T_world_cam_;
  SE3 last_motion_;  // T_prev_cur of the last accepted frame, for the constant-velocity guess
  std::int32_t frame_count_ = 0;
  std::int32_t last_fused_time_ = -1;  ///< time stamp (frame count) of the last fused frame
  int fused_frames_ = 0;
  int bad_frames_ = 0;
  TrackingStatus status_ = TrackingStatus::kOk;
  // Loop closure: per frame (by time) its pose, the node it hangs from (-1 none) and its pose in
  // that node's frame; per node (a fused frame) its pose and time; the loop edges; the last
  // closure's correction per node.
  std::vector<SE3> frame_pose_;
  std::vector<int> frame_node_;
  std::vector<SE3> T_node_frame_;
  std::vector<SE3> node_pose_;
  std::vector<std::int32_t> node_time_;
  std::vector<SE3> odometry_;  // odometry_[k] = T_{k-1}^-1 T_k when node k was added (k >= 1)
  std::vector<PoseGraphEdge> loop_edges_;
  std::vector<SE3> node_correction_;
  int loop_closures_ = 0;
};

}  // namespace orpe::slam
