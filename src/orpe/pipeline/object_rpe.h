// The Object-RPE pipeline (the paper's Fig. 1), per frame:
//   1. tracking + surfel fusion (slam::SlamSystem);
//   2. on segmentation keyframes: 2D instance segmentation + instance-aware semantic fusion
//      (SemanticMapper);
//   3. on evaluated frames (every PipelineParams::pose_every_n_keyframes-th keyframe): for each
//   object
//      seen in the frame, single-view 6D pose on the chosen inputs (detection or map-projected
//      mask, camera or map-projected depth / colour);
//   4. with the EKF: one PoseEkf per map instance (keyed by instance id; model and symmetry of the
//      instance's argmax class) fuses the single-view poses moved to the world by the tracked
//      camera.
// Outputs: per evaluated frame and object a camera-frame pose (BOP result rows), per instance a
// final world pose (objects.json), plus the SLAM trajectory and the semantic map.
//
// Choices (docs/PIPELINE.md has the rationale):
//  - "Seen in the frame": projected-mask modes take every map instance whose projected mask has at
//    least min_pose_mask_px pixels at the tracked pose (so an object the detector missed in this
//    frame still gets a pose); raw-mask modes take this keyframe's detections.
//  - Class: the instance's argmax class (projected masks) or the detection's class (raw masks).
//  - Reported camera-frame pose with the EKF: T_world_cam^-1 * T_world_obj of the instance's filter
//    after this frame's update (also when this frame's measurement was invalid or gated out, as
//    long as the filter is initialised); without the EKF: the frame's single-view estimate when
//    valid.
//  - Projected mask / depth / colour: the semantic stage's label-aware render of the instances
//    (InstanceRenderer + split_instance_views, every instance: the semantic stage's own
//    render_instance_views keeps only confirmed ones, which would leave an object's first keyframe
//    without a projected mask); around the instances, depth and colour of a
//    plain render of every surfel, so pixels around the object carry the map's surfaces as the
//    camera's images would (the registration's free-space test looks there).
//  - Frames whose tracking is LOST are neither segmented nor evaluated (their pose is a held
//  guess).
//  - pipeline.segmentation_delay_frames = D > 0: a keyframe is segmented on a worker thread
//    (segmentation_async) and fused, and its poses estimated on its own images, D frames later;
//    the results depend on D only, not on the back-end's timing (docs/PIPELINE.md).
//  - Several input configurations (PoseVariant) can run in one pass sharing SLAM and semantic
//  mapping;
//    a single-view estimate is computed once per distinct input (the geometry-only estimator
//    ignores colour, so DF-PM-PD-PC reuses DF-PM-PD's estimates).
#pragma once

#include <chrono>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "orpe/core/frame.h"
#include "orpe/io/bop_results.h"
#include "orpe/io/dataset.h"
#include "orpe/pipeline/config.h"
#include "orpe/pipeline/object_models.h"
#include "orpe/pipeline/pipeline_params.h"
#include "orpe/pipeline/segmentation_worker.h"
#include "orpe/pose/model_registration.h"
#include "orpe/pose/pose_backend.h"
#include "orpe/pose/pose_ekf.h"
#include "orpe/recognition/model_recognizer.h"
#include "orpe/semantic/instance_render.h"
#include "orpe/semantic/semantic_mapper.h"
#include "orpe/slam/slam_system.h"

namespace orpe {

/// One configuration of the single-view inputs and the EKF switch (a row of the ablation table).
class ObjectPoseFusion;

struct PoseVariant {
  std::string name;
  bool projected_mask = true;
  bool projected_depth = true;
  bool projected_color = true;
  bool ekf = true;
  /// The configuration of `params` (name: its ablation name, or "custom").
  static PoseVariant from(const PipelineParams& params);
  /// A named ablation configuration (PipelineParams::ablation_names()). Throws ConfigError.
  static PoseVariant named(const std::string& name);
};

struct ObjectRpeParams {
  slam::SlamParams slam;
  SegmentationParams segmentation;
  SemanticParams semantic;
  RecognitionParams recognition;             ///< segmentation.backend=model
  SceneGeometryParams recognition_geometry;  ///< segmentation.backend=model
  PoseBackendParams pose;  ///< single-view back-end: model (pose_registration) | densefusion
  ModelRegistrationParams pose_registration;
  PoseEkfParams pose_ekf;
  PipelineParams pipeline;
  /// Pose configurations run in this pass; empty = no pose stage (SLAM + semantic mapping only).
  std::vector<PoseVariant> variants;
  /// false = SLAM only (no segmentation, no semantic map, no poses).
  bool semantic_mapping = true;

