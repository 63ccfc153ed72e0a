// Reconstruction error of the semantic map's objects (the paper, sec. IV-C): every reconstructed
// surfel of an object is projected onto the surface of the object's model placed at its
// ground-truth pose, and the distances are averaged (reported in mm).
//
//  - Surface: the model's triangle mesh when there is one (exact closest point on the triangles, an
//    AABB tree), else its points (closest point).
//  - Which surfels: those of the map instances whose class (the PLY's class id, the instance's
//  argmax
//    class) is the object's class; when a scene has several objects of one class, each instance
//    goes to the one whose model centre is nearest to the instance's centroid.
//  - Ground-truth pose in the map's frame: T_world_cam_est(f) * T_cam_obj_gt(f) for the first frame
//  f
//    of the run that lists the object, so the error does not depend on how the map's world frame
//    was chosen (SLAM drift after that frame is part of the error, as in the paper).
//  - Far fractions: the share of an object's surfels farther than 1 cm / 2 cm from the surface
//    (stray surfels that a median hides and a mean only hints at).
//  - Completeness: the share of the model surface the camera saw (samples of the surface that some
//    frame of the run shows, mark_seen_surface) that lies within 1 cm of a surfel of the object's
//    segment, so a segment cannot win by shrinking.
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
  /// Points spread over the surface (object frame): a mesh is sampled area-weighted at about one
  /// point per (2 mm)^2 (deterministic, at least 2,000 and at most 100,000 points); a point model
  /// gives its points.
  const std::vector<Eigen::Vector3f>& samples() const;

 private:
  ModelSurface();
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Closest point to p on triangle (a, b, c) (Ericson, Real-Time Collision Detection, 5.1.5).
Eigen::Vector3f closest_point_on_triangle(const Eigen::Vector3f& p, const Eigen::Vector3f& a,
                                          const Eigen::Vector3f& b, const Eigen::Vector3f& c);

struct ReconstructionErrorParams {
  float min_confidence = 0.0f;  ///< surfels with lower confidence are ignored
  bool register_model = false;  ///< also report the error after ICP registration
  int icp_iterations = 30;
  double icp_max_distance_m = 0.02;  ///< ICP uses surfels within this distance of the surface
  double far_near_m = 0.01;          ///< far fractions: surfels farther than these from the surface
  double far_m = 0.02;
  double completeness_distance_m = 0.01;  ///< a seen surface sample is covered within this
};

/// When a frame shows a model point (mark_seen_surface): it projects inside the image onto a pixel
/// that the ground truth labels as this object and whose measured depth is within this of the
/// point's depth (points on the far side of the object, or hidden by a gap in the depth, are not
/// seen).
struct SeenSurfaceParams {
  double depth_tolerance_m = 0.015;
};

/// A ground-truth object placed in the map's world frame.
struct GroundTruthObjectPose {
  int object_id = 0;  ///< ObjectGroundTruth::instance_id
  int class_id = 0;
  SE3 T_world_obj;
  /// Samples of the model surface (object frame) that the run's frames showed; completeness is
  /// computed over these and is not reported when empty.
  std::vector<Eigen::Vector3f> seen_surface_obj;
};

struct ObjectReconstructionError {
  int object_id = 0;
  int class_id = 0;
  std::string name;
  std::vector<int> instances;  ///< map instances assigned to it
  int surfels = 0;
  double mean_m = 0;  ///< mean surfel-to-surface distance at the ground-truth pose (m)
  double median_m = 0;
  double rms_m = 0;
  double mean_registered_m = -1;     ///< after ICP registration (-1 when not computed)
  double registration_shift_m = -1;  ///< translation of the ICP correction (m)
  double registration_angle_deg = -1;
  double far_near_fraction = 0;  ///< share of the surfels farther than far_near_m (1 cm)
  double far_fraction = 0;       ///< share farther than far_m (2 cm)
  double completeness = -1;      ///< share of the seen surface covered (-1: not computed)
  int seen_surface_samples = 0;
};

struct ReconstructionEvaluation {
  std::vector<ObjectReconstructionError> objects;  ///< sorted by class, then object id
  double mean_m = 0;                               ///< mean over objects that have surfels
  int objects_measured =
      0;  ///< objects with surfels (mean_m is meaningless when 0: printed "-", JSON null)
  double mean_registered_m = -1;
  double mean_completeness = -1;  ///< over objects with a seen surface (-1: none)
  double max_far_fraction = 0;    ///< the largest far_fraction (2 cm) of an object
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
ReconstructionEvaluation evaluate_reconstruction(const PointCloudData& map,
                                                 const std::vector<GroundTruthObjectPose>& objects,
                                                 const std::map<int, const ModelSurface*>& surfaces,
                                                 const std::map<int, std::string>& class_names,
                                                 const ReconstructionErrorParams& params = {});

/// The error of a whole map against the scene's true surface (issue 19: a loop that is not closed
/// leaves doubled, shifted surfaces): the distance of every surfel to the surface, in the frame
/// both are given in (no alignment; `orpe run` starts the map at the first frame's ground-truth
/// camera pose, so its map and `orpe synth`'s scene_mesh.ply share the world frame).
struct MapSurfaceError {
  int surfels = 0;  ///< surfels measured (confidence >= min_confidence)
  double min_confidence = 0;
  double mean_m = 0, median_m = 0, rms_m = 0;
  double far_near_m = 0.01, far_m = 0.02;
  double far_near_fraction = 0;  ///< share of the surfels farther than far_near_m
  double far_fraction = 0;       ///< share farther than far_m
  std::string report() const;
  std::string to_json() const;
};

/// Scores every surfel of `map` with confidence >= params.min_confidence (all when the map has no
/// confidences) against `surface` (params.far_near_m / far_m for the far shares). Throws
/// std::invalid_argument when no surfel is left.
MapSurfaceError evaluate_map_surface(const PointCloudData& map, const ModelSurface& surface,
                                     const ReconstructionErrorParams& params = {});

/// Reads a semantic map PLY: read_point_cloud_ply, plus the semantic stage's property names
/// (`instance`, `class`; io's reader expects `instance_id`, `class_id`). Throws IoError.
PointCloudData read_semantic_map_ply(const std::string& path);

/// Ground-truth objects of a dataset placed in the frame of an estimated trajectory: for each
/// object (ObjectGroundTruth::instance_id), T_world_cam_est(f) * T_cam_obj_gt(f) at the first frame
/// f of `reader` that lists it and has a trajectory pose (timestamps within 1 ms). Throws IoError
/// for unreadable frames.
std::vector<GroundTruthObjectPose> ground_truth_objects_in_map(
    const DatasetReader& reader, const std::vector<StampedPose>& trajectory);

/// Fills GroundTruthObjectPose::seen_surface_obj: the samples of each object's surface (`surfaces`:
/// class id -> surface) that some frame of `reader` with a trajectory pose shows
/// (SeenSurfaceParams), using the frame's ground-truth object poses, labels and depth. Objects
/// whose class has no surface are left empty. Throws IoError for unreadable frames.
void mark_seen_surface(const DatasetReader& reader, const std::vector<StampedPose>& trajectory,
                       const std::map<int, const ModelSurface*>& surfaces,
                       std::vector<GroundTruthObjectPose>* objects,
                       const SeenSurfaceParams& params = {});

/// The surface of a class's model: its mesh (DatasetInfo::model_mesh_paths, OBJ or PLY) when
/// present, else its points. Throws IoError naming the file.
ModelSurface load_model_surface(const DatasetInfo& info, int class_id);

}  // namespace orpe
