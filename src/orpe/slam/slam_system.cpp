#include "orpe/slam/slam_system.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>

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
  if (!(prediction_surface_band_m >= 0 && prediction_surface_band_m <= 1)) {
    if (why) *why = "prediction_surface_band_m must be in [0, 1]";
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
  if (!loop.IsValid(&w)) {
    if (why) *why = "slam_loop: " + w;
    return false;
  }
  return true;
}

std::string SlamFrameResult::report() const {
  return fmt::format(
      "frame {:5d} {:<8} inliers {:6d} ({:4.2f}) icp_rms {:6.4f} m rgb_rms {:5.2f} gain {:5.3f} "
      "it {:2d} "
      "overlap {:4.2f} agree {:4.2f} front {:5.3f} behind {:5.3f} step {:.1e} | +{} ~{} -{} "
      "merged {} surfels {} | {:5.1f} ms (pre {:4.1f} pred {:4.1f} track {:5.1f} fuse {:5.1f}){}{}",
      frame_index, to_string(status), icp_inliers, inlier_fraction, icp_rms_m, rgb_rms, rgb_gain,
      iterations, overlap_fraction, consistent_fraction, in_front_fraction, behind_fraction,
      final_step, fusion.created, fusion.updated,
      fusion.removed_unstable + fusion.removed_free_space, fusion.merged, fusion.surfels, total_ms,
      preprocess_ms, predict_ms, track_ms, fuse_ms, reason.empty() ? "" : " | ", reason);
}

SlamSystem::SlamSystem(const SlamParams& params)
    : params_(params),
      // With fusion at a coarser level, only the tracker reads level-0 normals, at its pixel step.
      preprocessor_(params.preprocess,
                    params.fusion.fusion_level > 0 ? params.tracker.level0_pixel_step : 1),
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