  /// The stage params of `config`, one variant from config.pipeline's switches.
  static ObjectRpeParams from_config(const OrpeConfig& config);
  bool IsValid(std::string* why) const;
};

/// One object in one evaluated frame, for one variant.
struct ObjectFrameEstimate {
  int instance_id = 0;  ///< map instance (raw masks: the instance the detection joined; 0 = none)
  int class_id = 0;
  double class_probability = 0;
  int mask_px = 0;
  SingleViewPose single_view;  ///< this frame's single-view estimate (valid = false when none)
  bool ekf_accepted = false;   ///< the measurement passed the EKF gate (EKF variants)
  bool reported = false;       ///< a pose is reported for this frame
  SE3 T_cam_obj;               ///< the reported pose (see the header comment)
  double score = 0;            ///< the reported row's score
};

struct PipelineFrameResult {
  int frame_index = 0;
  double timestamp_s = 0;
  slam::SlamFrameResult slam;
  /// A keyframe's detections were fused semantically in this call: this frame's, or with
  /// pipeline.segmentation_delay_frames those of the frame segmented_frame_index (the call
  /// `segmentation_delay_frames` frames later, or ObjectRpePipeline::flush_one at the end).
  bool keyframe = false;
  bool evaluated = false;          ///< poses were estimated (on the keyframe segmented_frame_index)
  int segmented_frame_index = -1;  ///< the keyframe fused in this call (RgbdFrame::index)
  int detections = 0;
  int instances = 0;                                       ///< map instances after this frame
  std::vector<std::vector<ObjectFrameEstimate>> variants;  ///< per variant (when evaluated)
  // Wall time, milliseconds.
  double slam_ms = 0, semantic_ms = 0, render_ms = 0, single_view_ms = 0, ekf_ms = 0, total_ms = 0;
  /// One line for the terminal.
  std::string report() const;
};

/// The final pose of one map instance (one variant).
struct ObjectWorldPose {
  int instance_id = 0;
  int class_id = 0;
  std::string class_name;
  double class_probability = 0;
  int detections = 0;  ///< keyframes that detected the instance
  int surfels = 0;
  std::string
      model_symmetry;        ///< the class model's detected symmetry (what the EKF treats as equal)
  std::string model_colour;  ///< where the class model's colour came from; empty = none
  bool valid = false;        ///< a pose exists
  /// "ekf" (the filter's state) or "best_single_view" (the highest-scoring single-view estimate
  /// moved to the world, for variants without the EKF).
  std::string source;
  SE3 T_world_obj;
  bool has_covariance = false;
  Mat6 covariance = Mat6::Zero();  ///< EKF: body-frame tangent [rho; phi] (m^2, rad^2)
  int num_views = 0;               ///< single-view estimates fused (EKF) or valid (no EKF)
  int num_rejected = 0;
  int num_reinitialisations = 0;
};

/// Totals over a run.
struct PipelineStats {
  int frames = 0, keyframes = 0, evaluated_frames = 0, lost_frames = 0, degraded_frames = 0;
  /// Frames on which a LOST camera was relocalised (slam_reloc), by RgbdFrame::index, with the
  /// keyframe each was found against.
  std::vector<std::pair<int, int>> relocalised_frames;
  /// Frames on which a loop was closed (slam_loop), with the revisited keyframe's index.
  std::vector<std::pair<int, int>> loop_closures;
  int detections = 0;
  int single_view_estimates = 0, single_view_valid = 0, single_view_cache_hits = 0;
  int single_view_from_prior = 0;  ///< estimates that were a local refinement of the EKF's prior
  /// Estimates given the prior that ran the global search (the refined prior did not fit).
  int single_view_prior_not_fitting = 0;
  int single_view_skipped = 0;     ///< objects not re-estimated (PipelineParams::skip_*)
  int ekf_accepted = 0, ekf_rejected = 0;
  int colour_views_learned = 0;  ///< views that taught an object its colour (learned from the map)
  /// Evaluated frames whose projected images reused the semantic stage's render of every surfel
  /// (SceneRender; of render_views' frames).
  int projected_scene_reused = 0;
  double slam_ms = 0, semantic_ms = 0, render_ms = 0, single_view_ms = 0, ekf_ms = 0, total_ms = 0;
  /// The semantic stage's parts (ms, SemanticFrameReport): segmentation back-end, the map's
  /// instance render, association, surfel updates, segment guards.
  double semantic_segment_ms = 0, semantic_render_ms = 0, semantic_associate_ms = 0,
         semantic_update_ms = 0, semantic_guards_ms = 0;
  /// Asynchronous segmentation: time the pipeline waited for a keyframe's detections (ms).
  double segmentation_wait_ms = 0;
  /// Loading object models on their class's first pose estimate (ms; inside total_ms, in no stage).
  double model_loading_ms = 0;
};

class ObjectRpePipeline {
 public:
  /// `dataset` gives the models (model_points_paths / model_mesh_paths / symmetric_classes), class
  /// names and the scene id of the result rows. Throws ConfigError for invalid params.
  ObjectRpePipeline(const ObjectRpeParams& params, const DatasetInfo& dataset);
  ~ObjectRpePipeline();

