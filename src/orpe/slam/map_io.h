// Surfel map output: the map as a point cloud (io/point_cloud_io.h), written as binary PLY with one
// vertex per surfel -- x y z (world, m), nx ny nz, red green blue, radius (m), confidence,
// instance_id (0 = none) -- atomically (temporary file + rename): a crash never leaves a half map.
#pragma once

#include <string>

#include "orpe/core/se3.h"
#include "orpe/io/point_cloud_io.h"
#include "orpe/slam/map_renderer.h"
#include "orpe/slam/surfel_map.h"

namespace orpe::slam {

/// The surfels with confidence >= min_confidence (0: all) as a point cloud: positions, normals,
/// colours, radii, confidences and instance ids (class ids left empty).
PointCloudData surfel_map_cloud(const SurfelMap& map, float min_confidence = 0.0f);

/// Writes surfel_map_cloud(map, min_confidence) to `path`. Returns the number of surfels written.
/// Throws IoError naming `path` on failure.
size_t write_surfel_ply(const std::string& path, const SurfelMap& map, float min_confidence = 0.0f);

/// An overview viewpoint of the map for pictures: behind and above the given camera pose, looking
/// at the centroid of the stable surfels. `back_m` / `up_m` move along that camera's -z / -y axes.
SE3 overview_pose(const SurfelMap& map, const SE3& T_world_cam, float min_confidence, double back_m,
                  double up_m);

/// The part of the map a picture should show: the box of the surfels that belong to an object
/// instance (instance_id > 0) when there are at least `min_points` of them, else of all surfels
/// with confidence >= min_confidence; per axis from the 2nd to the 98th percentile, so that a few
/// stray far surfels (a wall seen through a window) do not shrink the scene to a dot. Empty when
/// the map has fewer than `min_points` such surfels.
Eigen::AlignedBox3d map_focus_box(const SurfelMap& map, float min_confidence,
                                  size_t min_points = 50);

/// A viewpoint that frames `box` (world): it looks at the box's centre from the side the given
/// camera saw it from (that camera's viewing direction, tilted `elevation_deg` further down about
/// its x axis, with its up vector), at the nearest distance at which all eight corners project
/// into the central `fill` fraction of the image of K (in width and height).
SE3 framing_pose(const Eigen::AlignedBox3d& box, const SE3& T_world_cam, const PinholeIntrinsics& K,
                 double elevation_deg = 25, double fill = 0.9);

/// Renders the map (surfel colours, shaded by the normal for depth cues) into an RGB image; empty
/// pixels get `background`.
ColorImage render_map_image(MapRenderer& renderer, const SurfelMap& map, const SE3& T_world_cam,
                            const PinholeIntrinsics& K, float min_confidence,
                            Rgb8 background = {255, 255, 255});

}  // namespace orpe::slam
