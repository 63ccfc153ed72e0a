// Reconstruction error of the semantic map's objects (the paper, sec. IV-C): every reconstructed
// surfel of an object is projected onto the surface of the object's model placed at its ground-truth
// pose, and the distances are averaged (reported in mm).
//
//  - Surface: the model's triangle mesh when there is one (exact closest point on the triangles, an
//    AABB tree), else its points (closest point).
//  - Which surfels: those of the map instances whose class (the PLY's class id, the instance's argmax
//    class) is the object's class; when a scene has several objects of one class, each instance goes
//    to the one whose model centre is nearest to the instance's centroid.
//  - Ground-truth pose in the map's frame: T_world_cam_est(f) * T_cam_obj_gt(f) for the first frame f
//    of the run that lists the object, so the error does not depend on how the map's world frame was
//    chosen (SLAM drift after that frame is part of the error, as in the paper).
//  - Optionally ("registered"), the model pose is first refined by ICP against the surfels (the
//    paper's "register the reconstructed object to its ground-truth model"); this removes the rigid
//    part of the error (tracking drift, calibration) and keeps the shape error.
#pragma once

#include <Eigen/Core>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "orpe/core/se3.h"
#include "orpe/io/dataset.h"
#include "orpe/io/point_cloud_io.h"

namespace orpe {

struct TriangleMesh;

/// Closest-point queries on a model surface in its own frame (metres). Thread-safe queries.
class ModelSurface {
 public:
  /// Triangles of `mesh` (metres). Throws std::invalid_argument for a mesh without triangles.
  static ModelSurface from_mesh(const TriangleMesh& mesh);
  /// A point set (closest point). Throws std::invalid_argument for an empty set.
  static ModelSurface from_points(const std::vector<Eigen::Vector3f>& points);
  ModelSurface(ModelSurface&&) noexcept;
  ModelSurface& operator=(ModelSurface&&) noexcept;
  ~ModelSurface();

  /// Distance (m) from p (object frame) to the surface; `closest` receives the closest point.
  double distance_m(const Eigen::Vector3f& p, Eigen::Vector3f* closest = nullptr) const;
  bool has_triangles() const;
  /// Centre of the bounding box of the surface (object frame).
  Eigen::Vector3f centre() const;

 private:
  ModelSurface();
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Closest point to p on triangle (a, b, c) (Ericson, Real-Time Collision Detection, 5.1.5).
Eigen::Vector3f closest_point_on_triangle(const Eigen::Vector3f& p, const Eigen::Vector3f& a,
                                          const Eigen::Vector3f& b, const Eigen::Vector3f& c);

struct ReconstructionErrorParams {
  float min_confidence = 0.0f;    ///< surfels with lower confidence are ignored
  bool register_model = false;    ///< also report the error after ICP registration
  int icp_iterations = 30;
  double icp_max_distance_m = 0.02;  ///< ICP uses surfels within this distance of the surface
};

/// A ground-truth object placed in the map's world frame.
struct GroundTruthObjectPose {
  int object_id = 0;  ///< ObjectGroundTruth::instance_id
  int class_id = 0;
  SE3 T_world_obj;
};

struct ObjectReconstructionError {
  int object_id = 0;
  int class_id = 0;
  std::string name;
  std::vector<int> instances;  ///< map instances assigned to it
  int surfels = 0;
  double mean_m = 0;    ///< mean surfel-to-surface distance at the ground-truth pose (m)
  double median_m = 0;
  double rms_m = 0;
  double mean_registered_m = -1;  ///< after ICP registration (-1 when not computed)
  double registration_shift_m = -1;   ///< translation of the ICP correction (m)
  double registration_angle_deg = -1;
};

struct ReconstructionEvaluation {
  std::vector<ObjectReconstructionError> objects;  ///< sorted by class, then object id
  double mean_m = 0;             ///< mean over objects that have surfels
  double mean_registered_m = -1;
  int objects_without_surfels = 0;
  std::vector<int> unmatched_instances;  ///< instances whose class has no ground-truth object
  std::string report() const;
  std::string markdown() const;
  std::string to_json() const;
};

/// Scores the surfels of `map` (positions_m, instance_ids and class_ids required, confidences used
/// when present). `surfaces`: class id -> model surface; classes of `objects` without a surface are
/// skipped (listed with surfels = 0). Throws std::invalid_argument when the map lacks instance or
/// class ids.
ReconstructionEvaluation evaluate_reconstruction(
    const PointCloudData& map, const std::vector<GroundTruthObjectPose>& objects,
    const std::map<int, const ModelSurface*>& surfaces, const std::map<int, std::string>& class_names,
    const ReconstructionErrorParams& params = {});

/// Reads a semantic map PLY: read_point_cloud_ply, plus the semantic stage's property names
/// (`instance`, `class`; io's reader expects `instance_id`, `class_id`). Throws IoError.
PointCloudData read_semantic_map_ply(const std::string& path);

/// Ground-truth objects of a dataset placed in the frame of an estimated trajectory: for each object
/// (ObjectGroundTruth::instance_id), T_world_cam_est(f) * T_cam_obj_gt(f) at the first frame f of
/// `reader` that lists it and has a trajectory pose (timestamps within 1 ms). Throws IoError for
/// unreadable frames.
std::vector<GroundTruthObjectPose> ground_truth_objects_in_map(
    const DatasetReader& reader, const std::vector<StampedPose>& trajectory);

/// The surface of a class's model: its mesh (DatasetInfo::model_mesh_paths, OBJ or PLY) when
/// present, else its points. Throws IoError naming the file.
ModelSurface load_model_surface(const DatasetInfo& info, int class_id);

}  // namespace orpe
