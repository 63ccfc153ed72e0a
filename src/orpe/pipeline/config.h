// The effective configuration of a run: every stage's Params, loaded from defaults, a JSON config
// file and `--set section.key=value` overrides, in that order. Echoed into every run summary.
#pragma once

#include <string>
#include <vector>

#include "orpe/core/params.h"
#include "orpe/eval/bop_pose_metrics.h"
#include "orpe/eval/mask_metrics.h"
#include "orpe/eval/pose_metrics.h"
#include "orpe/eval/trajectory_metrics.h"
#include "orpe/io/dataset.h"
#include "orpe/pipeline/pipeline_params.h"
#include "orpe/pose/model_registration.h"
#include "orpe/pose/pose_backend.h"
#include "orpe/pose/pose_ekf.h"
#include "orpe/recognition/model_recognizer.h"
#include "orpe/semantic/segmenter.h"
#include "orpe/semantic/semantic_fusion.h"
#include "orpe/slam/slam_system.h"
#include "orpe/synth/synth_params.h"

namespace orpe {

struct OrpeConfig {
  DatasetParams dataset;
  TrajectoryMetricsParams eval_trajectory;
  PoseMetricsParams eval_pose;
  BopPoseMetricsParams eval_bop;  ///< `orpe eval poses --bop`: VSD / MSSD / MSPD average recall
  MaskMetricsParams eval_masks;
  slam::SlamOptions slam;                  ///< dense SLAM system options
  slam::PreprocessParams slam_preprocess;  ///< SLAM depth filter / pyramids
  slam::TrackerParams slam_tracking;       ///< SLAM frame-to-model tracking
  slam::FusionParams slam_fusion;          ///< SLAM surfel fusion
  slam::RelocaliserParams slam_reloc;      ///< SLAM relocalisation after tracking loss
  slam::LoopClosureParams slam_loop;       ///< SLAM loop closure

  /// The SLAM system's parameters assembled from the slam* sections.
  slam::SlamParams slam_params() const {
    return {slam_preprocess, slam_tracking, slam_fusion, slam, slam_reloc, slam_loop};
  }
  SegmentationParams segmentation;  ///< 2D instance segmentation back-end and keyframe policy
  SemanticParams semantic;          ///< instance-aware semantic fusion
  RecognitionParams recognition;    ///< segmentation.backend=model: hypotheses and verification
  SceneGeometryParams recognition_geometry;  ///< segmentation.backend=model: planes and regions
  PoseBackendParams pose;                    ///< single-view pose back-end (model | densefusion)
  ModelRegistrationParams pose_registration;
  PoseEkfParams pose_ekf;
  SynthParams synth;
  PipelineParams
      pipeline;  ///< Object-RPE pipeline switches (ablation inputs, EKF, evaluated frames)

  /// Visits (section name, Params&) for every stage. Add a stage's Params here and nowhere else.
  template <class V>
  void visit_sections(V&& v) {
    v("dataset", dataset);
    v("eval_trajectory", eval_trajectory);
    v("eval_pose", eval_pose);
    v("eval_bop", eval_bop);
    v("eval_masks", eval_masks);
    v("slam", slam);
    v("slam_preprocess", slam_preprocess);
    v("slam_tracking", slam_tracking);
    v("slam_fusion", slam_fusion);
    v("slam_reloc", slam_reloc);
    v("slam_loop", slam_loop);
    v("segmentation", segmentation);
    v("semantic", semantic);
    v("recognition", recognition);
    v("recognition_geometry", recognition_geometry);
    v("pose", pose);
    v("pose_registration", pose_registration);
    v("pose_ekf", pose_ekf);
    v("synth", synth);
    v("pipeline", pipeline);
  }

  bool IsValid(std::string* why) const;
};

/// Applies a config file: JSON ({"section": {"key": value}}), or YAML (.yaml / .yml: `section:`
/// then indented `key: value` lines, each value parsed by the key's type as `--set` does). Unknown
/// sections / keys and wrong types are IoErrors naming the file (and, for YAML, the line).
void load_config_file(OrpeConfig& config, const std::string& path);
/// Applies one "section.key=value" override. Throws ConfigError for unknown keys or bad values.
void apply_config_override(OrpeConfig& config, const std::string& assignment);
/// Named presets (applied before a config file and overrides):
///  - "default": the documented defaults (ElasticFusion's constants where they apply).
///  - "realtime": SLAM at >= 15 frames/s at 640x480 on two CPU cores -- level-0 tracking on every
///  2nd
///    row and column (slam_tracking.level0_pixel_step=2), 5 instead of 10 level-0 iterations, and
///    fusion at half resolution (slam_fusion.fusion_level=1: a 4x sparser map). Measured on
///    7-Scenes: same ATE, 2.3x faster (docs/BENCHMARKS.md).
std::vector<std::string> config_preset_names();
/// Applies the preset `name` to `config`. Throws ConfigError for an unknown name.
void apply_config_preset(OrpeConfig& config, const std::string& name);
/// Every parameter with its current value and documentation.
std::vector<ParamDoc> describe_config(const OrpeConfig& config);
/// The configuration as pretty-printed JSON.
std::string config_to_json(const OrpeConfig& config);

}  // namespace orpe
