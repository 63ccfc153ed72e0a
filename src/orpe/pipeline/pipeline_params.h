// Switches of the Object-RPE pipeline (config section "pipeline"): which inputs the single-view
// pose estimator gets, whether the per-object EKF runs, on which frames poses are estimated, and
// run options.
//
// The ablation of the paper (Table II) as named configurations of the four input switches:
//
//   name          | mask      | depth     | colour    | EKF
//   DF            | detection | camera    | camera    | off
//   DF-PM         | projected | camera    | camera    | off
//   DF-PM-PD      | projected | projected | camera    | off
//   DF-PM-PD-PC   | projected | projected | projected | off
//   Object-RPE    | projected | projected | projected | on
//
// "DF" is the single-view estimator in use (the paper's DenseFusion). Until a learned back-end
// exists it is the model-based registration of the pose stage (pose/model_registration.h), which
// uses geometry only: DF-PM-PD and DF-PM-PD-PC then give identical single-view poses. "Projected"
// inputs are rendered from the semantic surfel map at the tracked camera pose
// (SemanticMapper::render_instance_views).
#pragma once

#include <string>
#include <vector>

namespace orpe {

struct PipelineParams {
  bool use_projected_mask = true;   ///< PM: masks rendered from the map instead of the detections
  bool use_projected_depth = true;  ///< PD: depth rendered from the map instead of the camera's
  bool use_projected_color = true;  ///< PC: colour rendered from the map instead of the camera's
  bool use_ekf = true;              ///< fuse single-view poses per instance with the SE(3) EKF
  /// Single-view pose runs on every n-th keyframe of the segmentation (its keyframe policy decides
  /// which frames are keyframes); these are the "evaluated frames" of poses.csv.
  int pose_every_n_keyframes = 1;
  /// Instances / detections with a smaller mask (pixels) get no single-view estimate. 0 = auto:
  /// 200 at 640 x 480 and larger images, scaled down by the image's area below (50 at 320 x 240),
  /// so that a low-resolution camera keeps the small objects a 640 x 480 one estimates
  /// (min_pose_mask_px_for()).
  int min_pose_mask_px = 0;
  /// EKF, projected masks: a map instance whose projected mask has at least this many pixels, but
  /// fewer than min_pose_mask_px, gets no single-view estimate, yet its fused pose is reported (the
  /// map knows where the object is, the estimator cannot work on so few pixels); 50 = the semantic
  /// stage's visibility threshold (semantic.min_visible_area_px). 0 = off.
  int ekf_report_min_mask_px = 50;
  /// Projected-mask modes: only instances detected in at least this many keyframes get a pose.
  int min_instance_detections = 1;
  /// Only instances (projected modes) or detections (raw masks) whose class probability reaches
  /// this.
  double min_class_probability = 0.0;
  /// Symmetry group each object's EKF uses to compare a measurement with its state:
  /// "geometric" = the model's detected shape symmetry (pose stage), "dataset" = only for the
  /// dataset's symmetric classes (those scored with ADD-S): the dataset's annotated group (BOP
  /// models_info.json) when it has one, else the detected one; "none" = no symmetry (the paper).
  std::string ekf_symmetry = "dataset";
  /// A folder of colour models (`orpe colour` writes them: <class name>.colour,
  /// pose/colour_score.h): a class with a file there uses it to rank the poses geometry confuses,
  /// in place of its mesh's own colour. Empty = none. Never colour a model from the frames it is
  /// then scored on.
  std::string model_colour_dir;
  /// Folder of the on-disk cache of prepared object models (pipeline/model_cache.h): a run reads a
  /// model it prepared before from there instead of parsing, sampling and analysing its files
  /// again; the same model bit for bit, so outputs do not depend on it. "auto" = $ORPE_CACHE_DIR
  /// when set (set and empty: off), else $XDG_CACHE_HOME/orpe/models, else
  /// $HOME/.cache/orpe/models; "" or "none" = off. A folder that cannot be written: one warning,
  /// the run goes on uncached.
  std::string model_cache_dir = "auto";
  /// EKF initialisation from a consensus of this many first valid measurements (pipeline/
  /// object_fusion.h); 1 = from the first measurement (the paper).
  int ekf_init_views = 5;
  /// Stop collecting the start's views as soon as a strict majority of ekf_init_views agree (one
  /// view and floor(ekf_init_views / 2) others pass the gate against it) and each view so far was
  /// decisive (geometry or colour singled its pose out: pose_registration.colour_learn_min_*
  /// margins): the rest could not outvote them, so they are fused as later views and estimated
  /// from the fused pose (prior fast path) instead of by global searches. false = always collect
  /// all ekf_init_views (the default). Off by default: on the three YCB clips it kept the accuracy
  /// but saved little, and on a synthetic textured table scene (test FusionGain.*) it cost the
  /// fused poses ~1 point of ADD AUC. Measured: docs/PIPELINE.md, "EKF: consensus start".
  bool ekf_init_majority_stop = false;
  /// Prior fast path (EKF variants; a deviation, docs/PIPELINE.md): an object whose filter has a
  /// state gives the single-view estimator its fused pose, moved into the camera, as the prior;
  /// with pose_registration.prior_refinement the estimator refines it locally and runs the global
  /// search only when it does not fit. Rule that keeps the filter's modes honest: at most
  /// prior_max_consecutive estimates in a row per object come from the prior (the next one is a
  /// global search, an independent vote), and a prior-refined measurement counts
  /// prior_mode_weight times a global one in the competition of the filter's modes (0: it refines
  /// the mode it came from and never votes for it). false = every estimate is a global search (the
  /// paper). Off from session 7 to 18 (then it lowered Object-RPE's ADD(-S) AUC on the three YCB
  /// clips: one ambiguous box kept its first mode); on since session 19, with
  /// pose_registration.prior_flips: on the same clips ADD-S unchanged, ADD(-S) per frame / final
  /// 59.5 / 57.8 -> 62.0 / 63.0 (degraded masks), 61.3 / 57.4 -> 61.4 / 64.5 (exact), single view
  /// 107 -> 76 ms per frame (docs/PIPELINE.md, docs/BENCHMARKS.md).
  bool ekf_prior_hypothesis = true;
  int prior_max_consecutive = 2;
  /// Back-off of the recurring global search (session 23): a global search whose measurement the
  /// filter takes into its reported mode (no switch) doubles the object's allowance of estimates in
  /// a row from the prior, up to prior_max_consecutive_limit; one that is rejected, invalid or
  /// makes the report switch sets it back to prior_max_consecutive. Independent votes stay
  /// frequent while the modes are contested and become rarer while they agree.
  /// prior_max_consecutive_limit <= prior_max_consecutive: no back-off (sessions 7-22).
  int prior_max_consecutive_limit = 8;
  double prior_mode_weight = 0.0;
  /// Skip rule (EKF variants; a deviation, docs/PIPELINE.md): an object is not re-estimated on an
  /// evaluated frame when its filter has fused at least skip_min_fused_views views, its last
  /// single-view estimate passed the gate, the camera moved less than skip_max_translation_m and
  /// skip_max_rotation_deg since that estimate, and fewer than skip_max_consecutive frames in a row
  /// were skipped; its fused pose is reported. skip_min_fused_views = 0 turns the rule off.
  int skip_min_fused_views = 5;
  double skip_max_translation_m = 0.03;
  double skip_max_rotation_deg = 3.0;
  int skip_max_consecutive = 3;
  /// Projected depth / colour: the map is rendered only in the window of the instances' splats
  /// grown by this many pixels (the registration's free-space and support tests look around the
  /// mask); pixels outside it are empty.
  int render_margin_px = 40;
  /// Keyframe segmentation delay (docs/PIPELINE.md "Asynchronous segmentation"): the detections of
  /// a keyframe are fused into the semantic map, and its poses estimated, this many frames later
  /// (on the keyframe's own images and camera pose; the map has those frames more). 0 = on the
  /// keyframe itself (the paper). The delay, not the timing, decides the results: a batch run is
  /// byte-identical whether the back-end runs on its own thread or not, however slow it is.
  int segmentation_delay_frames = 0;
  /// With a delay > 0, run the segmentation back-end on its own thread, so that tracking goes on
  /// while it works; the pipeline waits only when a keyframe's delay is up and its detections are
  /// not ready. false = the back-end runs on the pipeline's thread when the delay is up.
  bool segmentation_async = true;
  /// Start the SLAM at the first frame's ground-truth camera pose when the dataset has one, so that
  /// the trajectory and world poses are in the dataset's world frame; else the first camera is the
  /// world.
  bool init_from_ground_truth = true;
  /// map.ply / semantic_map.ply: write surfels with at least this confidence (0 = all).
  double output_min_confidence = 0.0;
  /// Terminal progress line every n frames (0 = none).
  int progress_every_n_frames = 1;

