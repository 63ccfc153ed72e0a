#include "orpe/slam/slam_system.h"

#include <fmt/format.h>

#include <chrono>

#include "orpe/core/error.h"

namespace orpe::slam {
namespace {

double ms_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t).count();
}

}  // namespace

const char* to_string(TrackingStatus s) {
  switch (s) {
    case TrackingStatus::kOk:
      return "OK";
    case TrackingStatus::kDegraded:
      return "DEGRADED";
    case TrackingStatus::kLost:
      return "LOST";
  }
  return "?";
}

bool SlamOptions::IsValid(std::string* why) const {
  if (reserve_surfels < 0) {
    if (why) *why = "reserve_surfels must be >= 0";
    return false;
  }
  if (prediction_level < 0 || prediction_level > 2) {
    if (why) *why = "prediction_level must be 0, 1 or 2";
    return false;
  }
  if (!(prediction_radius_scale >= 0.3 && prediction_radius_scale <= 2.0)) {
    if (why) *why = "prediction_radius_scale must be in [0.3, 2]";
    return false;
  }
  if (!(min_valid_depth_fraction >= 0 && min_valid_depth_fraction <= 1) || min_valid_depth_px < 0) {
    if (why) *why = "need min_valid_depth_fraction in [0, 1] and min_valid_depth_px >= 0";
    return false;
  }
  return true;
}

bool SlamParams::IsValid(std::string* why) const {
  std::string w;
  if (!preprocess.IsValid(&w)) {
    if (why) *why = "slam_preprocess: " + w;
    return false;
  }
  if (!tracker.IsValid(&w)) {
    if (why) *why = "slam_tracking: " + w;
    return false;
  }
  if (!fusion.IsValid(&w)) {
    if (why) *why = "slam_fusion: " + w;
    return false;
  }
  if (!options.IsValid(&w)) {
    if (why) *why = "slam: " + w;
    return false;
  }
  if (!reloc.IsValid(&w)) {
    if (why) *why = "slam_reloc: " + w;
    return false;
  }
  return true;
}

std::string SlamFrameResult::report() const {
  return fmt::format(
      "frame {:5d} {:<8} inliers {:6d} ({:4.2f}) icp_rms {:6.4f} m rgb_rms {:5.2f} it {:2d} "
      "overlap {:4.2f} agree {:4.2f} front {:5.3f} behind {:5.3f} step {:.1e} | +{} ~{} -{} "
      "merged {} surfels {} | {:5.1f} ms (pre {:4.1f} pred {:4.1f} track {:5.1f} fuse {:5.1f}){}{}",
      frame_index, to_string(status), icp_inliers, inlier_fraction, icp_rms_m, rgb_rms, iterations,
      overlap_fraction, consistent_fraction, in_front_fraction, behind_fraction, final_step,
      fusion.created, fusion.updated, fusion.removed_unstable + fusion.removed_free_space,
      fusion.merged, fusion.surfels, total_ms, preprocess_ms, predict_ms, track_ms, fuse_ms,
      reason.empty() ? "" : " | ", reason);
}

SlamSystem::SlamSystem(const SlamParams& params)
    : params_(params),
      preprocessor_(params.preprocess),
      tracker_(params.tracker),
      fusion_(params.fusion),
      relocaliser_(params.reloc) {
  std::string why;
  if (!params_.IsValid(&why)) throw ConfigError(why);
  map_.reserve(static_cast<size_t>(params_.options.reserve_surfels));
}

SlamFrameResult SlamSystem::process(const RgbdFrame& frame) {
  return process_impl(frame, nullptr);
}

SlamFrameResult SlamSystem::process_at_known_pose(const RgbdFrame& frame, const SE3& T_world_cam) {
  return process_impl(frame, &T_world_cam);
}

