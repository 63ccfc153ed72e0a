#include "orpe/pipeline/object_rpe.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <future>
#include <thread>
#include <tuple>

#include "orpe/core/error.h"
#include "orpe/nets/densefusion_estimator.h"
#include "orpe/nets/maskrcnn.h"
#include "orpe/pipeline/instance_tracks.h"
#include "orpe/pipeline/model_cache.h"
#include "orpe/pipeline/object_fusion.h"
#include "orpe/pose/colour_score.h"
#include "orpe/semantic/detection.h"

namespace orpe {
namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

/// Per object, what the skip rule needs of its last single-view estimate.
struct SkipState {
  bool last_accepted = false;  ///< the last estimate was valid and passed the EKF's gate
  SE3 T_world_cam;             ///< camera of the last estimate
  int skipped_in_a_row = 0;
};

/// PipelineParams::skip_*: the fused pose is confident (enough fused views, the last estimate
/// agreed with it) and the view unchanged (the camera barely moved since that estimate).
bool skip_estimate(const SkipState& s, int fused_views, const SE3& T_world_cam,
                   const PipelineParams& pp) {
  if (pp.skip_min_fused_views <= 0 || fused_views < pp.skip_min_fused_views || !s.last_accepted ||
      s.skipped_in_a_row >= pp.skip_max_consecutive)
    return false;
  const SE3 motion = s.T_world_cam.inverse() * T_world_cam;
  return motion.translation().norm() < pp.skip_max_translation_m &&
         motion.rotation_angle_deg() < pp.skip_max_rotation_deg;
}

/// An object's allowance of estimates in a row from the prior after a global search: doubled (up
/// to prior_max_consecutive_limit) when the filter took the measurement into its reported mode,
/// else back to prior_max_consecutive.
int backed_off_allowance(int allowance, bool agreed, const PipelineParams& pp) {
  const int base = pp.prior_max_consecutive;
  if (!agreed || base <= 0) return base;
  return std::min(2 * allowance, std::max(base, pp.prior_max_consecutive_limit));
}

/// The single-view estimate's score as the weight of its pose row and of its EKF measurement:
/// clamped to [0.01, 1] (a registration score can exceed 1; a valid estimate never weighs 0).
double single_view_weight(const SingleViewPose& sv) {
  return std::clamp(sv.score, 0.01, 1.0);
}

/// How far a map instance is confirmed to exist: detections / min_confirmed_detections, at most 1.
/// A per-frame row's score carries it, so that of two rows of one class in one image (a blob just
/// detected once, an object detected on every keyframe) the established object ranks first.
double existence_weight(int detections, int min_confirmed_detections) {
  if (min_confirmed_detections <= 1) return 1.0;
  return std::clamp(static_cast<double>(detections) / min_confirmed_detections, 0.0, 1.0);
}
}  // namespace

// ---------------------------------------------------------------------------------------------------
// Params

PoseVariant PoseVariant::from(const PipelineParams& p) {
  PoseVariant v;
  v.name = p.ablation_name();
  v.projected_mask = p.use_projected_mask;
  v.projected_depth = p.use_projected_depth;
  v.projected_color = p.use_projected_color;
  v.ekf = p.use_ekf;
  return v;
}

PoseVariant PoseVariant::named(const std::string& name) {
  PipelineParams p;
  p.apply_ablation(name);
  return from(p);
}

ObjectRpeParams ObjectRpeParams::from_config(const OrpeConfig& config) {
  ObjectRpeParams p;
  p.slam = config.slam_params();
  p.segmentation = config.segmentation;
  p.semantic = config.semantic;
  p.recognition = config.recognition;
  p.recognition_geometry = config.recognition_geometry;
  p.pose = config.pose;
  p.pose_registration = config.pose_registration;
  p.pose_ekf = config.pose_ekf;
  p.pipeline = config.pipeline;
  p.variants = {PoseVariant::from(config.pipeline)};
  return p;
}

bool ObjectRpeParams::IsValid(std::string* why) const {
  auto fail = [&](const std::string& section, const std::string& reason) {
    if (why) *why = section + ": " + reason;
    return false;
  };
  std::string r;
  if (!slam.IsValid(&r)) return fail("slam", r);
  if (!segmentation.IsValid(&r)) return fail("segmentation", r);
  if (!semantic.IsValid(&r)) return fail("semantic", r);
  if (!recognition.IsValid(&r)) return fail("recognition", r);
  if (!recognition_geometry.IsValid(&r)) return fail("recognition_geometry", r);
  if (!pose.IsValid(&r)) return fail("pose", r);
  if (!pose_registration.IsValid(&r)) return fail("pose_registration", r);
  if (!pose_ekf.IsValid(&r)) return fail("pose_ekf", r);
  if (!pipeline.IsValid(&r)) return fail("pipeline", r);
  if (!variants.empty() && !semantic_mapping)
    return fail("pipeline", "poses need the semantic map (semantic_mapping is off)");
  for (size_t i = 0; i < variants.size(); ++i)
    for (size_t j = i + 1; j < variants.size(); ++j)
      if (variants[i].name == variants[j].name)
        return fail("pipeline", "two pose variants are named '" + variants[i].name + "'");
  return true;
}

std::string PipelineFrameResult::report() const {
  std::string line = fmt::format("frame {:6d} {:<8}", frame_index, slam::to_string(slam.status));
  if (keyframe) line += fmt::format(" det {:2d} inst {:2d}", detections, instances);
  if (evaluated && !variants.empty()) {
    int valid = 0, reported = 0;
    for (const auto& o : variants.front()) {
      valid += o.single_view.valid;
      reported += o.reported;
    }
    line += fmt::format(" poses {:2d}/{:2d}", reported, static_cast<int>(variants.front().size()));
    if (valid != reported) line += fmt::format(" ({} single-view valid)", valid);
  }
  line += fmt::format(" | slam {:.0f}", slam_ms);
  if (semantic_ms > 0) line += fmt::format(" sem {:.0f}", semantic_ms);
  if (evaluated) line += fmt::format(" render {:.0f} pose {:.0f}", render_ms, single_view_ms);
  line += fmt::format(" total {:.0f} ms", total_ms);
  if (slam.status != slam::TrackingStatus::kOk && !slam.reason.empty()) line += " | " + slam.reason;
  return line;
}

