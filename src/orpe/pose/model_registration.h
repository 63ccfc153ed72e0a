// Model-based single-view pose: global registration of the instance's segmented depth points to the
// object's 3D model. No training; only the model is needed.
//
//  1. Segmented cloud: mask (eroded) x valid depth, back-projected; points farther than a fraction
//  of
//     the model diameter from the median point are dropped (background leaking into the mask).
//  2. Hypotheses: a uniform grid of rotations (super-Fibonacci sampling of SO(3)); for each, the
//     translation puts the centroid of the model's camera-facing half on the observed centroid.
//  3. Coarse stage, every hypothesis: a few iterations of robust point-to-plane ICP (Huber loss,
//     trimmed by a shrinking association distance, back-facing model points rejected; a small
//     point-to-point term keeps flat faces from sliding; model points seen in front of the observed
//     depth are pulled onto the nearest observed point) on a small subset of the points; then a
//     score.
//  4. Refine the best distinct hypotheses on all points, score again, keep the best.
//  5. Colour (when the model has colour and the input a colour image; pose_registration.colour_*):
//     the best pose turned about the model's principal axes (its near-symmetries) is refined too,
//     and the candidates whose geometric score is within colour_geometry_margin of the best are
//     ranked by score + colour_weight * NCC of the image with the model's colour (colour_score.h).
//
// Score = fit - free_space_weight * violations, where fit = mean over the observed points of
// max(0, 1 - d / inlier_distance) (d: distance to the model surface) and violations = fraction of
// model points that project in front of the observed depth by more than a margin (the object would
// hide what the sensor saw). Hypotheses run in parallel (OpenMP).
#pragma once

#include <string>
#include <vector>

#include "orpe/pose/colour_score.h"
#include "orpe/pose/single_view.h"

namespace orpe {

struct ModelRegistrationParams {
  // Segmented cloud.
  int erode_px = 2;
  int min_points = 30;
  int max_points = 1000;
  double outlier_radius_factor = 0.6;
  // Hypotheses and ICP.
  int num_rotations = 160;
  int coarse_points = 100;
  int coarse_iterations = 8;
  double coarse_max_corr_factor = 0.3;
  int coarse_grid_cells = 40;
  int refine_top_k = 5;
  int refine_iterations = 25;
  double refine_max_corr_factor = 0.1;
  double translation_search_occlusion = 0.1;
  double translation_search_step_factor = 0.2;
  double final_max_corr_m = 0.015;
  double huber_delta_m = 0.005;
  double point_to_point_weight = 0.1;
  bool reject_back_facing = true;
  // Scoring and validity.
  double inlier_distance_m = 0.01;
  double free_space_margin_m = 0.015;
  int free_space_window_px = 2;
  double free_space_weight = 1.0;
  double free_space_icp_weight = 1.0;
  double support_weight = 0.5;
  int free_space_model_points = 500;
  double min_inlier_fraction = 0.3;
  int seed = 7;
  /// Colour ranking of the candidates geometry cannot separate (colour_score.h).
  ColourScoreParams colour;
  /// Colour learned from the map for models without their own (the pipeline; colour_score.h).
  ColourLearningParams colour_learning;
  // Prior fast path (model_registration.cpp, refine_from_prior): with a prior, a local refinement
  // first; the global search only when the refined prior does not fit.
  bool prior_refinement = true;
  int prior_iterations = 12;
  int prior_points = 500;
  double prior_min_inlier_fraction = 0.7;
  double prior_max_free_space_violation = 0.15;
  double prior_min_score = 0.8;
  /// The refined prior's score also fits when it reaches this fraction of the object's own
  /// reference (SingleViewInput::prior_reference_score: in the pipeline its last global estimate
  /// the filter took into its reported mode): an object whose right pose scores below
  /// prior_min_score (small, partly seen, little support) keeps the fast path. The inlier and
  /// free-space thresholds stay absolute. 0 = absolute thresholds only.
  double prior_relative_fraction = 0.8;
  bool prior_flips = true;