void SlamSystem::predict(const SE3& T_world_cam, std::int32_t now) {
  RenderOptions opt;
  opt.min_confidence = static_cast<float>(params_.fusion.stable_confidence);
  // Unstable surfels of the last fused frame (not of the previous frame: after frames that were
  // not fused -- no depth, LOST -- those would be none, and the young map too sparse to re-acquire).
  opt.also_seen_since =
      (params_.options.track_recent_unstable || fused_frames_ < 15) ? last_fused_time_ : -1;
  opt.active_window_frames = params_.fusion.active_window_frames;
  opt.now = now;
  opt.far_m = static_cast<float>(params_.preprocess.max_depth_m);
  opt.radius_scale = static_cast<float>(params_.options.prediction_radius_scale);
  opt.want_surfel_centre = true;
  const int pl = std::min(params_.options.prediction_level, params_.preprocess.pyramid_levels - 1);
  const PinholeIntrinsics K_pred = intrinsics_.scaled(pl);
  predict_renderer_.render(map_, T_world_cam, K_pred, opt, &prediction_);
  build_model_pyramid(prediction_, K_pred, params_.preprocess.pyramid_levels - pl,
                      static_cast<float>(params_.preprocess.pyramid_max_depth_jump_m), &model_, pl);
  if (params_.options.rgb_against_previous_frame && prev_frame_at_pose_) {
    // The previous frame was taken at the reference pose: its intensities and vertices are the
    // photometric reference, in the same (reference camera) frame as the rendered model.
    for (size_t k = 0; k < model_.levels.size(); ++k) {
      const FrameLevel& P = prev_pyramid_.levels[k + static_cast<size_t>(pl)];
      model_.levels[k].intensity = P.intensity;
      model_.levels[k].color_point = P.vertex;
    }
  }
}

AlignmentResult SlamSystem::align_into(const SE3& init, SlamFrameResult& res) {
  const AlignmentResult a = tracker_.align(pyramid_, model_, init);
  res.icp_inliers = a.icp_inliers;
  res.inlier_fraction = a.icp_overlap > 0 ? double(a.icp_inliers) / a.icp_overlap : 0.0;
  res.icp_rms_m = a.icp_rms_m;
  res.rgb_rms = a.rgb_rms;
  res.iterations = a.iterations;
  res.overlap_fraction = a.overlap_fraction;
  res.consistent_fraction = a.consistent_fraction;
  res.in_front_fraction = a.in_front_fraction;
  res.behind_fraction = a.behind_fraction;
  res.final_step = a.final_step;
  res.reason = a.reason;
  return a;
}

bool SlamSystem::try_relocalise(std::int32_t now, SlamFrameResult& res) {
  const auto t = std::chrono::steady_clock::now();
  const SlamFrameResult lost = res;  // the figures of the failed alignment, kept if none verifies
  const std::vector<RelocCandidate> candidates = relocaliser_.query(pyramid_.levels[0]);
  res.reloc_candidates = static_cast<int>(candidates.size());
  // The photometric reference of the previous frame is not at a candidate pose.
  const bool prev_at_pose = prev_frame_at_pose_;
  prev_frame_at_pose_ = false;
  for (const RelocCandidate& c : candidates) {
    predict(c.T_world_cam, now);
    const AlignmentResult a = align_into(SE3(), res);
    if (a.failed || a.weak) continue;
    T_world_cam_ = c.T_world_cam * a.T_ref_cam;
    res.tracked_T_world_cam = T_world_cam_;
    res.relocalised = true;
    res.reloc_keyframe = c.keyframe_frame_index;
    res.reason = fmt::format("relocalised against keyframe {} ({} of {} matches inliers)",
                             c.keyframe_frame_index, c.inliers, c.matches);
    status_ = TrackingStatus::kOk;
    bad_frames_ = 0;
    res.reloc_ms += ms_since(t);
    return true;
  }
  prev_frame_at_pose_ = prev_at_pose;
  const int tried = res.reloc_candidates;
  res = lost;
  res.reloc_candidates = tried;
  if (tried > 0)
    res.reason += fmt::format(" | relocalisation: none of {} candidate poses verified", tried);
  res.reloc_ms += ms_since(t);
  return false;
}