// ---------------------------------------------------------------------------------------------------
// Pipeline state

struct ObjectRpePipeline::Track {
  int class_id = 0;
  std::unique_ptr<ObjectPoseFusion> ekf;  // EKF variants
  // Colour learned from the views at the fused pose (EKF variants, models without own colour).
  std::unique_ptr<ColourLearner> colour;
  // Best single-view estimate (variants without the EKF).
  bool have_best = false;
  double best_score = -1e9;
  SE3 best_T_world_obj;
  int valid_views = 0;
  SkipState skip;                    // EKF variants
  std::int32_t last_slam_time = -1;  // SLAM frame counter of the last view fused (loop closure)
  int prior_in_a_row = 0;   // estimates in a row from the prior (pipeline.prior_max_consecutive)
  int prior_allowance = 0;   // how many in a row may come from it (track_for starts it)
  // Score of its last global estimate that agreed with the fused mode: the reference a refined
  // prior's score is held to (pose_registration.prior_relative_fraction); 0 = none.
  double reference_score = 0;
};

struct ObjectRpePipeline::VariantState {
  PoseVariant config;
  std::map<int, Track> tracks;  // by instance id
  std::vector<PoseResultRow> rows;
  /// Per reported object of each evaluated frame: (frame index, T_world_cam, instance, class,
  /// score, time), for final_pose_rows().
  struct Seen {
    int frame_index;
    SE3 T_world_cam;
    int instance_id;
    int class_id;
    double score;
    double time_s;
    std::int32_t slam_time;  ///< SLAM frame counter (its pose follows loop closures)
  };
  std::vector<Seen> seen;
  std::vector<SingleViewRecord> records;
};

/// An object to estimate in this frame.
struct ObjectRpePipeline::Candidate {
  int instance_id = 0;
  int class_id = 0;
  double class_probability = 0;
  const MaskImage* mask = nullptr;
  int mask_px = 0;
  int object_key = 0;        // detection index (raw masks) or instance id (projected masks)
  bool report_only = false;  // too small for a single-view estimate: EKF variants report the state
  int detections = 1;        // keyframes that detected its map instance so far (1 without one)
};

ObjectRpePipeline::ObjectRpePipeline(const ObjectRpeParams& params, const DatasetInfo& dataset)
    : params_(params), dataset_(dataset), models_(dataset) {
  models_.set_colour_dir(params_.pipeline.model_colour_dir);
  models_.set_cache_dir(resolve_model_cache_dir(params_.pipeline.model_cache_dir));
  std::string why;
  if (!params_.IsValid(&why)) throw ConfigError("pipeline: " + why);
  slam_ = std::make_unique<slam::SlamSystem>(params_.slam);
  if (params_.semantic_mapping) {
    std::vector<int> class_ids;
    for (const auto& [id, name] : dataset_.class_names) class_ids.push_back(id);
    if (params_.segmentation.backend == "model")
      semantic_ = std::make_unique<SemanticMapper>(make_model_recognizer(), params_.segmentation,
                                                   params_.semantic);
    else if (params_.segmentation.backend == "maskrcnn")
      semantic_ = std::make_unique<SemanticMapper>(
          std::make_unique<nets::MaskRcnnSegmenter>(params_.segmentation, dataset_.class_names),
          params_.segmentation, params_.semantic);
    else
      semantic_ =
          std::make_unique<SemanticMapper>(params_.segmentation, params_.semantic, class_ids);
  }
  if (!params_.variants.empty() && params_.pose.backend == "densefusion") {
    // A learned estimator that uses the colour crop: PC and raw colour are different inputs.
    estimator_ = std::make_unique<nets::DenseFusionEstimator>(params_.pose, dataset_.class_names);
    estimator_uses_color_ = true;
  } else if (!params_.variants.empty()) {
    estimator_ = std::make_unique<ModelRegistrationEstimator>(params_.pose_registration);
    // The registration ranks confusable poses by colour (pose_registration.colour_enabled).
    estimator_uses_color_ = params_.pose_registration.colour.enabled;
  }
  for (const auto& v : params_.variants) {
    VariantState s;
    s.config = v;
    variants_.push_back(std::move(s));
  }
}

ObjectRpePipeline::~ObjectRpePipeline() = default;

std::unique_ptr<Segmenter> ObjectRpePipeline::make_model_recognizer() {
  std::vector<int> with_models;
  for (const auto& [id, path] : dataset_.model_points_paths) with_models.push_back(id);
  const std::vector<int> classes =
      resolve_model_classes(params_.segmentation.model_classes, dataset_.class_names, with_models);
  // Every candidate model is needed on the first keyframe: load them on all cores first.
  const auto t_load = Clock::now();
  models_.preload(classes, static_cast<int>(std::max(1u, std::thread::hardware_concurrency())));
  stats_.model_loading_ms += ms_since(t_load);
  std::vector<ObjectModel> models;
  for (int id : classes) models.push_back(models_.get(id));  // IoError names a bad model file
  return std::make_unique<ModelRecognizer>(params_.segmentation, params_.recognition,
                                           params_.recognition_geometry, std::move(models));
}

