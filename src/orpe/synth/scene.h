// Scene composition: an environment (floor, table or warehouse shelf) and object instances resting
// stably on its surfaces or on each other, without interpenetration.
//
// World frame: z up, the floor at z = 0. Each object rests in one of its RestingPoses, turned about
// the vertical, its lowest point on the support surface. Non-interpenetration is guaranteed
// conservatively: every object lies inside its prism (convex footprint x [bottom, top]), and no two
// prisms overlap (separating-axis test on the footprints with a gap, or disjoint height ranges);
// objects stand fully inside their support surface (shrunk by a margin) and below the next shelf.
#pragma once

#include <memory>
#include <random>
#include <string>
#include <vector>

#include "orpe/synth/objects.h"

namespace orpe::synth {

/// A horizontal convex support region.
struct SupportSurface {
  std::vector<Eigen::Vector2d> polygon;  ///< CCW, world xy (m)
  double height_m = 0;                   ///< z of the surface
  double clearance_m = 1e9;              ///< free height above it (shelf levels)
  int owner = -1;                        ///< -1 environment, else the instance standing below
};

struct ObjectInstance {
  int type = 0;  ///< index into SynthScene::types (obj_id = type + 1)
  SE3 T_world_obj;
  int resting_pose = 0;                          ///< index into the type's resting poses
  int support = -1;                              ///< index into SynthScene::supports
  std::vector<Eigen::Vector2d> footprint_world;  ///< convex, world xy
  double bottom_m = 0, top_m = 0;                ///< height range of the prism
};

/// One environment part (rendered with id 0).
struct EnvironmentPart {
  std::shared_ptr<const TriangleMesh> mesh;
  SE3 T_world_part;
};

struct SceneLayoutParams {
  std::string kind = "floor";      ///< floor | table | shelf | room
  int max_attempts = 400;          ///< placement tries per object before it is dropped
  double min_gap_m = 0.005;        ///< clearance between neighbouring prisms
  double edge_margin_m = 0.01;     ///< objects stay this far inside their support's edges
  double stack_probability = 0.3;  ///< chance to try standing on another object's top first
  double floor_fill =
      0.45;  ///< floor scene: objects' footprint area / area of the region they share
};

struct SynthScene {
  std::string kind;
  std::vector<ObjectModel> types;
  std::vector<ObjectInstance> objects;
  std::vector<EnvironmentPart> environment;
  std::vector<SupportSurface> supports;
  Vec3 centre_world = Vec3::Zero();  ///< where the camera looks (centre of the objects' bounds)
  double radius_m = 0.5;             ///< radius of a sphere around centre_world holding all objects
  double view_azimuth_rad = 0;       ///< preferred camera azimuth (shelf: in front)
  double default_elevation_deg = 35;
  std::vector<std::string> warnings;  ///< e.g. objects that could not be placed
  /// Distractors: objects outside the model set (not targets). distractors[j].type indexes
  /// distractor_types; they do not move the camera's look-at point (centre_world, radius_m).
  std::vector<ObjectModel> distractor_types;
  std::vector<ObjectInstance> distractors;
};

/// Builds the environment of `kind` and places one instance per entry of `instance_types` (indices
/// into `types`). Pallets first, then by decreasing footprint. Objects that cannot be placed are
/// dropped (with a warning in the scene). Deterministic for a given generator state.
SynthScene build_scene(std::vector<ObjectModel> types, const std::vector<int>& instance_types,
                       const SceneLayoutParams& params, std::mt19937_64& rng);

/// Places one instance of each of `types` (distractors, in that order) into a built scene, with the
/// objects' rules (resting poses, supports, including the objects' tops) and clear of the objects
/// and of each other; nothing is stacked on a distractor. The objects do not move. Distractors that
/// find no place are dropped with a warning. Sets s.distractor_types and s.distractors.
void place_distractors(SynthScene& s, std::vector<ObjectModel> types,
                       const SceneLayoutParams& params, std::mt19937_64& rng);

/// The whole static scene as one mesh in the world frame (metres): the environment's parts, the
/// objects and the distractors, each moved by its pose. `orpe synth` writes it as scene_mesh.ply,
/// the ground truth of the map's geometry (`orpe eval map`).
TriangleMesh scene_mesh_world(const SynthScene& s);

/// True when two convex polygons are closer than `gap` (separating-axis test).
bool polygons_overlap(const std::vector<Eigen::Vector2d>& a, const std::vector<Eigen::Vector2d>& b,
                      double gap);

}  // namespace orpe::synth