void SlamSystem::predict(const SE3& T_world_cam, std::int32_t now, std::int32_t seen_until) {
  RenderOptions opt;
  opt.min_confidence = static_cast<float>(params_.fusion.stable_confidence);
  // Unstable surfels of the last fused frame (not of the previous frame: after frames that were
  // not fused -- no depth, LOST -- those would be none, and the young map too sparse to
  // re-acquire).
  opt.also_seen_since =
      (params_.options.track_recent_unstable || fused_frames_ < 15) ? last_fused_time_ : -1;
  opt.active_window_frames = params_.fusion.active_window_frames;
  if (seen_until < now) {  // the old map only, inactive or not
    opt.seen_until = seen_until;
    opt.also_seen_since = -1;
    opt.active_window_frames = 0;
  }
  opt.now = now;
  opt.far_m = static_cast<float>(params_.preprocess.max_depth_m);
  opt.radius_scale = static_cast<float>(params_.options.prediction_radius_scale);
  opt.want_surfel_centre = true;
  opt.surface_band_m = static_cast<float>(params_.options.prediction_surface_band_m);
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
  res.rgb_gain = a.rgb_gain;
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
  std::string rejected;  // why each candidate failed its verification
  for (const RelocCandidate& c : candidates) {
    const TrackingVerification v = verify_by_tracking(c.T_world_cam, params_.reloc.verify_rounds,
                                                      params_.tracker, [&](const SE3& T_world_ref) {
                                                        predict(T_world_ref, now);
                                                        return align_into(SE3(), res);
                                                      });
    if (!v.ok()) {
      rejected +=
          fmt::format("; keyframe {} ({} of {} matches inliers, {} rounds): {}",
                      c.keyframe_frame_index, c.inliers, c.matches, v.rounds, v.alignment.reason);
      continue;
    }
    T_world_cam_ = v.T_world_cam;
    res.tracked_T_world_cam = T_world_cam_;
    res.relocalised = true;
    res.reloc_keyframe = c.keyframe_frame_index;
    res.reason =
        fmt::format("relocalised against keyframe {} ({} of {} matches inliers, {} rounds)",
                    c.keyframe_frame_index, c.inliers, c.matches, v.rounds);
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
    res.reason +=
        fmt::format(" | relocalisation: none of {} candidate poses verified{}", tried, rejected);
  res.reloc_ms += ms_since(t);
  return false;
}

SE3 SlamSystem::loop_correction(std::int32_t time) const {
  if (time < 0 || time >= static_cast<std::int32_t>(frame_node_.size())) return SE3();
  const int n = frame_node_[static_cast<size_t>(time)];
  return n >= 0 && n < static_cast<int>(node_correction_.size())
             ? node_correction_[static_cast<size_t>(n)]
             : SE3();
}

void SlamSystem::record_frame(std::int32_t now, bool fused) {
  if (static_cast<std::int32_t>(frame_pose_.size()) != now)
    throw std::logic_error("SlamSystem: frame records out of step");
  frame_pose_.push_back(T_world_cam_);
  if (fused) {
    if (!node_pose_.empty())
      odometry_.push_back(node_pose_.back().inverse() * T_world_cam_);
    else
      odometry_.push_back(SE3());
    node_pose_.push_back(T_world_cam_);
    node_time_.push_back(now);
  }
  const int node = static_cast<int>(node_pose_.size()) - 1;
  frame_node_.push_back(node);
  T_node_frame_.push_back(node >= 0 ? node_pose_.back().inverse() * T_world_cam_ : SE3());
}

bool SlamSystem::try_close_loop(std::int32_t now, SlamFrameResult& res) {
  const LoopClosureParams& lp = params_.loop;
  const std::int32_t old_until = now - lp.min_age_frames;
  const std::vector<RelocCandidate> candidates = relocaliser_.query(pyramid_.levels[0], old_until);
  res.loop_candidates = static_cast<int>(candidates.size());
  if (candidates.empty()) return false;
  const int cur = static_cast<int>(node_pose_.size()) - 1;  // this frame's node
  const bool prev_at_pose = prev_frame_at_pose_;
  prev_frame_at_pose_ = false;  // the photometric reference is not at a candidate pose
  bool closed = false;
  for (const RelocCandidate& c : candidates) {
    const auto kn_it = std::lower_bound(node_time_.begin(), node_time_.end(), c.keyframe_time);
    if (kn_it == node_time_.end() || *kn_it != c.keyframe_time) continue;
    const int kn = static_cast<int>(kn_it - node_time_.begin());
    predict(c.T_world_cam, now, old_until);
    const AlignmentResult a = tracker_.align(pyramid_, model_, SE3());
    if (a.failed || a.weak) continue;
    const SE3 T_old = c.T_world_cam * a.T_ref_cam;  // this camera in the old map's frame
    const double dm = (T_old.translation() - T_world_cam_.translation()).norm();
    const double ddeg =
        rotation_distance_rad(T_old.rotation(), T_world_cam_.rotation()) * 180.0 / M_PI;
    if (dm > lp.max_correction_m || ddeg > lp.max_correction_deg) continue;
    if (dm < lp.min_correction_m && ddeg < lp.min_correction_deg) break;  // already consistent
    loop_edges_.push_back(
        {kn, cur, node_pose_[static_cast<size_t>(kn)].inverse() * T_old, lp.loop_weight});
    std::vector<PoseGraphEdge> edges;
    edges.reserve(node_pose_.size() + loop_edges_.size());
    for (size_t k = 1; k < node_pose_.size(); ++k)
      edges.push_back({static_cast<int>(k) - 1, static_cast<int>(k), odometry_[k], 1.0});
    edges.insert(edges.end(), loop_edges_.begin(), loop_edges_.end());
    const std::vector<SE3> before = node_pose_;
    PoseGraphOptions go;
    go.iterations = lp.iterations;
    go.sigma_translation_m = lp.odometry_sigma_m;
    go.sigma_rotation_rad = lp.odometry_sigma_rad;
    optimise_pose_graph(node_pose_, edges, go);
    node_correction_.resize(node_pose_.size());
    for (size_t k = 0; k < node_pose_.size(); ++k)
      node_correction_[k] = node_pose_[k] * before[k].inverse();
    // Odometry measurements stay what tracking measured; the frames, surfels and keyframes follow
    // the node they hang from.
    for (size_t f = 0; f < frame_pose_.size(); ++f)
      if (frame_node_[f] >= 0)
        frame_pose_[f] = node_pose_[static_cast<size_t>(frame_node_[f])] * T_node_frame_[f];
    const std::int32_t n_times = static_cast<std::int32_t>(frame_node_.size());
    for (size_t i = 0; i < map_.size(); ++i) {
      const std::int32_t t = std::clamp(map_.last_seen_time[i], std::int32_t{0}, n_times - 1);
      const int node = frame_node_[static_cast<size_t>(t)];
      if (node < 0) continue;
      const SE3& C = node_correction_[static_cast<size_t>(node)];
      map_.position_world[i] = (C * map_.position_world[i].cast<double>()).cast<float>();
      map_.normal_world[i] = (C.rotation() * map_.normal_world[i].cast<double>()).cast<float>();
    }
    relocaliser_.update_poses(
        [this](std::int32_t time, const SE3& T) { return loop_correction(time) * T; });
    T_world_cam_ = frame_pose_.back();
    // The old surfels this view sees are active again: tracking and fusion continue on them.
    predict(T_world_cam_, now, old_until);
    for (const std::int32_t idx : prediction_.surfel_index)
      if (idx >= 0) map_.last_seen_time[static_cast<size_t>(idx)] = now;
    ++loop_closures_;
    res.loop_closed = true;
    res.loop_keyframe = c.keyframe_frame_index;
    res.loop_correction_m = dm;
    res.loop_correction_deg = ddeg;
    res.reason = fmt::format(
        "loop closed with keyframe {} ({} of {} matches inliers): moved {:.3f} m "
        "{:.2f} deg",
        c.keyframe_frame_index, c.inliers, c.matches, dm, ddeg);
    closed = true;
    break;
  }
  prev_frame_at_pose_ = prev_at_pose;
  return closed;
}

SlamFrameResult SlamSystem::process_impl(const RgbdFrame& frame, const SE3* known_T_world_cam) {
  const auto t_start = std::chrono::steady_clock::now();
  SlamFrameResult res;
  res.frame_index = frame.index;
  check_intrinsics(frame);
  const std::int32_t now = frame_count_;
  const SE3 T_world_cam_before = T_world_cam_;

  const auto t = std::chrono::steady_clock::now();
  std::swap(pyramid_, prev_pyramid_);
  preprocessor_.process(frame, &pyramid_);
  res.preprocess_ms = ms_since(t);

  bool accept = true;
  if (too_little_depth(res)) {
    accept = false;
  } else if (!map_.empty()) {
    accept = track(now, known_T_world_cam != nullptr, res);
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
  fuse_frame(frame, now, fuse, res);
  record_frame(now, fuse);
  const LoopClosureParams& lp = params_.loop;
  if (lp.enabled && params_.reloc.enabled && !known_T_world_cam && fuse &&
      status_ == TrackingStatus::kOk && !res.relocalised && now >= lp.min_age_frames &&
      now % lp.detect_every_frames == 0) {
    const auto t_loop = std::chrono::steady_clock::now();
    try_close_loop(now, res);
    res.loop_ms = ms_since(t_loop);
    res.T_world_cam = T_world_cam_;
  }
  ++frame_count_;
  res.total_ms = ms_since(t_start);
  return res;
}

void SlamSystem::check_intrinsics(const RgbdFrame& frame) {
  if (frame_count_ == 0) {
    std::string why;
    if (!frame.intrinsics.IsValid(&why)) throw ConfigError("frame '" + frame.name + "': " + why);
    intrinsics_ = frame.intrinsics;
  } else if (!(frame.intrinsics == intrinsics_)) {
    throw ConfigError("frame '" + frame.name +
                      "': intrinsics or image size changed within the sequence");
  }
}

bool SlamSystem::too_little_depth(SlamFrameResult& res) {
  const DepthImage& depth0 = pyramid_.levels[0].depth;
  for (const float z : depth0) res.valid_depth_px += z > 0.0f;
  res.no_depth = res.valid_depth_px < params_.options.min_valid_depth_px ||
                 res.valid_depth_px <
                     params_.options.min_valid_depth_fraction * static_cast<double>(depth0.size());
  if (!res.no_depth) return false;
  // Nothing to align or fuse: hold the pose; the next frame with depth has to re-acquire (or,
  // before there is a map, starts it).
  res.reason =
      fmt::format("too little valid depth: {} of {} px in [{}, {}] m", res.valid_depth_px,
                  depth0.size(), params_.preprocess.min_depth_m, params_.preprocess.max_depth_m);
  if (!map_.empty()) status_ = TrackingStatus::kLost;
  ++bad_frames_;
  last_motion_ = SE3();
  res.tracked_T_world_cam = T_world_cam_;
  return true;
}

bool SlamSystem::track(std::int32_t now, bool known_pose, SlamFrameResult& res) {
  auto t = std::chrono::steady_clock::now();
  predict(T_world_cam_, now);
  res.predict_ms = ms_since(t);

  t = std::chrono::steady_clock::now();
  const SE3 init = (params_.tracker.constant_velocity && status_ != TrackingStatus::kLost)
                       ? last_motion_
                       : SE3();
  const AlignmentResult a = align_into(init, res);
  res.track_ms = ms_since(t);
  bool accept = true;
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
  if (!known_pose && !accept && status_ == TrackingStatus::kLost && params_.reloc.enabled &&
      try_relocalise(now, res)) {
    accept = true;
  } else if (known_pose) {
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
  return accept;
}

void SlamSystem::fuse_frame(const RgbdFrame& frame, std::int32_t now, bool fuse,
                            SlamFrameResult& res) {
  if (!fuse) {
    pixel_surfel_ = IndexImage();
    res.fusion.surfels = map_.size();
    return;
  }
  auto t = std::chrono::steady_clock::now();
  // The colours at the map's brightness: the tracker's gain (1 for the first frame; against the
  // previous frame the gain is not the map's).
  const bool map_gain = !params_.options.rgb_against_previous_frame;
  res.fusion = fusion_.fuse(pyramid_, T_world_cam_, now, &map_, &pixel_surfel_,
                            map_gain ? static_cast<float>(res.rgb_gain) : 1.0f);
  res.fuse_ms = ms_since(t);
  res.fused = true;
  last_fused_time_ = now;
  ++fused_frames_;
  if (params_.reloc.enabled && status_ == TrackingStatus::kOk) {
    t = std::chrono::steady_clock::now();
    relocaliser_.maybe_add(pyramid_.levels[0], T_world_cam_, frame.index, now);
    res.reloc_ms += ms_since(t);
  }
}

}  // namespace orpe::slam