void ObjectRpePipeline::set_single_view_estimator(
    std::unique_ptr<SingleViewPoseEstimator> estimator, bool uses_color) {
  if (!estimator) throw ConfigError("pipeline: null single-view estimator");
  estimator_ = std::move(estimator);
  estimator_uses_color_ = uses_color;
}

size_t ObjectRpePipeline::num_variants() const {
  return variants_.size();
}
const PoseVariant& ObjectRpePipeline::variant(size_t v) const {
  return variants_.at(v).config;
}
const std::vector<ObjectRpePipeline::SingleViewRecord>& ObjectRpePipeline::single_view_records(
    size_t v) const {
  return variants_.at(v).records;
}
const std::vector<PoseResultRow>& ObjectRpePipeline::pose_rows(size_t v) const {
  return variants_.at(v).rows;
}

/// A keyframe waiting for its delay (pipeline.segmentation_delay_frames).
struct ObjectRpePipeline::PendingKeyframe {
  int due_frame = 0;  // stats_.frames at which it is fused
  std::shared_ptr<const RgbdFrame> frame;
  SE3 T_world_cam;
  std::future<std::vector<Detection>> detections;  // asynchronous: the worker's result
  std::shared_ptr<double> segment_ms;              // asynchronous: the back-end's time
};

void ObjectRpePipeline::set_segmenter(std::unique_ptr<Segmenter> segmenter) {
  if (!segmenter || !semantic_) throw ConfigError("pipeline: no segmenter, or no semantic mapping");
  if (stats_.frames > 0) throw ConfigError("pipeline: set_segmenter after the first frame");
  semantic_ = std::make_unique<SemanticMapper>(std::move(segmenter), params_.segmentation,
                                               params_.semantic);
}

const PipelineFrameResult& ObjectRpePipeline::process(const RgbdFrame& frame) {
  const auto t_frame = Clock::now();
  result_ = PipelineFrameResult{};
  result_.frame_index = frame.index;
  result_.timestamp_s = frame.timestamp_s;
  ++stats_.frames;

  if (first_frame_) {
    if (params_.pipeline.init_from_ground_truth && frame.T_world_cam_gt)
      slam_->set_initial_pose(*frame.T_world_cam_gt);
    first_frame_ = false;
  }
  auto t0 = Clock::now();
  result_.slam = slam_->process(frame);
  result_.slam_ms = ms_since(t0);
  const SE3 T_world_cam = slam_->T_world_cam();
  trajectory_.push_back({frame.timestamp_s, T_world_cam});
  if (result_.slam.loop_closed) {
    // The loop closure corrected every earlier pose (and the map's surfels, the objects' too).
    const std::vector<SE3>& corrected = slam_->trajectory();
    for (size_t k = 0; k < trajectory_.size() && k < corrected.size(); ++k)
      trajectory_[k].T_world_cam = corrected[k];
    stats_.loop_closures.emplace_back(frame.index, result_.slam.loop_keyframe);
    move_objects_with_loop_correction();
  }
  const bool lost = result_.slam.status == slam::TrackingStatus::kLost;
  stats_.lost_frames += lost;
  stats_.degraded_frames += result_.slam.status == slam::TrackingStatus::kDegraded;
  if (result_.slam.relocalised)
    stats_.relocalised_frames.emplace_back(frame.index, result_.slam.reloc_keyframe);

  const bool delayed = params_.pipeline.segmentation_delay_frames > 0;
  if (semantic_ && !lost && !delayed) {
    t0 = Clock::now();
    keep_scene_for_pose_stage();
    const slam::IndexImage& pixel_surfel = slam_->last_pixel_surfel();
    const SemanticStep& step = semantic_->process(frame, T_world_cam, slam_->map(),
                                                  pixel_surfel.empty() ? nullptr : &pixel_surfel);
    result_.semantic_ms = ms_since(t0);
    if (step.keyframe) {
      segmented_frame_ = &frame;
      segmented_T_world_cam_ = T_world_cam;
      keyframe_fused(step, frame, T_world_cam);
    }
  } else if (semantic_ && !lost && semantic_->next_frame(T_world_cam)) {
    submit_keyframe(frame, T_world_cam);
  }
  while (delayed && !pending_.empty() && pending_.front().due_frame <= stats_.frames)
    fuse_pending_keyframe();
  if (semantic_ && !lost)
    result_.instances = static_cast<int>(semantic_->fusion().instances().size());
  finish_result(t_frame);
  return result_;
}

void ObjectRpePipeline::keep_scene_for_pose_stage() {
  // The semantic stage's render of every surfel serves the pose stage's projected depth and colour
  // when that runs next, at the same camera and map (docs/PIPELINE.md, "Projected images"): kept,
  // when the next keyframe will be evaluated with projected inputs, over the instances' window
  // grown by twice the pose stage's margin (its instances may have grown meanwhile).
  semantic_->drop_kept_scene();
  bool projected = false;
  for (const auto& v : variants_)
    projected |= v.config.projected_mask || v.config.projected_depth || v.config.projected_color;
  const bool evaluated = stats_.keyframes % params_.pipeline.pose_every_n_keyframes == 0;
  semantic_->set_keep_scene(projected && evaluated ? 2 * params_.pipeline.render_margin_px : -1);
}

void ObjectRpePipeline::keyframe_fused(const SemanticStep& step, const RgbdFrame& frame,
                                       const SE3& T_world_cam) {
  result_.keyframe = true;
  result_.segmented_frame_index = frame.index;
  result_.detections = static_cast<int>(step.detections.size());
  if (step.report.merged_instances > 0) hand_over_merged_tracks();
  ++stats_.keyframes;
  stats_.semantic_segment_ms += step.segment_ms;
  stats_.semantic_render_ms += step.report.render_ms;
  stats_.semantic_associate_ms += step.report.associate_ms;
  stats_.semantic_update_ms += step.report.update_ms;
  stats_.semantic_guards_ms += step.report.guards_ms;
  stats_.detections += result_.detections;
  result_.evaluated =
      !variants_.empty() && (stats_.keyframes - 1) % params_.pipeline.pose_every_n_keyframes == 0;
  if (!result_.evaluated) return;
  ++stats_.evaluated_frames;
  evaluated_frames_.push_back(frame.index);
  estimate_poses(frame, T_world_cam, result_);
}

