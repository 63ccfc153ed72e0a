// The 3D model of an object class as the pose stage uses it: surface points (metres, object frame),
// optional outward normals, its diameter, and its symmetry group.
//
// Symmetry: a transform S (object frame -> object frame) is a symmetry when the model maps onto
// itself, so T_cam_obj and T_cam_obj * S are equivalent poses. The group is
//   { C(theta) * D_k : D_k in `discrete` (identity included implicitly), theta in [0, 2 pi) }
// where C(theta) is the rotation by theta about the continuous axis when `continuous` is set, and
// the identity otherwise. A cylinder is (continuous axis) x {I, 180-degree flip}; a box is the
// discrete group {I, Rx(pi), Ry(pi), Rz(pi)}.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "orpe/core/se3.h"

namespace orpe {

class ModelSearchIndex;  // kd-tree over the model points (model_search.h)
struct ModelColour;      // surface samples with grey levels (colour_score.h)

enum class SymmetryKind { kNone, kDiscrete, kContinuous };

struct ObjectSymmetry {
  /// Discrete symmetries other than the identity, each T_obj_obj' (rotation about a point).
  std::vector<SE3> discrete;
  /// Continuous rotational symmetry about an axis through `axis_point_obj` (object frame).
  bool continuous = false;
  Vec3 axis_obj = Vec3::UnitZ();  ///< unit
  Vec3 axis_point_obj = Vec3::Zero();

  SymmetryKind kind() const {
    return continuous ? SymmetryKind::kContinuous
                      : (discrete.empty() ? SymmetryKind::kNone : SymmetryKind::kDiscrete);
  }
  /// Rotation by theta (rad) about the continuous axis, as T_obj_obj'.
  SE3 continuous_element(double theta_rad) const;
  /// Human-readable summary, e.g. "continuous about (0,0,1) + 1 discrete".
  std::string describe() const;
};

struct ObjectModel {
  int class_id = 0;
  std::string name;
  std::vector<Eigen::Vector3f> points;   ///< metres, object frame
  std::vector<Eigen::Vector3f> normals;  ///< unit, outward; empty or points.size()
  double diameter_m = 0;                 ///< max distance between two model points
  double mean_spacing_m = 0;             ///< mean distance of a point to its nearest other point
  /// Scored with ADD-S (not ADD) in ADD(-S): the dataset's list of symmetric classes.
  bool symmetric_for_metric = false;
  /// Geometric symmetry group, used by the EKF so that equivalent poses do not fight.
  ObjectSymmetry symmetry;
  /// kd-tree over `points`; built by prepare_object_model(). Shared between copies.
  std::shared_ptr<const ModelSearchIndex> search_index;
  /// Appearance (texture, vertex colours, or learned from views with known poses); null = none.
  /// Shared between copies; used to rank the poses geometry cannot separate (colour_score.h).
  std::shared_ptr<const ModelColour> colour;

  bool has_normals() const { return !normals.empty() && normals.size() == points.size(); }
  bool prepared() const { return search_index != nullptr && diameter_m > 0; }
};

/// Vertex positions (file units) and unit per-vertex normals of a mesh read by load_mesh
/// (render/mesh_io.h: any format assimp reads; normals from the file when present, else
/// area-weighted face normals; orientation follows the face winding). Throws IoError.
struct MeshVerticesNormals {
  std::vector<Eigen::Vector3f> vertices;
  std::vector<Eigen::Vector3f> normals;
};
MeshVerticesNormals read_obj_vertices_normals(const std::string& path);

struct ModelLoadOptions {
  /// Model file units per metre (YCB-Video points.xyz: 1; BOP PLY: 1000).
  double units_per_m = 1.0;
  /// Mesh (OBJ) to take outward normals from (nearest mesh vertex); empty = estimate by PCA.
  std::string mesh_path;
  /// Use the mesh vertices (denser) instead of the point file as the model points.
  bool use_mesh_vertices = false;
  /// Detect the geometric symmetry group from the points (detect_symmetry()).
  bool detect_symmetry = true;
  /// Take the model's colour (colour_score.h) from the mesh's texture or vertex colours.
  bool load_colour = true;
  /// When set, receives the path of every file read or looked for (MeshLoadOptions::files_read).
  std::vector<std::string>* files_read = nullptr;
};

/// Loads an ASCII point file (io/model_io.h read_xyz_points), normals from the mesh when given,
/// the symmetry, and calls prepare_object_model(). Throws IoError naming the file.
ObjectModel load_object_model(const std::string& points_path, const ModelLoadOptions& options = {},
                              int class_id = 0, const std::string& name = "");

/// Fills what is missing: diameter, mean spacing, normals (PCA over 12 neighbours, oriented away
/// from the centroid when no mesh is available), and the search index. Throws std::invalid_argument
/// when the model has fewer than 4 points or non-finite coordinates.
void prepare_object_model(ObjectModel& model);

/// Max pairwise distance (exact up to 20k points, else on a deterministic subset).
double model_diameter_m(const std::vector<Eigen::Vector3f>& points);

/// Finds rotational symmetries about the principal axes of the points: continuous (rotations by
/// 30..180 degrees all map the points onto themselves) or discrete of order 2, 3, 4, 6, plus
/// 180-degree flips perpendicular to a continuous axis. "Maps onto itself": the mean nearest-
/// neighbour distance of the rotated points is below `tolerance_m` plus the model's own mean point
/// spacing. Requires prepare_object_model() to have built the index.
ObjectSymmetry detect_symmetry(const ObjectModel& model, double tolerance_m = 0.002);

}  // namespace orpe
