// Object types for synthetic scenes: the built-in warehouse set (after the paper's 11 warehouse
// objects: printed boxes, cans, a tomato-puree carton, a pallet and a half pallet) and user meshes.
//
// Built-in models have their frame at the centre of their bounding box, z up when standing upright,
// sizes invented to be plausible (the paper's objects are not public). A user mesh keeps its file's
// frame, so that ground-truth poses refer to the same frame as the file (e.g. YCB points.xyz).
#pragma once

#include <cstdint>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "orpe/core/se3.h"
#include "orpe/render/mesh.h"

namespace orpe::synth {

/// Shape symmetries (geometry only: textures are ignored), in BOP's terms.
struct ObjectSymmetries {
  std::vector<SE3> discrete;  ///< non-identity model-frame transforms mapping the shape onto itself
  struct Continuous {
    Vec3 axis;      ///< unit axis, model frame
    Vec3 offset_m;  ///< a point on the axis, model frame (m)
  };
  std::vector<Continuous> continuous;
  bool any() const { return !discrete.empty() || !continuous.empty(); }
};

/// One way of resting on a horizontal surface: the rotation and the footprint it gives.
struct RestingPose {
  Mat3 R_support_obj;                      ///< orientation relative to the support (z up)
  double z_offset_m = 0;                   ///< lift so that the lowest point touches z = 0
  double height_m = 0;                     ///< top of the object above the support
  std::vector<Eigen::Vector2d> footprint;  ///< convex hull of the object seen from above (m), CCW,
                                           ///< relative to the object origin (before yaw)
  double weight = 1;                       ///< relative probability of choosing this pose
  bool flat_top = false;                   ///< the top is a flat face others may stand on
};

struct ObjectModel {
  std::string name;                          ///< e.g. "003_jacky_box", or the file's stem
  std::string source;                        ///< "builtin" or the mesh file path
  std::shared_ptr<const TriangleMesh> mesh;  ///< metres, model frame
  ObjectSymmetries symmetries;
  std::vector<RestingPose> resting_poses;  ///< at least one
  bool is_pallet = false;                  ///< large: floor only, placed first
};

/// Names of the built-in warehouse classes, in the paper's order (001_frasvaf_box ...
/// 011_half_pallet).
const std::vector<std::string>& builtin_class_names();

/// Builds a built-in class. `variant` 0 is the canonical look; other variants change print colours
/// and sizes slightly (used when a scene needs more distinct types than there are classes).
/// Throws std::invalid_argument for an unknown name.
ObjectModel make_builtin_object(const std::string& name, int variant = 0);

/// Distractor sizes stay farther than this ratio from every target's (in at least one of the sorted
/// bounding-box sizes).
constexpr double kDistractorSizeRatio = 1.25;

/// True when the sorted bounding-box sizes of a and b are all within `ratio` of each other.
bool similar_size(const TriangleMesh& a, const TriangleMesh& b, double ratio);

/// A distractor (an object outside the model set): a box (sides 5-32 cm) or an upright cylinder
/// (radius 2.5-9 cm, height 5-30 cm) in one flat saturated colour, its size redrawn (up to 100
/// times) until it is not similar_size to any of `targets`. Named distractor_box_NN /
/// distractor_cylinder_NN (NN = index + 1). Its draws come from `rng` only.
ObjectModel make_distractor_object(const std::vector<ObjectModel>& targets, int index,
                                   std::mt19937_64& rng);

/// Loads a user mesh/// Loads a user mesh (OBJ/PLY) as an object type. `metres_per_unit` 0 guesses:
/// millimetres when the model's bounding box is larger than 5 units, else metres. Resting poses
/// from the faces of its principal-axes bounding box, checked for static stability. Throws IoError
/// for bad files.
ObjectModel load_object_model(const std::string& path, double metres_per_unit = 0);

/// Resting poses of a mesh for the 6 orientations putting +-axes[k] up (axes: columns,
/// orthonormal). Stable when the centre of mass (volume centroid) projects inside the support
/// polygon (the convex hull of the vertices within `contact_tol_m` of the lowest point). Weight =
/// support area (stable only; if none is stable, the largest support is kept). `up_weights` (per
/// +x,-x,+y,-y,+z,-z of `axes`) multiplies the weights (0 removes a pose).
std::vector<RestingPose> compute_resting_poses(const TriangleMesh& mesh, const Mat3& axes,
                                               const std::array<double, 6>& up_weights = {1, 1, 1,
                                                                                          1, 1, 1},
                                               double contact_tol_m = 0.002);

/// The same for arbitrary up directions (object frame), each with its weight factor.
std::vector<RestingPose> compute_resting_poses_for(const TriangleMesh& mesh,
                                                   const std::vector<Vec3>& ups,
                                                   const std::vector<double>& up_weights,
                                                   double contact_tol_m = 0.002);

/// Candidate "down" directions of a mesh (object frame): modes of the area-weighted histogram of
/// outward face normals (flat faces), then the given principal axes; duplicates within 10 deg
/// dropped.
std::vector<Vec3> candidate_down_directions(const TriangleMesh& mesh, const Mat3& pca_axes);

/// Convex hull (Andrew's monotone chain), CCW, no repeated end point.
std::vector<Eigen::Vector2d> convex_hull_2d(std::vector<Eigen::Vector2d> points);

/// Volume centroid of a closed mesh (signed tetrahedra); the area centroid when the volume is ~0.
Vec3 mesh_centroid(const TriangleMesh& mesh);

}  // namespace orpe::synth