void ObjectRpePipeline::submit_keyframe(const RgbdFrame& frame, const SE3& T_world_cam) {
  PendingKeyframe p;
  p.due_frame = stats_.frames + params_.pipeline.segmentation_delay_frames;
  p.frame = std::make_shared<const RgbdFrame>(frame);
  p.T_world_cam = T_world_cam;
  if (params_.pipeline.segmentation_async) {
    if (!worker_) worker_ = std::make_unique<SegmentationWorker>();
    p.segment_ms = std::make_shared<double>(0.0);
    SemanticMapper* semantic = semantic_.get();
    p.detections = worker_->submit([semantic, f = p.frame, T = T_world_cam, ms = p.segment_ms] {
      SegmentationContext context;  // no map: it changes meanwhile (the back-ends use the pose)
      context.T_world_cam = T;
      return semantic->detect(*f, context, ms.get());
    });
  }
  pending_.push_back(std::move(p));
}

void ObjectRpePipeline::fuse_pending_keyframe() {
  PendingKeyframe p = std::move(pending_.front());
  pending_.pop_front();
  const auto t0 = Clock::now();
  std::vector<Detection> detections;
  double segment_ms = 0;
  if (p.detections.valid()) {
    detections = p.detections.get();  // rethrows the back-end's error
    stats_.segmentation_wait_ms += ms_since(t0);
    segment_ms = *p.segment_ms;
  } else {
    SegmentationContext context;  // as the asynchronous path: the same results
    context.T_world_cam = p.T_world_cam;
    detections = semantic_->detect(*p.frame, context, &segment_ms);
  }
  // The frame's pixel -> surfel image is stale by now: the fusion projects the map itself.
  keep_scene_for_pose_stage();
  const SemanticStep& step = semantic_->integrate(*p.frame, p.T_world_cam, std::move(detections),
                                                  slam_->map(), nullptr, segment_ms);
  result_.semantic_ms += ms_since(t0);
  segmented_frame_hold_ = p.frame;
  segmented_frame_ = p.frame.get();
  segmented_T_world_cam_ = p.T_world_cam;
  keyframe_fused(step, *p.frame, p.T_world_cam);
}

bool ObjectRpePipeline::flush_one() {
  if (pending_.empty()) return false;
  const auto t0 = Clock::now();
  result_ = PipelineFrameResult{};
  result_.frame_index = pending_.front().frame->index;
  result_.timestamp_s = pending_.front().frame->timestamp_s;
  fuse_pending_keyframe();
  result_.instances = static_cast<int>(semantic_->fusion().instances().size());
  finish_result(t0);
  return true;
}

void ObjectRpePipeline::finish_result(Clock::time_point t_start) {
  result_.total_ms = ms_since(t_start);
  stats_.slam_ms += result_.slam_ms;
  stats_.semantic_ms += result_.semantic_ms;
  stats_.render_ms += result_.render_ms;
  stats_.single_view_ms += result_.single_view_ms;
  stats_.ekf_ms += result_.ekf_ms;
  stats_.total_ms += result_.total_ms;
  if (!result_.evaluated) return;
  // The BOP "time" column: the processing time of the call that estimated the frame's poses.
  const int im_id = result_.segmented_frame_index;
  for (auto& v : variants_) {
    for (auto it = v.rows.rbegin(); it != v.rows.rend() && it->im_id == im_id; ++it)
      it->time_s = result_.total_ms / 1000.0;
    for (auto it = v.seen.rbegin(); it != v.seen.rend() && it->frame_index == im_id; ++it)
      it->time_s = result_.total_ms / 1000.0;
  }
}

void ObjectRpePipeline::learn_colour(Track& track, const ObjectModel& model,
                                     const SingleViewPose& sv, bool accepted,
                                     const ObjectPoseFusion& fusion, const SE3& T_world_cam,
                                     const ColorImage& color, const DepthImage& depth,
                                     const MaskImage& mask, const PinholeIntrinsics& K) {
  const ModelRegistrationParams& rp = params_.pose_registration;
  if (!rp.colour.enabled || !rp.colour_learning.enabled || model.colour || color.empty() ||
      !fusion.has_estimate())
    return;
  if (!track.colour) track.colour = std::make_unique<ColourLearner>(model, rp.colour_learning);
  if (track.colour->observe(sv, accepted, fusion.accepted(), fusion.T_cam_obj(T_world_cam), color,
                            depth, mask, K))
    ++stats_.colour_views_learned;
}

/// One evaluated frame of the pose stage: its inputs, the map's renders and the candidates.
struct ObjectRpePipeline::PoseFrame {
  PoseFrame(const RgbdFrame& f, const SE3& T, PipelineFrameResult& r)
      : frame(f), T_world_cam(T), result(r), K(f.intrinsics) {}
  const RgbdFrame& frame;
  SE3 T_world_cam;
  PipelineFrameResult& result;
  PinholeIntrinsics K;
  int min_pose_mask_px = 1;  // params.pipeline.min_pose_mask_px_for(this image)
  std::vector<InstanceView> views;              // per instance: projected mask, depth, colour
  slam::RenderedView view;                      // PD / PC: the instances' render over the scene's
  const DepthImage* projected_depth = nullptr;  // view.depth, or the frame's without renders
  const ColorImage* projected_color = nullptr;
  std::vector<Candidate> from_map;         // projected masks
  std::vector<MaskImage> detection_masks;  // raw masks (owned here: candidates point into them)
  std::vector<Candidate> from_detections;
  // Single-view estimates, computed once per distinct input. The colour source is part of the key
  // only for estimators that use colour (the model-based registration does when its colour
  // ranking is on).
  std::map<std::tuple<int, int, int, int, int>, SingleViewPose> cache;
};

