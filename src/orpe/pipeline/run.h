// `orpe run`: a whole dataset through the pipeline, with every output written atomically.
//
//  OUT/trajectory.txt        TUM trajectory (T_world_cam per frame; timestamps of the dataset)
//  OUT/frames.csv           per processed frame: tracking state, map size, memory, time per stage
//                            (pipeline/frame_log.h)
//  OUT/map.ply               the surfel map (position, normal, colour, radius, confidence,
//  instance) OUT/summary.json          timings per stage, counts, map bytes, peak memory, ATE (when
//  the
//                            dataset has camera ground truth), the effective configuration
//  semantic and full modes:
//  OUT/semantic_map.ply      surfels with instance and class ids (semantic/semantic_output.h)
//  OUT/semantic_map_instances.ply  the same, coloured by instance
//  OUT/instances.json        per instance: class distribution, surfels, box, detections
//  OUT/masks/                (RunOptions::write_masks) per keyframe the detections' and the map's
//                            projected instance masks, for `orpe eval masks` (eval/mask_run.h)
//  full mode:
//  OUT/poses.csv             BOP results: one row per object per evaluated frame (camera frame)
//  OUT/poses_final.csv       (EKF) the final fused world poses moved into each evaluated frame
//  OUT/objects.json          per instance: class, world pose, covariance, number of fused views
//  OUT/single_view.csv      every single-view estimate with the tracked camera pose
//  (write_single_view_csv) OUT/evaluated_frames.txt  the frames with pose estimates, as a keyframe
//  list (scene/frame per line) OUT/ablation/<name>/{poses.csv, poses_final.csv, objects.json}  per
//  configuration named in
//                            RunOptions::ablations (the first-listed one is also written to OUT/)
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "orpe/pipeline/config.h"
#include "orpe/pipeline/object_rpe.h"

namespace orpe {

struct RunOptions {
  std::string dataset_path;
  std::string out_dir;
  std::string mode = "full";  ///< slam | semantic | full
  /// Pose configurations (ablation names) to run in one pass; empty = config.pipeline's switches.
  /// The first one is the primary, written to OUT/ directly.
  std::vector<std::string> ablations;
  /// Also render the final map to this PNG (relative to out_dir unless absolute); empty = no
  /// picture. The viewpoint frames the objects' surfels (else the map's; slam::map_focus_box) from
  /// the first camera's side, 25 deg higher (slam::framing_pose). When view_back_m or view_up_m is
  /// > 0 it is instead behind (view_back_m along the first camera's -z) and above (view_up_m along
  /// its -y) the first camera, looking at the centroid of the written surfels.
  std::string render_view;
  double view_back_m = 0;
  double view_up_m = 0;
  /// semantic / full: also write per-keyframe input and projected instance masks to OUT/masks/.
  bool write_masks = false;
  /// The command line that started the run, recorded in summary.json (provenance.command).
  std::string command_line;
  /// Called with each progress line; null = spdlog::info.
  std::function<void(const std::string&)> progress;
  /// Replace an existing out_dir that holds a previous run (else an out_dir that is not empty is
  /// refused before the first frame).
  bool overwrite = false;
  /// Polled at every frame boundary; true = stop there and write the outputs of the frames so far,
  /// marked "interrupted" in summary.json (RunSummary::interrupted). Null = never.
  std::function<bool()> stop_requested;
};

struct RunSummary {
  std::string out_dir;
  std::string mode;
  int frames = 0;
  int skipped_frames = 0;
  int instances = 0;
  size_t surfels = 0;
  std::vector<std::string> variants;
  std::vector<size_t> pose_rows;  ///< per variant
  PipelineStats stats;
  double read_ms = 0, output_ms = 0, wall_ms = 0;
  double peak_rss_mb = 0;
  size_t map_bytes = 0;
  std::optional<double> ate_rmse_m;  ///< when the dataset has camera ground truth
  /// The same without the rows of LOST frames (their held poses), when there were any.
  std::optional<double> ate_tracked_rmse_m;
  int lost_rows = 0;  ///< trajectory rows of LOST frames
  std::vector<std::string> files;    ///< written, relative to out_dir
  bool interrupted = false;          ///< stopped early by RunOptions::stop_requested
  int no_depth_frames = 0;           ///< frames with too little valid depth (not tracked)
  int wrong_size_frames = 0;         ///< frames of another size than the first (skipped)
  std::string report() const;
};

/// Runs the pipeline over the dataset at options.dataset_path (config.dataset selects the scene and
/// frames) and writes the outputs above. Throws IoError / ConfigError with the file and the
/// problem. The outputs form one set: they are written into a staging folder next to out_dir, which
/// replaces out_dir at the end (core/staged_dir.h), so a failed or killed run leaves the previous
/// out_dir as it was. The output folder and the --render-view name are checked before the first
/// frame. A frame of another size than the first is skipped with a warning; a run where no frame
/// had usable depth is an IoError.
RunSummary run_object_rpe(const OrpeConfig& config, const RunOptions& options);

/// single_view.csv: every single-view estimate of a variant, one line each:
/// frame,instance,class,class_probability,valid,score,mu_m,inlier_fraction,num_points,
/// R_cam_obj (9 values row-major, spaces),t_cam_obj_m (3),R_world_cam (9),t_world_cam_m (3),mask_px
void write_single_view_csv(const std::string& path,
                           const std::vector<ObjectRpePipeline::SingleViewRecord>& records);

/// objects.json text for a set of final object poses.
std::string object_poses_json(const std::vector<ObjectWorldPose>& objects,
                              const PoseVariant& variant);

}  // namespace orpe