SlamFrameResult SlamSystem::process_impl(const RgbdFrame& frame, const SE3* known_T_world_cam) {
  const auto t_start = std::chrono::steady_clock::now();
  SlamFrameResult res;
  res.frame_index = frame.index;
  if (frame_count_ == 0) {
    std::string why;
    if (!frame.intrinsics.IsValid(&why)) throw ConfigError("frame '" + frame.name + "': " + why);
    intrinsics_ = frame.intrinsics;
  } else if (!(frame.intrinsics == intrinsics_)) {
    throw ConfigError("frame '" + frame.name +
                      "': intrinsics or image size changed within the sequence");
  }
  const std::int32_t now = frame_count_;
  const SE3 T_world_cam_before = T_world_cam_;

  auto t = std::chrono::steady_clock::now();
  std::swap(pyramid_, prev_pyramid_);
  preprocessor_.process(frame, &pyramid_);
  res.preprocess_ms = ms_since(t);

  const DepthImage& depth0 = pyramid_.levels[0].depth;
  for (const float z : depth0) res.valid_depth_px += z > 0.0f;
  res.no_depth = res.valid_depth_px < params_.options.min_valid_depth_px ||
                 res.valid_depth_px <
                     params_.options.min_valid_depth_fraction * static_cast<double>(depth0.size());
  bool accept = true;
  if (res.no_depth) {
    // Nothing to align or fuse: hold the pose; the next frame with depth has to re-acquire (or,
    // before there is a map, starts it).
    res.reason =
        fmt::format("too little valid depth: {} of {} px in [{}, {}] m", res.valid_depth_px,
                    depth0.size(), params_.preprocess.min_depth_m, params_.preprocess.max_depth_m);
    if (!map_.empty()) status_ = TrackingStatus::kLost;
    ++bad_frames_;
    accept = false;
    last_motion_ = SE3();
    res.tracked_T_world_cam = T_world_cam_;
  } else if (!map_.empty()) {
    t = std::chrono::steady_clock::now();
    predict(T_world_cam_, now);
    res.predict_ms = ms_since(t);

    t = std::chrono::steady_clock::now();
    const SE3 init = (params_.tracker.constant_velocity && status_ != TrackingStatus::kLost)
                         ? last_motion_
                         : SE3();
    const AlignmentResult a = align_into(init, res);
    res.track_ms = ms_since(t);
    if (a.failed) {
      ++bad_frames_;
      status_ = TrackingStatus::kLost;
      accept = false;
    } else if (a.weak) {
      ++bad_frames_;
      if (status_ == TrackingStatus::kLost) {
        accept = false;  // re-acquire only on a good alignment
        res.reason = "still lost: " + a.reason;
      } else if (bad_frames_ > params_.tracker.max_bad_frames) {
        status_ = TrackingStatus::kLost;
        accept = false;
        res.reason = std::to_string(bad_frames_) + " degraded frames in a row: " + a.reason;
      } else {
        status_ = TrackingStatus::kDegraded;
      }
    } else {
      bad_frames_ = 0;
      status_ = TrackingStatus::kOk;
    }
    res.tracked_T_world_cam = T_world_cam_ * a.T_ref_cam;
    if (!known_T_world_cam && !accept && status_ == TrackingStatus::kLost &&
        params_.reloc.enabled && try_relocalise(now, res)) {
      accept = true;
    } else if (known_T_world_cam) {
      // Mapping with known poses: the alignment is only reported; the frame is fused at the given
      // pose.
      accept = true;
      if (status_ == TrackingStatus::kLost) status_ = TrackingStatus::kDegraded;
    }
    if (res.relocalised) {
      last_motion_ = SE3();
    } else if (accept) {
      T_world_cam_ = T_world_cam_ * a.T_ref_cam;
      last_motion_ = a.T_ref_cam;
    } else {
      last_motion_ = SE3();
    }
  } else {
    status_ = TrackingStatus::kOk;
  }
  if (known_T_world_cam) {
    T_world_cam_ = *known_T_world_cam;
    last_motion_ = T_world_cam_before.inverse() * T_world_cam_;
    if (map_.empty()) res.tracked_T_world_cam = T_world_cam_;
  } else if (map_.empty()) {
    res.tracked_T_world_cam = T_world_cam_;
  }
  res.status = res.no_depth ? TrackingStatus::kLost : status_;
  res.T_world_cam = T_world_cam_;

  prev_frame_at_pose_ = accept;
  const bool fuse =
      accept && (status_ == TrackingStatus::kOk ||
                 (status_ == TrackingStatus::kDegraded && params_.options.fuse_degraded));
  if (fuse) {
    t = std::chrono::steady_clock::now();
    res.fusion = fusion_.fuse(pyramid_, T_world_cam_, now, &map_, &pixel_surfel_);
    res.fuse_ms = ms_since(t);
    res.fused = true;
    last_fused_time_ = now;
    ++fused_frames_;
    if (params_.reloc.enabled && status_ == TrackingStatus::kOk) {
      t = std::chrono::steady_clock::now();
      relocaliser_.maybe_add(pyramid_.levels[0], T_world_cam_, frame.index);
      res.reloc_ms += ms_since(t);
    }
  } else {
    pixel_surfel_ = IndexImage();
    res.fusion.surfels = map_.size();
  }
  ++frame_count_;
  res.total_ms = ms_since(t_start);
  return res;
}

}  // namespace orpe::slam