void ObjectRpePipeline::estimate_poses(const RgbdFrame& frame, const SE3& T_world_cam,
                                       PipelineFrameResult& result) {
  PoseFrame f(frame, T_world_cam, result);
  f.K.width = frame.depth.width();
  f.K.height = frame.depth.height();
  f.min_pose_mask_px = params_.pipeline.min_pose_mask_px_for(f.K.width, f.K.height);
  const bool need_projected = render_projected(f);
  f.projected_depth = need_projected ? &f.view.depth : &frame.depth;
  f.projected_color = need_projected ? &f.view.color : &frame.color;
  candidates_from_map(f);
  candidates_from_detections(f);
  preload_models(f);
  result.variants.resize(variants_.size());
  for (size_t vi = 0; vi < variants_.size(); ++vi) {
    VariantState& vs = variants_[vi];
    const std::vector<Candidate>& candidates =
        vs.config.projected_mask ? f.from_map : f.from_detections;
    for (const Candidate& c : candidates) {
      if (c.report_only && !vs.config.ekf) continue;
      ObjectFrameEstimate est;
      est.instance_id = c.instance_id;
      est.class_id = c.class_id;
      est.class_probability = c.class_probability;
      est.mask_px = c.mask_px;
      if (const ObjectModel* model = model_for(c, est)) {
        Track* track = track_for(vs, c);
        const bool skip = estimate_single_view(f, vi, c, track, *model, est);
        vs.records.push_back({frame.index, c.instance_id, c.class_id, c.class_probability,
                              est.single_view, T_world_cam, c.mask_px});
        fuse_estimate(f, vs, c, track, *model, skip, est);
      }
      result.variants[vi].push_back(std::move(est));
    }
  }
}

bool ObjectRpePipeline::render_projected(PoseFrame& f) {
  // The map at the tracked pose. PM / PD / PC of the instances rendered as the semantic stage
  // renders them (label-aware: young unlabelled surfels do not punch holes into the masks) -- of
  // every instance, not only the semantic stage's confirmed ones, so that an object gets a
  // projected mask from its first keyframe on (pipeline.min_instance_detections filters); around
  // them, depth and colour of a plain render of every surfel.
  const PipelineParams& pp = params_.pipeline;
  const auto t0 = Clock::now();
  bool need_projected = false;
  for (const auto& v : variants_)
    need_projected |=
        v.config.projected_mask || v.config.projected_depth || v.config.projected_color;
  if (need_projected) {
    InstanceImages images;
    InstanceRenderOptions ro;
    ro.max_splat_radius_px = static_cast<float>(params_.semantic.mask_splat_radius_px);
    ro.splat_radius_scale = static_cast<float>(params_.semantic.mask_splat_radius_scale);
    ro.depth_tolerance_m = params_.semantic.mask_depth_tolerance_m;
    ro.one_pass = params_.semantic.mask_render_one_pass;
    ro.want_color = true;
    ro.scene_margin_px = pp.render_margin_px;  // the scene around the instances (windowed)
    if (semantic_) ro.reuse_scene = &semantic_->fusion().kept_scene();
    instance_renderer_.render(slam_->map(), f.T_world_cam, f.K, ro, &images);
    stats_.projected_scene_reused += images.scene_reused;
    bool any_ekf = false;
    for (const auto& v : variants_) any_ekf |= v.config.ekf && v.config.projected_mask;
    const int min_view_px = any_ekf && pp.ekf_report_min_mask_px > 0
                                ? std::min(f.min_pose_mask_px, pp.ekf_report_min_mask_px)
                                : f.min_pose_mask_px;
    f.views = split_instance_views(images, semantic_->fusion().instances(), min_view_px);
    f.view.depth = std::move(images.scene_depth);
    f.view.color = std::move(images.scene_color);
    for (const InstanceView& iv : f.views)  // the mask lies inside its box
      for (int v = iv.box.v_min; v <= iv.box.v_max; ++v)
        for (int u = iv.box.u_min; u <= iv.box.u_max; ++u)
          if (iv.projected_mask.at(u, v)) {
            f.view.depth.at(u, v) = iv.projected_depth.at(u, v);
            f.view.color.at(u, v) = iv.projected_color.at(u, v);
          }
  }
  f.result.render_ms = ms_since(t0);
  return need_projected;
}

void ObjectRpePipeline::candidates_from_map(PoseFrame& f) const {
  const auto& instances = semantic_->fusion().instances();
  const PipelineParams& pp = params_.pipeline;
  for (const InstanceView& iv : f.views) {
    const auto info = instances.find(iv.instance_id);
    if (info == instances.end()) continue;
    Candidate c;
    c.instance_id = iv.instance_id;
    c.class_id = iv.class_id;
    c.class_probability = iv.class_probability;
    c.mask = &iv.projected_mask;
    c.mask_px = iv.area_px;
    c.object_key = iv.instance_id;
    c.detections = info->second.detections;
    if (c.class_id <= 0 || info->second.detections < pp.min_instance_detections ||
        c.class_probability < pp.min_class_probability)
      continue;
    if (c.mask_px < f.min_pose_mask_px) {
      if (pp.ekf_report_min_mask_px <= 0 || c.mask_px < pp.ekf_report_min_mask_px) continue;
      c.report_only = true;
    }
    f.from_map.push_back(c);
  }
}