  /// Replaces the single-view estimator (default: ModelRegistrationEstimator with
  /// params.pose_registration), e.g. a learned back-end or a test double. `uses_color`: whether its
  /// result depends on the colour image (else estimates are shared between inputs that differ only
  /// in colour). Call before the first process().
  void set_single_view_estimator(std::unique_ptr<SingleViewPoseEstimator> estimator,
                                 bool uses_color);
  const SingleViewPoseEstimator* single_view_estimator() const { return estimator_.get(); }

  /// Replaces the segmentation back-end (default: segmentation.backend), e.g. a test double. Call
  /// before the first process().
  void set_segmenter(std::unique_ptr<Segmenter> segmenter);

  /// Runs every stage on one frame (frames in order).
  const PipelineFrameResult& process(const RgbdFrame& frame);
  /// With pipeline.segmentation_delay_frames: fuses the oldest keyframe still waiting for its
  /// delay (end of the stream) and estimates its poses; false when none waits. The result is in
  /// last_result().
  bool flush_one();
  const PipelineFrameResult& last_result() const { return result_; }
  /// The keyframe fused by the last process() / flush_one() (result.keyframe) and its camera pose;
  /// valid until the next call.
  const RgbdFrame* segmented_frame() const { return segmented_frame_; }
  const SE3& segmented_T_world_cam() const { return segmented_T_world_cam_; }
  /// End of the run: fuses the keyframes still waiting (flush_one), removes spurious instances
  /// (SemanticMapper::finalize) and drops their filters.
  void finalize();

  const ObjectRpeParams& params() const { return params_; }
  const std::vector<StampedPose>& trajectory() const { return trajectory_; }
  /// Frame indices (RgbdFrame::index) of the evaluated frames, in order.
  const std::vector<int>& evaluated_frames() const { return evaluated_frames_; }
  const slam::SlamSystem& slam() const { return *slam_; }
  /// Null when semantic mapping is off.
  const SemanticMapper* semantic() const { return semantic_.get(); }
  ObjectModelLibrary& models() { return models_; }
  const PipelineStats& stats() const { return stats_; }
  size_t num_variants() const;
  const PoseVariant& variant(size_t v) const;

  /// Per evaluated frame and reported object, the camera-frame pose (BOP rows; scene_id = the
  /// dataset's, im_id = frame index, obj_id = class id, time = the frame's processing time).
  const std::vector<PoseResultRow>& pose_rows(size_t variant) const;
  /// The same rows with the *final* fused world pose moved into each frame's camera (EKF variants:
  /// what the whole sequence says about the frame; others: empty).
  std::vector<PoseResultRow> final_pose_rows(size_t variant) const;
  /// Every single-view estimate of a variant (valid or not) with the tracked camera pose, for
  /// analysis and offline replays of the fusion (single_view.csv).
  struct SingleViewRecord {
    int frame_index = 0;
    int instance_id = 0;
    int class_id = 0;
    double class_probability = 0;
    SingleViewPose estimate;
    SE3 T_world_cam;
    int mask_px = 0;  ///< pixels of the mask the estimate ran on (or was skipped for)
  };
  const std::vector<SingleViewRecord>& single_view_records(size_t variant) const;
  /// Per map instance that got a pose (after finalize(): surviving instances only), sorted by id.
  std::vector<ObjectWorldPose> object_poses(size_t variant) const;

