// Single-view 6D pose of one object instance: the interface every back-end implements (the
// model-based registration in model_registration.h; a learned DenseFusion back-end later), and the
// helpers they share (segmented cloud extraction, the paper's measurement noise mu).
//
// Input: one instance's mask, the depth (metres) and colour of the frame — either the raw frame or
// images rendered from the map — the intrinsics, the class id and its 3D model. Output: T_cam_obj
// (object model frame -> camera frame), a score, mu_m and a validity flag with a reason.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "orpe/core/camera.h"
#include "orpe/core/image.h"
#include "orpe/core/se3.h"
#include "orpe/pose/object_model.h"

namespace orpe {

struct SingleViewInput {
  const MaskImage* mask = nullptr;    ///< non-zero = the instance's pixels
  const DepthImage* depth = nullptr;  ///< metres, 0 = invalid; same size as the mask
  const ColorImage* color = nullptr;  ///< RGB8, same size; optional for geometry-only back-ends
  PinholeIntrinsics intrinsics;
  int class_id = 0;
  const ObjectModel* model = nullptr;  ///< prepared (prepare_object_model) for speed; required
  /// Optional guess (e.g. the fused world pose moved into this camera): tried as one more
  /// hypothesis.
  std::optional<SE3> T_cam_obj_prior;
  /// Optional, with the prior: the score of the object's last estimate the caller trusts (0 =
  /// none); a back-end may accept a refined prior that scores close to it.
  double prior_reference_score = 0;

  /// Pointers set, sizes consistent, intrinsics valid, model non-empty.
  bool IsValid(std::string* why) const;
};

struct SingleViewPose {
  bool valid = false;
  std::string reason;  ///< why the estimate is invalid (empty when valid)
  SE3 T_cam_obj;
  double score = 0;  ///< back-end specific confidence, higher is better (model-based: in [-1, 1])
  /// Mean distance (m) of the segmented object points to the nearest model point under T_cam_obj:
  /// the paper's measurement noise (R = mu I in the EKF).
  double mu_m = 0;
  int num_points = 0;          ///< segmented points used
  double inlier_fraction = 0;  ///< of segmented points within the back-end's inlier distance
  double free_space_violation =
      0;  ///< fraction of model points seen in front of the observed depth
  double time_ms = 0;
  /// Colour evidence (colour_score.h), when the model has colour and the input a colour image:
  /// NCC of the image with the model's colour at T_cam_obj, and its lead over the best other
  /// candidate pose that geometry could not exclude (0 when there was none or no colour).
  /// Geometric score lead of T_cam_obj over the best refined candidate at another rotation (> 0.3
  /// rad away; 0 when there was none): small = geometry alone cannot tell the modes apart.
  double geometry_margin = 0;
  bool colour_used = false;
  double colour_ncc = 0;
  double colour_margin = 0;
  /// The estimate is a local refinement of SingleViewInput::T_cam_obj_prior (no global search).
  bool from_prior = false;
  /// ... which also refined the prior's near-symmetric turns and took the best: the choice among
  /// the modes geometry (or colour) confuses was made anew, not inherited from the prior.
  bool prior_modes_compared = false;
  std::string report() const;
};

class SingleViewPoseEstimator {
 public:
  virtual ~SingleViewPoseEstimator() = default;
  virtual std::string name() const = 0;
  /// Never throws on bad content: an unusable input gives valid = false with the reason.
  virtual SingleViewPose estimate(const SingleViewInput& input) const = 0;
};

/// How the instance's points are taken from the mask and depth.
struct SegmentedCloudParams {
  int erode_px = 2;       ///< mask erosion against boundary pixels (skipped if too few remain)
  int min_points = 30;    ///< fewer valid points -> invalid estimate
  int max_points = 1500;  ///< deterministic subsample above this
  double outlier_radius_factor = 0.6;  ///< keep points within factor * diameter of the median point
  unsigned seed = 7;                   ///< subsampling seed
};

struct SegmentedCloud {
  std::vector<Eigen::Vector3f> points;  ///< camera frame, metres
  Eigen::Vector3f centroid = Eigen::Vector3f::Zero();
  int mask_pixels = 0;         ///< non-zero mask pixels before erosion
  int valid_depth_pixels = 0;  ///< mask pixels (after erosion) with valid depth
  int outliers_removed = 0;    ///< dropped by the diameter test
};

/// Back-projects the mask's valid-depth pixels. `diameter_m` scales the outlier test (0 = no test).
SegmentedCloud extract_segmented_cloud(const MaskImage& mask, const DepthImage& depth,
                                       const PinholeIntrinsics& intrinsics, double diameter_m,
                                       const SegmentedCloudParams& params);

/// The paper's mu: mean over `points_cam` of the distance to the nearest model point under
/// T_cam_obj (m). Uses the model's search index (built on the fly when missing).
double mean_model_distance_m(const std::vector<Eigen::Vector3f>& points_cam,
                             const ObjectModel& model, const SE3& T_cam_obj);

}  // namespace orpe