void ObjectRpePipeline::candidates_from_detections(PoseFrame& f) const {
  // The raw masks of this keyframe's detections; the instance each joined is the majority label
  // of the fused detection labels under its mask.
  bool need_raw = false;
  for (const auto& v : variants_) need_raw |= !v.config.projected_mask;
  if (!need_raw) return;
  const auto& instances = semantic_->fusion().instances();
  const PipelineParams& pp = params_.pipeline;
  const auto& detections = semantic_->last_step().detections;
  const LabelImage& fused_labels = semantic_->fusion().last_detection_labels();
  const float threshold = static_cast<float>(params_.segmentation.mask_threshold);
  f.detection_masks.reserve(detections.size());
  for (const auto& d : detections)
    f.detection_masks.push_back(binary_mask(d.probability, threshold));
  for (size_t i = 0; i < detections.size(); ++i) {
    const MaskImage& mask = f.detection_masks[i];
    std::map<int, int> votes;
    int area = 0;
    for (size_t k = 0; k < mask.size(); ++k) {
      if (!mask[k]) continue;
      ++area;
      if (!fused_labels.empty() && fused_labels[k] > 0) ++votes[fused_labels[k]];
    }
    Candidate c;
    c.class_id = detections[i].class_id;
    c.class_probability = detections[i].score;
    for (const auto& [cls, p] : class_distribution(detections[i]))
      if (cls == c.class_id) c.class_probability = p;
    c.mask = &mask;
    c.mask_px = area;
    c.object_key = static_cast<int>(i);
    int best_votes = 0;
    for (const auto& [id, n] : votes)
      if (n > best_votes && instances.count(id)) {
        best_votes = n;
        c.instance_id = id;
      }
    if (c.instance_id > 0) c.detections = instances.at(c.instance_id).detections;
    if (area < f.min_pose_mask_px || c.class_probability < pp.min_class_probability) continue;
    f.from_detections.push_back(c);
  }
}

void ObjectRpePipeline::preload_models(const PoseFrame& f) {
  // The classes seen for the first time are loaded together, one per core (a YCB-Video model takes
  // ~0.2 s to read and prepare); the results are the ones model_for() would load one by one.
  std::vector<int> classes;
  for (const auto* list : {&f.from_map, &f.from_detections})
    for (const Candidate& c : *list)
      if (models_.has(c.class_id) && !model_errors_.count(c.class_id))
        classes.push_back(c.class_id);
  if (classes.size() < 2) return;
  const auto t_load = Clock::now();
  try {
    models_.preload(classes, static_cast<int>(std::max(1u, std::thread::hardware_concurrency())));
  } catch (const IoError&) {
    // model_for() loads that class again and reports the error for it.
  }
  stats_.model_loading_ms += ms_since(t_load);
}

const ObjectModel* ObjectRpePipeline::model_for(const Candidate& c, ObjectFrameEstimate& est) {
  if (!models_.has(c.class_id)) {
    if (model_errors_.emplace(c.class_id, "no model").second)
      spdlog::warn("class {} has no model in the dataset: its objects get no pose", c.class_id);
    est.single_view.reason = "no model for the class";
    return nullptr;
  }
  const ObjectModel* model = nullptr;
  if (!model_errors_.count(c.class_id)) {
    try {
      const auto t_load = Clock::now();
      model = &models_.get(c.class_id);  // loaded on the class's first use
      stats_.model_loading_ms += ms_since(t_load);
    } catch (const IoError& e) {
      model_errors_[c.class_id] = e.what();
      spdlog::warn("class {}: model not usable, its objects get no pose: {}", c.class_id, e.what());
    }
  }
  if (!model) est.single_view.reason = "model not usable: " + model_errors_.at(c.class_id);
  return model;
}

ObjectRpePipeline::Track* ObjectRpePipeline::track_for(VariantState& vs, const Candidate& c) {
  // The instance's track (EKF variants need a map instance to key the filter).
  if (c.instance_id <= 0) return nullptr;
  Track& t = vs.tracks[c.instance_id];
  if (t.class_id != c.class_id) {  // new, or the instance's argmax class changed: restart
    t = Track{};
    t.class_id = c.class_id;
    t.prior_allowance = params_.pipeline.prior_max_consecutive;
    if (vs.config.ekf) {
      const PipelineParams& pp = params_.pipeline;
      t.ekf = std::make_unique<ObjectPoseFusion>(params_.pose_ekf,
                                                 models_.ekf_symmetry(c.class_id, pp.ekf_symmetry),
                                                 pp.ekf_init_views, pp.ekf_init_majority_stop);
    }
  }
  return &t;
}