  template <class V>
  void visit(V&& v) {
    v("erode_px", erode_px,
      "Mask erosion (pixels) against noisy boundaries; skipped when too few points remain");
    v("min_points", min_points, "Fewer valid segmented points -> invalid estimate");
    v("max_points", max_points,
      "Segmented points used for refinement and scoring (deterministic subsample)");
    v("outlier_radius_factor", outlier_radius_factor,
      "Drop segmented points farther than this x model diameter from their median point; 0 = off");
    v("num_rotations", num_rotations,
      "Rotation hypotheses (uniform super-Fibonacci grid over SO(3))");
    v("coarse_points", coarse_points, "Points per hypothesis in the coarse stage");
    v("coarse_iterations", coarse_iterations, "ICP iterations per hypothesis in the coarse stage");
    v("coarse_max_corr_factor", coarse_max_corr_factor,
      "Coarse stage: initial association distance as a fraction of the model diameter");
    v("coarse_grid_cells", coarse_grid_cells,
      "Coarse stage ICP: nearest model points looked up in a grid of this many cells across the "
      "model diameter (the nearest point of the cell's centre; the score stays exact); 0 = the "
      "exact kd-tree");
    v("refine_top_k", refine_top_k, "Distinct best coarse hypotheses refined on all points");
    v("refine_iterations", refine_iterations, "ICP iterations per refined hypothesis");
    v("refine_max_corr_factor", refine_max_corr_factor,
      "Refinement: initial association distance as a fraction of the model diameter");
    v("translation_search_occlusion", translation_search_occlusion,
      "When at least this fraction of the mask boundary is an occluder's edge, each rotation also "
      "tries "
      "a 3x3 grid of shifts across the ray before ICP (0 = always, -1 = never)");
    v("translation_search_step_factor", translation_search_step_factor,
      "Step of that shift grid as a fraction of the model diameter");
    v("final_max_corr_m", final_max_corr_m,
      "Association distance (m) reached at the last ICP iteration");
    v("huber_delta_m", huber_delta_m, "Huber loss threshold on point-to-plane residuals (m)");
    v("point_to_point_weight", point_to_point_weight,
      "Weight of the point-to-point term next to point-to-plane (0 = pure point-to-plane)");
    v("reject_back_facing", reject_back_facing,
      "Reject associations to model points facing away from the camera (needs outward normals)");
    v("inlier_distance_m", inlier_distance_m,
      "Distance (m) under which an observed point fits the model");
    v("free_space_margin_m", free_space_margin_m,
      "A model point this far (m) in front of the observed depth is a free-space violation");
    v("free_space_window_px", free_space_window_px,
      "Free-space test against the minimum depth within this radius (pixels): tolerance to edge "
      "bleeding");
    v("free_space_weight", free_space_weight,
      "Weight of the free-space violation fraction in the score");
    v("free_space_icp_weight", free_space_icp_weight,
      "ICP: weight of pulling free-space-violating model points to the nearest observed point; 0 = "
      "off");
    v("support_weight", support_weight,
      "Score weight of the support term: fraction of camera-facing, unoccluded model points lying "
      "on "
      "the observed depth (inside the mask or not)");
    v("free_space_model_points", free_space_model_points,
      "Model points used for the free-space test");
    v("min_inlier_fraction", min_inlier_fraction,
      "Below this inlier fraction the estimate is invalid");
    v("seed", seed, "Seed of the deterministic point subsampling");
    colour.visit(v);
    colour_learning.visit(v);
    v("prior_refinement", prior_refinement,
      "With a prior (T_cam_obj_prior, e.g. the fused pose moved into this camera): refine it "
      "locally and skip the global rotation search when the result fits (prior_min_*); "
      "false = the prior is one more hypothesis of the global search");
    v("prior_iterations", prior_iterations, "ICP iterations of the prior's local refinement");
    v("prior_points", prior_points,
      "Segmented points used by the prior's local refinement and its score (strided subset)");
    v("prior_min_inlier_fraction", prior_min_inlier_fraction,
      "The refined prior fits when at least this fraction of the points are inliers, ...");
    v("prior_max_free_space_violation", prior_max_free_space_violation,
      "... at most this fraction of the model points violate free space, ...");
    v("prior_flips", prior_flips,
      "Fast path: also refine the refined prior turned 180 degrees about each principal axis "
      "(the modes geometry confuses) the same way and keep the best (score, then colour): the "
      "choice among those modes is made anew on every view");
    v("prior_min_score", prior_min_score,
      "... and its score reaches this; else the global search runs (prior as one hypothesis)");
    v("prior_relative_fraction", prior_relative_fraction,
      "The refined prior's score also fits when it reaches this fraction of the object's "
      "reference score (its last global estimate that agreed with the fused pose); 0 = "
      "prior_min_score only");
  }
  bool IsValid(std::string* why) const;
  SegmentedCloudParams segmented_cloud() const;
};

/// A uniform set of n rotations (super-Fibonacci spirals, Alexa 2022). Deterministic.
std::vector<Mat3> uniform_rotations(int n);

class ModelRegistrationEstimator final : public SingleViewPoseEstimator {
 public:
  /// Throws ConfigError for invalid params.
  explicit ModelRegistrationEstimator(const ModelRegistrationParams& params = {});
  std::string name() const override { return "model_registration"; }
  SingleViewPose estimate(const SingleViewInput& input) const override;
  /// Scores a given pose (no search, no refinement) exactly as the search does: for diagnosis,
  /// e.g. comparing the score of the ground truth with the score of the estimate.
  SingleViewPose evaluate(const SingleViewInput& input, const SE3& T_cam_obj) const;
  const ModelRegistrationParams& params() const { return params_; }

 private:
  SingleViewPose run(const SingleViewInput& input, const SE3* fixed_pose) const;
  ModelRegistrationParams params_;
  std::vector<Mat3> rotations_;
};

}  // namespace orpe