  template <class V>
  void visit(V&& v) {
    v("use_projected_mask", use_projected_mask,
      "PM: single-view pose on the instance mask rendered from the map (else the detection's "
      "mask)");
    v("use_projected_depth", use_projected_depth,
      "PD: single-view pose on the depth rendered from the map (else the camera's depth)");
    v("use_projected_color", use_projected_color,
      "PC: single-view pose on the colour rendered from the map (else the camera's colour)");
    v("use_ekf", use_ekf, "Fuse single-view poses per object instance with the SE(3) EKF");
    v("pose_every_n_keyframes", pose_every_n_keyframes,
      "Estimate poses on every n-th segmentation keyframe (the evaluated frames)");
    v("min_pose_mask_px", min_pose_mask_px,
      "Masks with fewer pixels get no pose estimate; 0 = auto: 200 at 640 x 480 and above, scaled "
      "down by the image area below (50 at 320 x 240)");
    v("ekf_report_min_mask_px", ekf_report_min_mask_px,
      "EKF with projected masks: report the fused pose of instances whose projected mask has at "
      "least this many pixels but too few for a single-view estimate (0 = off)");
    v("min_instance_detections", min_instance_detections,
      "Projected masks: only instances detected in at least this many keyframes get a pose");
    v("min_class_probability", min_class_probability,
      "Only instances / detections whose class probability reaches this get a pose, in [0, 1]");
    v("ekf_symmetry", ekf_symmetry,
      "Symmetry the EKF uses: geometric (detected shape symmetry) | dataset (only for the "
      "dataset's "
      "symmetric classes; their annotated group when the dataset has one) | none");
    v("model_colour_dir", model_colour_dir,
      "Folder of colour models (<class name>.colour, from `orpe colour`) that replace the models' "
      "own colour; empty = none");
    v("model_cache_dir", model_cache_dir,
      "Folder of the cache of prepared object models (same models bit for bit, loaded faster): "
      "auto = $ORPE_CACHE_DIR, else $XDG_CACHE_HOME/orpe/models, else ~/.cache/orpe/models; "
      "empty or none = off");
    v("ekf_init_views", ekf_init_views,
      "Start each object's EKF from the consensus of this many first measurements (1 = the first)");
    v("ekf_init_majority_stop", ekf_init_majority_stop,
      "Start the EKF as soon as a strict majority of ekf_init_views agree and each view so far "
      "was decisive (the rest could not outvote them); false = always collect all "
      "ekf_init_views");
    v("ekf_prior_hypothesis", ekf_prior_hypothesis,
      "Give the single-view estimator the EKF pose as a prior: refined locally, the global "
      "search only when it does not fit (pose_registration.prior_*; paper: off)");
    v("prior_max_consecutive", prior_max_consecutive,
      "Prior fast path: at most this many estimates in a row per object from the prior; the next "
      "is a global search (0 = never from the prior)");
    v("prior_max_consecutive_limit", prior_max_consecutive_limit,
      "Prior fast path: a global search that agrees with the fused mode doubles the object's "
      "allowance of estimates in a row from the prior, up to this; a disagreeing one resets it "
      "to prior_max_consecutive (<= prior_max_consecutive: no back-off)");
    v("prior_mode_weight", prior_mode_weight,
      "Prior fast path: weight of a prior-refined measurement in the competition of the EKF's "
      "modes, relative to a global search's (0 = refines its mode, never votes)");
    v("skip_min_fused_views", skip_min_fused_views,
      "EKF: skip the single-view estimate of an object whose filter fused at least this many "
      "views, whose last estimate passed the gate and whose view barely changed (0 = never skip)");
    v("skip_max_translation_m", skip_max_translation_m,
      "Skip rule: the camera moved less than this (m) since the object's last estimate");
    v("skip_max_rotation_deg", skip_max_rotation_deg,
      "Skip rule: the camera turned less than this (degrees) since the object's last estimate");
    v("skip_max_consecutive", skip_max_consecutive,
      "Skip rule: at most this many evaluated frames in a row are skipped per object");
    v("render_margin_px", render_margin_px,
      "Projected depth / colour rendered only within this many pixels of the instances' splats");
    v("segmentation_delay_frames", segmentation_delay_frames,
      "Fuse each keyframe's detections (and estimate its poses) this many frames later; with "
      "segmentation_async the back-end runs meanwhile on its own thread (0 = on the keyframe)");
    v("segmentation_async", segmentation_async,
      "With a delay > 0: segment on a background thread while tracking goes on (results do not "
      "depend on it)");
    v("init_from_ground_truth", init_from_ground_truth,
      "Start the SLAM at the first frame's ground-truth camera pose when there is one");
    v("output_min_confidence", output_min_confidence,
      "map.ply / semantic_map.ply keep surfels with at least this confidence (0 = all)");
    v("progress_every_n_frames", progress_every_n_frames,
      "Progress line every n frames (0 = none)");
  }
  bool IsValid(std::string* why) const;
  /// The mask threshold in pixels for a width x height image (min_pose_mask_px, or its auto value).
  int min_pose_mask_px_for(int width, int height) const;

  /// The named ablation configurations, in table order.
  static const std::vector<std::string>& ablation_names();
  /// Sets the four switches to a named configuration. Throws ConfigError for an unknown name.
  void apply_ablation(const std::string& name);
  /// The name of the configuration the switches form, or "custom".
  std::string ablation_name() const;
};

}  // namespace orpe