bool ObjectRpePipeline::estimate_single_view(PoseFrame& f, size_t vi, const Candidate& c,
                                             Track* track, const ObjectModel& model,
                                             ObjectFrameEstimate& est) {
  const PipelineParams& pp = params_.pipeline;
  const PoseVariant& cfg = variants_[vi].config;
  const bool use_prior = cfg.ekf && pp.ekf_prior_hypothesis && track && track->ekf &&
                         track->ekf->has_estimate() &&
                         track->prior_in_a_row < track->prior_allowance;
  const bool learned = track && track->colour && track->colour->model();
  const auto key =
      std::make_tuple(cfg.projected_mask ? 1 : 0, c.object_key, cfg.projected_depth ? 1 : 0,
                      estimator_uses_color_ ? (cfg.projected_color ? 1 : 0) : -1,
                      use_prior || learned ? static_cast<int>(vi) : -1);
  auto cached = f.cache.find(key);
  // The skip rule needs a fused pose, not the prior hypothesis: it holds with
  // ekf_prior_hypothesis off too.
  const bool fused = cfg.ekf && track && track->ekf && track->ekf->has_estimate();
  const bool skip = fused && !c.report_only &&
                    skip_estimate(track->skip, track->ekf->accepted(), f.T_world_cam, pp);
  if (c.report_only) {
    est.single_view = SingleViewPose{};
    est.single_view.reason = "mask too small for a single-view estimate";
  } else if (skip) {
    est.single_view = SingleViewPose{};
    est.single_view.reason = "skipped: fused pose confident and view unchanged (pipeline.skip_*)";
    ++track->skip.skipped_in_a_row;
    ++stats_.single_view_skipped;
  } else if (cached != f.cache.end()) {
    est.single_view = cached->second;
    ++stats_.single_view_cache_hits;
  } else {
    SingleViewInput in;
    in.mask = c.mask;
    in.depth = cfg.projected_depth ? f.projected_depth : &f.frame.depth;
    in.color = cfg.projected_color ? f.projected_color : &f.frame.color;
    in.intrinsics = f.K;
    in.class_id = c.class_id;
    in.model = learned ? track->colour->model() : &model;
    if (use_prior) {
      in.T_cam_obj_prior = track->ekf->T_cam_obj(f.T_world_cam);
      in.prior_reference_score = track->reference_score;
    }
    const auto t0 = Clock::now();
    est.single_view = estimator_->estimate(in);
    f.result.single_view_ms += ms_since(t0);
    ++stats_.single_view_estimates;
    stats_.single_view_valid += est.single_view.valid;
    stats_.single_view_from_prior += est.single_view.from_prior;
    stats_.single_view_prior_not_fitting += use_prior && !est.single_view.from_prior;
    if (track) track->prior_in_a_row = est.single_view.from_prior ? track->prior_in_a_row + 1 : 0;
    f.cache.emplace(key, est.single_view);
  }
  return skip;
}

void ObjectRpePipeline::fuse_estimate(PoseFrame& f, VariantState& vs, const Candidate& c,
                                      Track* track, const ObjectModel& model, bool skip,
                                      ObjectFrameEstimate& est) {
  const PoseVariant& cfg = vs.config;
  const SingleViewPose& sv = est.single_view;
  const double sv_score = single_view_weight(sv);
  if (cfg.ekf) {
    if (track && track->ekf) {
      const auto t0 = Clock::now();
      fuse_into_ekf(f, cfg, c, *track, model, skip, est);
      f.result.ekf_ms += ms_since(t0);
    }
  } else if (sv.valid) {
    est.reported = true;
    est.T_cam_obj = sv.T_cam_obj;
    est.score = c.class_probability * sv_score;
    if (track) {
      ++track->valid_views;
      if (est.score > track->best_score) {
        track->have_best = true;
        track->best_score = est.score;
        track->best_T_world_obj = f.T_world_cam * sv.T_cam_obj;
        track->last_slam_time = slam_->last_time();
      }
    }
  }
  if (!est.reported) return;
  PoseResultRow row;
  row.scene_id = dataset_.scene_id;
  row.im_id = f.frame.index;
  row.obj_id = est.class_id;
  row.score = est.score * existence_weight(c.detections, params_.semantic.min_confirmed_detections);
  row.T_cam_obj = est.T_cam_obj;
  vs.rows.push_back(row);
  if (cfg.ekf && est.instance_id > 0)
    vs.seen.push_back({f.frame.index, f.T_world_cam, est.instance_id, est.class_id, est.score, -1,
                       slam_->last_time()});
}

void ObjectRpePipeline::move_objects_with_loop_correction() {
  for (auto& vs : variants_)
    for (auto& [id, track] : vs.tracks) {
      if (track.last_slam_time < 0) continue;
      const SE3 C = slam_->loop_correction(track.last_slam_time);
      if (track.ekf) track.ekf->apply_world_correction(C);
      track.best_T_world_obj = C * track.best_T_world_obj;
      track.skip.T_world_cam = C * track.skip.T_world_cam;
    }
  const std::vector<SE3>& T = slam_->trajectory();
  for (auto& vs : variants_)
    for (auto& s : vs.seen)
      if (s.slam_time >= 0 && s.slam_time < static_cast<std::int32_t>(T.size()))
        s.T_world_cam = T[static_cast<size_t>(s.slam_time)];
}

void ObjectRpePipeline::fuse_into_ekf(PoseFrame& f, const PoseVariant& cfg, const Candidate& c,
                                      Track& track, const ObjectModel& model, bool skip,
                                      ObjectFrameEstimate& est) {
  const PipelineParams& pp = params_.pipeline;
  const SingleViewPose& sv = est.single_view;
  const double sv_score = single_view_weight(sv);
  ObjectPoseFusion& fusion = *track.ekf;
  // A global search on an object the filter already holds: a vote on its mode (the back-off).
  const bool vote = !skip && !c.report_only && !sv.from_prior && fusion.has_estimate();
  bool agreed = false;
  if (sv.valid) {
    PoseMeasurement m;
    m.frame_index = f.frame.index;
    m.T_world_cam = f.T_world_cam;
    m.T_cam_obj = sv.T_cam_obj;
    m.mu_m = sv.mu_m;
    if (sv.colour_used)
      m.mode_weight =
          mode_weight_from_colour(sv.colour_margin, params_.pose_ekf.colour_evidence_gain);
    // A refined prior that inherited its mode is not an independent vote among modes.
    if (sv.from_prior && !sv.prior_modes_compared) m.mode_weight *= pp.prior_mode_weight;
    // Decisive: the estimator singled the pose out among the modes geometry confuses, by the
    // colour-learning rule's thresholds (pose/colour_score.h, ColourLearningParams).
    const ColourLearningParams& cl = params_.pose_registration.colour_learning;
    const bool decisive = sv.geometry_margin >= cl.min_geometry_margin ||
                          (sv.colour_used && sv.colour_margin >= cl.min_colour_margin);
    const ObjectPoseFusion::Outcome o = fusion.add(m, sv_score, decisive);
    agreed = o.accepted && !o.switched;
    track.last_slam_time = slam_->last_time();
    est.ekf_accepted = o.accepted;
    ++(o.accepted ? stats_.ekf_accepted : stats_.ekf_rejected);
    learn_colour(track, model, sv, o.accepted, fusion, f.T_world_cam,
                 cfg.projected_color ? *f.projected_color : f.frame.color,
                 cfg.projected_depth ? *f.projected_depth : f.frame.depth, *c.mask, f.K);
  }
  if (!skip && !c.report_only) track.skip = {est.ekf_accepted, f.T_world_cam, 0};
  if (vote) track.prior_allowance = backed_off_allowance(track.prior_allowance, agreed, pp);
  if (vote && agreed) track.reference_score = sv.score;
  if (fusion.has_estimate()) {
    est.reported = true;
    est.T_cam_obj = fusion.T_cam_obj(f.T_world_cam);
    est.score = c.class_probability * (fusion.accepted() > 0 ? fusion.score() : sv_score);
  } else if (sv.valid) {  // still collecting the initial views: the single-view estimate
    est.reported = true;
    est.T_cam_obj = sv.T_cam_obj;
    est.score = c.class_probability * sv_score;
  }
}

