// BOP-format output (https://github.com/thodan/bop_toolkit/blob/master/docs/bop_datasets_format.md)
// of a one-scene dataset, where bop_toolkit expects the files:
//   DATASET/camera.json, DATASET/models/ (obj_XXXXXX.ply in mm with normals, vertex colours,
//     texture_u/v + obj_XXXXXX.png when textured; obj_XXXXXX_points.xyz in metres for ADD/ADD-S;
//     models_info.json), DATASET/test_targets_bop19.json,
//   DATASET/test/000000/ (bop_scene_dir): scene_camera.json {"<im_id>": {"cam_K", "depth_scale",
//     "cam_R_w2c", "cam_t_w2c" (mm)}}, scene_gt.json {"<im_id>": [{"cam_R_m2c", "cam_t_m2c" (mm),
//     "obj_id"}]}, scene_gt_info.json {"<im_id>": [{"bbox_obj", "bbox_visib", "px_count_all",
//     "px_count_valid", "px_count_visib", "visib_fract"}]}, groundtruth.txt (TUM: timestamp tx ty
//     tz qx qy qz qw, camera-to-world, metres).
// All files are written atomically. depth_scale: depth in mm = raw * depth_scale.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "orpe/core/camera.h"
#include "orpe/synth/generator.h"

namespace orpe::synth {

struct BopFrameRecord {
  double timestamp_s = 0;
  SE3 T_world_cam;
  bool has_camera_pose = true;  ///< false: no cam_R_w2c / cam_t_w2c (a recording without them)
  std::vector<SE3> T_cam_obj;  ///< per GT entry
  std::vector<int> obj_ids;    ///< per GT entry
  std::vector<ObjectFrameInfo> info;
  std::vector<SE3> T_cam_distractor;  ///< per distractor (distractor_id = index + 1)
  std::vector<ObjectFrameInfo> distractor_info;
};

/// Writes obj_XXXXXX.ply (+ texture), obj_XXXXXX_points.xyz and models_info.json for types[i] as
/// obj_id obj_ids[i] (i + 1 when obj_ids is empty).
void write_bop_models(const std::string& models_dir, const std::vector<ObjectModel>& types,
                      int points_per_model, std::uint64_t seed,
                      const std::vector<int>& obj_ids = {});

/// scene_camera.json, scene_gt.json, scene_gt_info.json (image ids = record index).
void write_bop_scene_json(const std::string& dir, const PinholeIntrinsics& K,
                          double depth_scale_mm_per_unit,
                          const std::vector<BopFrameRecord>& frames);

/// Not BOP (its readers ignore them): scene_gt_distractors.json and
/// scene_gt_info_distractors.json, the distractors' poses and visibility in the format of
/// scene_gt.json / scene_gt_info.json with "distractor_id" in place of "obj_id".
void write_distractor_json(const std::string& dir, const std::vector<BopFrameRecord>& frames);

/// The split and scene orpe synth writes: a BOP dataset root holds its scene in test/000000.
constexpr int kBopSceneId = 0;
std::string bop_scene_dir(const std::string& dataset_dir);  ///< dataset_dir + "/test/000000"

/// BOP's visibility rule for targets (bop_toolkit: visib_fract >= 0.1).
constexpr double kBopTargetMinVisib = 0.1;

/// test_targets_bop19.json: per image and object, the number of instances at least
/// `min_visib_fract` visible: [{"im_id", "inst_count", "obj_id", "scene_id"}, ...].
void write_bop_targets(const std::string& path, int scene_id,
                       const std::vector<BopFrameRecord>& frames, double min_visib_fract);

/// TUM trajectory: `timestamp tx ty tz qx qy qz qw`, camera-to-world, metres.
void write_tum_trajectory(const std::string& path, const std::vector<BopFrameRecord>& frames);

/// BOP naming helpers: 6-digit zero-padded ids.
std::string bop_image_name(int im_id);               ///< "000042"
std::string bop_mask_name(int im_id, int gt_index);  ///< "000042_000003"

}  // namespace orpe::synth
