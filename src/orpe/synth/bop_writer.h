// BOP-format output (https://github.com/thodan/bop_toolkit/blob/master/docs/bop_datasets_format.md)
// of one scene folder, with the models folder inside it:
//   DIR/scene_camera.json   {"<im_id>": {"cam_K": [9, row-major], "depth_scale": s, "cam_R_w2c":
//   [9], "cam_t_w2c": [3, mm]}} DIR/scene_gt.json       {"<im_id>": [{"cam_R_m2c": [9],
//   "cam_t_m2c": [3, mm], "obj_id": id}, ...]} DIR/scene_gt_info.json  {"<im_id>": [{"bbox_obj",
//   "bbox_visib", "px_count_all", "px_count_valid",
//                                         "px_count_visib", "visib_fract"}, ...]}
//   DIR/models/obj_XXXXXX.ply (mm, normals, vertex colours, texture_u/v + obj_XXXXXX.png when
//   textured), DIR/models/obj_XXXXXX_points.xyz (metres, surface samples for ADD/ADD-S),
//   DIR/models/models_info.json DIR/groundtruth.txt (TUM: timestamp tx ty tz qx qy qz qw,
//   camera-to-world, metres)
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
  std::vector<SE3> T_cam_obj;  ///< per GT entry
  std::vector<int> obj_ids;    ///< per GT entry
  std::vector<ObjectFrameInfo> info;
  std::vector<SE3> T_cam_distractor;  ///< per distractor (distractor_id = index + 1)
  std::vector<ObjectFrameInfo> distractor_info;
};

/// Writes obj_XXXXXX.ply (+ texture), obj_XXXXXX_points.xyz and models_info.json for types[i] as
/// obj_id i + 1.
void write_bop_models(const std::string& models_dir, const std::vector<ObjectModel>& types,
                      int points_per_model, std::uint64_t seed);

/// scene_camera.json, scene_gt.json, scene_gt_info.json (image ids = record index).
void write_bop_scene_json(const std::string& dir, const PinholeIntrinsics& K,
                          double depth_scale_mm_per_unit,
                          const std::vector<BopFrameRecord>& frames);

/// Not BOP (its readers ignore them): scene_gt_distractors.json and
/// scene_gt_info_distractors.json, the distractors' poses and visibility in the format of
/// scene_gt.json / scene_gt_info.json with "distractor_id" in place of "obj_id".
void write_distractor_json(const std::string& dir, const std::vector<BopFrameRecord>& frames);

/// TUM trajectory: `timestamp tx ty tz qx qy qz qw`, camera-to-world, metres.
void write_tum_trajectory(const std::string& path, const std::vector<BopFrameRecord>& frames);

/// BOP naming helpers: 6-digit zero-padded ids.
std::string bop_image_name(int im_id);               ///< "000042"
std::string bop_mask_name(int im_id, int gt_index);  ///< "000042_000003"

}  // namespace orpe::synth