void ObjectRpePipeline::hand_over_merged_tracks() {
  const SemanticFusion& fusion = semantic_->fusion();
  // Views fused so far: what a track has to lose.
  auto views = [](const Track& t) { return t.ekf ? t.ekf->accepted() : t.valid_views; };
  for (auto& v : variants_)
    hand_over_merged(
        v.tracks, [&](int id) { return fusion.resolve_instance(id); }, views);
}

std::map<int, double> ObjectRpePipeline::instance_class_min_widths() {
  std::map<int, double> widths;
  for (const auto& [id, info] : semantic_->fusion().instances()) {
    const int c = info.argmax_class();
    if (c <= 0 || widths.count(c) || !models_.has(c) || model_errors_.count(c)) continue;
    try {
      widths[c] = model_min_width_m(models_.get(c));
    } catch (const IoError& e) {
      model_errors_[c] = e.what();  // the pose stage reports it; the instance keeps its chance
    }
  }
  return widths;
}

void ObjectRpePipeline::finalize() {
  if (!semantic_) return;
  while (flush_one()) {
  }
  semantic_->set_class_min_widths(instance_class_min_widths());
  semantic_->finalize(slam_->map());  // prunes, never merges: the tracks already follow every merge
  const auto& instances = semantic_->fusion().instances();
  for (auto& v : variants_) {
    for (auto it = v.tracks.begin(); it != v.tracks.end();) {
      const auto inst = instances.find(it->first);
      // Drop filters of removed instances and of instances whose final class differs from the
      // filter's (the filter's model was another class's).
      if (inst == instances.end() || inst->second.argmax_class() != it->second.class_id) {
        it = v.tracks.erase(it);
      } else {
        if (it->second.ekf) it->second.ekf->flush();
        ++it;
      }
    }
  }
}

std::vector<PoseResultRow> ObjectRpePipeline::final_pose_rows(size_t vi) const {
  const VariantState& vs = variants_.at(vi);
  std::vector<PoseResultRow> rows;
  if (!vs.config.ekf) return rows;
  for (const auto& s : vs.seen) {
    // The object's final pose, also in frames seen under an id the map later merged away.
    const int id = semantic_ ? semantic_->fusion().resolve_instance(s.instance_id) : s.instance_id;
    const auto t = vs.tracks.find(id);
    if (t == vs.tracks.end() || !t->second.ekf || !t->second.ekf->has_estimate() ||
        t->second.class_id != s.class_id)
      continue;
    PoseResultRow row;
    row.scene_id = dataset_.scene_id;
    row.im_id = s.frame_index;
    row.obj_id = s.class_id;
    row.score = s.score;
    row.T_cam_obj = s.T_world_cam.inverse() * t->second.ekf->T_world_obj();
    row.time_s = s.time_s;
    rows.push_back(row);
  }
  return rows;
}

std::vector<ObjectWorldPose> ObjectRpePipeline::object_poses(size_t vi) const {
  const VariantState& vs = variants_.at(vi);
  std::vector<ObjectWorldPose> out;
  if (!semantic_) return out;
  const auto& instances = semantic_->fusion().instances();
  const auto geometry = instance_geometry(slam_->map());
  for (const auto& [id, track] : vs.tracks) {
    const auto inst = instances.find(id);
    if (inst == instances.end()) continue;
    ObjectWorldPose o;
    o.instance_id = id;
    o.class_id = track.class_id;
    o.class_name = models_.class_name(track.class_id);
    o.class_probability = inst->second.argmax_probability();
    o.detections = inst->second.detections;
    if (const auto g = geometry.find(id); g != geometry.end()) o.surfels = g->second.surfels;
    if (models_.has(track.class_id) && !model_errors_.count(track.class_id)) {
      const ObjectModel& m = models_.get(track.class_id);
      o.model_symmetry = m.symmetry.describe();
      if (m.colour) o.model_colour = m.colour->source;
    }
    if (track.ekf) {
      const FusedObjectPose f = track.ekf->result();
      o.source = "ekf";
      o.valid = track.ekf->has_estimate();
      o.T_world_obj = f.T_world_obj;
      o.has_covariance = o.valid;
      o.covariance = f.covariance;
      o.num_views = f.num_fused;
      o.num_rejected = std::max(f.num_rejected, track.ekf->rejected());
      o.num_reinitialisations = f.num_reinitialisations;
    } else {
      o.source = "best_single_view";
      o.valid = track.have_best;
      o.T_world_obj = track.best_T_world_obj;
      o.num_views = track.valid_views;
    }
    out.push_back(o);
  }
  return out;
}

}  // namespace orpe