 private:
  struct Track;
  struct VariantState;
  struct Candidate;
  struct PendingKeyframe;
  /// After a keyframe's semantic fusion: track hand-over, counts, pose estimation when evaluated.
  void keyframe_fused(const SemanticStep& step, const RgbdFrame& frame, const SE3& T_world_cam);
  /// Before a keyframe's semantic fusion: whether it keeps its render for the pose stage.
  void keep_scene_for_pose_stage();
  /// Delayed segmentation: queues the keyframe (and starts its back-end when asynchronous).
  void submit_keyframe(const RgbdFrame& frame, const SE3& T_world_cam);
  /// Delayed segmentation: fuses the oldest queued keyframe (waiting for its detections).
  void fuse_pending_keyframe();
  /// Adds this call's times to the stats and stamps the BOP "time" column of its rows.
  void finish_result(std::chrono::steady_clock::time_point t_start);
  struct PoseFrame;
  /// The pose stage on an evaluated frame: renders, candidates, then per variant and candidate
  /// the single-view estimate and its fusion.
  void estimate_poses(const RgbdFrame& frame, const SE3& T_world_cam, PipelineFrameResult& result);
  /// PM / PD / PC from the map when a variant needs them; false when none does.
  bool render_projected(PoseFrame& f);
  void candidates_from_map(PoseFrame& f) const;
  void candidates_from_detections(PoseFrame& f) const;
  /// Loads the models of the frame's candidates not loaded yet, on all cores (model_for reports
  /// any that fails to load).
  void preload_models(const PoseFrame& f);
  /// The candidate's model, or null (the estimate's reason says why: no model, not usable).
  const ObjectModel* model_for(const Candidate& c, ObjectFrameEstimate& est);
  /// The pose track of the candidate's instance (null without an instance).
  Track* track_for(VariantState& vs, const Candidate& c);
  /// Fills est.single_view (estimated, cached, skipped or report-only); true when skipped.
  bool estimate_single_view(PoseFrame& f, size_t variant, const Candidate& c, Track* track,
                            const ObjectModel& model, ObjectFrameEstimate& est);
  /// The variant's fusion of the estimate (EKF, or best view) and its result row.
  void fuse_estimate(PoseFrame& f, VariantState& vs, const Candidate& c, Track* track,
                     const ObjectModel& model, bool skip, ObjectFrameEstimate& est);
  void fuse_into_ekf(PoseFrame& f, const PoseVariant& cfg, const Candidate& c, Track& track,
                     const ObjectModel& model, bool skip, ObjectFrameEstimate& est);
  /// Feeds the track's colour learner (pose_registration.colour_learn*; colour_score.h) with a view
  /// the fusion has just seen, for models without colour of their own.
  void learn_colour(Track& track, const ObjectModel& model, const SingleViewPose& sv, bool accepted,
                    const ObjectPoseFusion& fusion, const SE3& T_world_cam, const ColorImage& color,
                    const DepthImage& depth, const MaskImage& mask, const PinholeIntrinsics& K);
  /// After a SLAM loop closure: every track's world pose (EKF state, best view) follows the
  /// correction of the frame that last gave it a view (the map's surfels moved with theirs).
  void move_objects_with_loop_correction();
  /// Moves the pose tracks of instances the semantic map merged onto the survivors (the one with
  /// more fused views wins when both have a track).
  void hand_over_merged_tracks();
  /// Minimal widths of the models of the instances' classes (semantic.min_height_fraction).
  std::map<int, double> instance_class_min_widths();
  /// The segmentation.backend=model recogniser over the dataset's (or model_classes') models.
  std::unique_ptr<Segmenter> make_model_recognizer();

  ObjectRpeParams params_;
  DatasetInfo dataset_;
  ObjectModelLibrary models_;
  std::unique_ptr<slam::SlamSystem> slam_;
  std::unique_ptr<SemanticMapper> semantic_;
  std::unique_ptr<SingleViewPoseEstimator> estimator_;
  InstanceRenderer instance_renderer_;
  bool estimator_uses_color_ = false;
  std::vector<VariantState> variants_;
  std::vector<StampedPose> trajectory_;
  std::vector<int> evaluated_frames_;
  std::map<int, std::string> model_errors_;  // class -> why its model could not be loaded
  PipelineFrameResult result_;
  PipelineStats stats_;
  bool first_frame_ = true;
  std::deque<PendingKeyframe> pending_;  // delayed keyframes, oldest first
  const RgbdFrame* segmented_frame_ = nullptr;
  std::shared_ptr<const RgbdFrame> segmented_frame_hold_;
  SE3 segmented_T_world_cam_;
  std::unique_ptr<SegmentationWorker> worker_;  // last: stops before the back-end it calls goes
};

}  // namespace orpe
