// Surfel map output: binary PLY (little endian) with one vertex per surfel.
//
//   element vertex N
//   property float x y z            (world frame, m)
//   property float nx ny nz         (unit normal, world frame)
//   property uchar red green blue
//   property float radius           (m)
//   property float confidence
//   property int instance_id        (0 = none)
//
// Written atomically (temporary file + rename): a crash never leaves a half-written map.
#pragma once

#include <string>

#include "orpe/core/se3.h"
#include "orpe/slam/map_renderer.h"
#include "orpe/slam/surfel_map.h"

namespace orpe::slam {

/// Writes the surfels with confidence >= min_confidence (0: all). Returns the number written.
/// Throws IoError naming `path` on failure.
size_t write_surfel_ply(const std::string& path, const SurfelMap& map, float min_confidence = 0.0f);

/// A camera pose at `eye` looking at `target` (camera y axis as close to `down_world` as possible).
SE3 look_at(const Vec3& eye, const Vec3& target, const Vec3& down_world);

/// An overview viewpoint of the map for pictures: behind and above the given camera pose, looking
/// at the centroid of the stable surfels. `back_m` / `up_m` move along that camera's -z / -y axes.
SE3 overview_pose(const SurfelMap& map, const SE3& T_world_cam, float min_confidence, double back_m,
                  double up_m);

/// Renders the map (surfel colours, shaded by the normal for depth cues) into an RGB image; empty
/// pixels get `background`.
ColorImage render_map_image(MapRenderer& renderer, const SurfelMap& map, const SE3& T_world_cam,
                            const PinholeIntrinsics& K, float min_confidence, Rgb8 background = {255, 255, 255});

}  // namespace orpe::slam
