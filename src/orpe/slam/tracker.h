// Frame-to-model camera tracking (ElasticFusion): the live frame's pyramid is aligned against
// vertex, normal and intensity maps rendered from the surfel map at a reference pose, by
// Gauss-Newton on a joint point-to-plane ICP + photometric cost, coarse to fine.
//
// Unknown: T_ref_cam, the live camera in the reference (rendered) camera's frame. Increments are
// left-multiplied in the reference frame: T_ref_cam <- exp(xi) * T_ref_cam, xi = [rho; phi].
//
// ICP residual (per live pixel p with vertex x, in the live camera frame):
//   q = T_ref_cam x,  model pixel = round(project(q)),  r = n_m . (q - v_m)   (metres)
//   J = [n_m^T, (q x n_m)^T]
// Photometric residual (per model pixel with colour point v_m -- the centre of the surfel whose
// colour I_m it shows -- in the reference frame):
//   y = T_ref_cam^-1 v_m,  r = I_live(project(y)) - I_m   (0..255, bilinear)
//   J = grad I_live . d project / d y . R_ref_cam^T [-I, hat(v_m)]
// Normal equations: A = w_icp^2 A_icp + A_rgb / s^2, b likewise, where s is the RMS photometric
// residual of the iteration (ElasticFusion normalises its RGB term by that sigma too).
#pragma once

#include <array>
#include <string>
#include <vector>

#include "orpe/core/se3.h"
#include "orpe/slam/preprocess.h"

namespace orpe::slam {

struct TrackerParams {
  int iterations_level0 = 10;  ///< Gauss-Newton iterations at full resolution (ElasticFusion: 10)
  int iterations_level1 = 5;   ///< at 1/2 resolution (5)
  int iterations_level2 = 4;   ///< at 1/4 resolution (4); levels beyond 2 use this too
  double icp_max_dist_m = 0.10;
  double icp_max_angle_deg = 20.0;
  bool use_icp = true;
  bool use_rgb = true;
  double icp_weight = 10.0;  ///< w_icp: A = w_icp^2 A_icp + A_rgb (ElasticFusion: 10)
  double rgb_max_depth_diff_m = 0.07;
  double rgb_min_gradient_level0 =
      5.0 / 3.0;  ///< |grad I| threshold, 0..255 per pixel (see SLAM.md)
  double rgb_min_gradient_level1 = 1.0;
  double rgb_min_gradient_level2 = 1.0 / 3.0;
  double rgb_max_depth_m = 6.0;
  double icp_huber_m = 0.0;  ///< Huber threshold of ICP residuals (m); 0 = plain least squares (EF)
  /// Huber threshold of photometric residuals in units of their RMS (of the previous iteration);
  /// 0 = plain least squares (EF)
  double rgb_huber_sigmas = 0.0;
  /// Photometric term: reference (model) pixels within this many pixels (of their pyramid level)
  /// of a depth discontinuity or of a pixel without depth are not used. Colour there mixes two
  /// surfaces (optics, antialiasing, the pyramid's averaging, the bilinear lookup) whose parallax
  /// differs, which biases the motion along the translation-rotation ambiguity (docs/SLAM.md,
  /// "Photometric term near depth edges"). 0 = every pixel (ElasticFusion). Typical 1-2. Applied at
  /// full resolution (pyramid level 0) only.
  int rgb_edge_margin_px = 1;
  /// Photometric term: estimate the live image's brightness gain against the map's colours (one
  /// factor per frame, solved jointly with the pose at each iteration) and compare gain x live
  /// intensity with the map's. A change of exposure or lighting otherwise shows as residuals that
  /// the pose absorbs (docs/SLAM.md, "Session 25"). Off = raw intensities (ElasticFusion).
  bool rgb_estimate_gain = true;
  /// A depth discontinuity: 8-neighbours differ by more than rgb_edge_jump_m + rgb_edge_jump_per_m
  /// x z x (the level's pixel size in full-resolution pixels) (m).
  double rgb_edge_jump_m = 0.01;
  double rgb_edge_jump_per_m = 0.02;
  /// Step the pixel loops by this at level 0 (1 = every pixel; 2 = every 2nd row and column).
  int level0_pixel_step = 1;
  double convergence_step = 1e-5;         ///< stop a level when |xi| (m, rad) falls below this
  double max_translation_update_m = 0.3;  ///< reject a frame moving more than this (ElasticFusion)
  double max_rotation_update_deg = 30.0;  ///< and rotating more than this
  /// Predict the initial pose with the last inter-frame motion (off = previous pose,
  /// ElasticFusion).
  bool constant_velocity = false;

  // Quality gates, evaluated at the finest level after the last iteration.
  int min_inliers = 2000;  ///< fewer ICP inliers (level 0) -> the frame failed
  // Kinect v1 depth (7-Scenes, 640x480): while tracking is right, only 28-48 % (5th-75th
  // percentile) of the overlapping pixels pass the 20 deg normal gate (noisy per-pixel normals), so
  // the fraction gates are set below that; a wrong alignment shows as few inliers or a high RMS as
  // well.
  double min_inlier_fraction = 0.12;   ///< inliers / overlap below this -> failed
  double good_inlier_fraction = 0.25;  ///< below this -> degraded
  // Kinect v1 depth noise grows as ~0.003 z^2 m (2.7 cm at 3 m): on 7-Scenes, frames that see a far
  // wall align correctly with a point-to-plane RMS of 1.6-2.5 cm.
  double max_icp_rms_m = 0.05;           ///< point-to-plane RMS above this -> failed
  double good_icp_rms_m = 0.03;          ///< above this -> degraded
  double min_hessian_eigenvalue = 1e-3;  ///< of the per-inlier ICP normal matrix; below -> degraded
  int max_bad_frames = 10;  ///< consecutive degraded frames before LOST (ElasticFusion)
  // Self-checks of the final alignment against the frame's own depth (docs/SLAM.md, "Tracking
  // states"): each live pixel with depth is moved by the estimate into the reference view and
  // compared with the model depth there. A wrong pose puts live points in front of or behind the
  // map's surfaces.
  double consistency_tolerance_m =
      0.02;  ///< |depth difference| within this + consistency_tolerance_per_m * z -> consistent
  double consistency_tolerance_per_m = 0.02;
  /// ... or within this many sigma(z) of the Kinect axial noise model (Nguyen et al. 2012,
  /// sigma = 0.0012 + 0.0019 (z - 0.4)^2 m), where that is larger (beyond ~5 m); 0 = off.
  double consistency_noise_sigmas = 3.0;
  // The free-space test, on by default (docs/SLAM.md, "The tracker's self-check"): a live point
  // in front of the map's surface by more than the tolerance sits where the map has seen empty
  // space. On correctly tracked frames this is rare even on Kinect v1 data (7-Scenes, 500 frames:
  // median 0.002, <= 0.028 but for frame 313 at 0.063), whose disagreement is nearly all on the
  // other side (live points behind the rendered surface: up to 0.37, map artefacts); a wrong
  // alignment violates both sides (synthetic camera jumps: 0.075-0.203 in front).
  double max_in_front_fraction =
      0.06;  ///< in-front / overlapping pixels above this -> failed (LOST)
  double good_in_front_fraction = 0.04;  ///< above this -> degraded
  /// Off (0) by default: on the shared 7-Scenes frames (Kinect v1) correctly tracked frames agree
  /// at only 0.63-0.80 around frames 170-196 (live points behind the map), so 0.85 / 0.9 lost the
  /// camera for good (ATE 0.54 m against 0.041 m off). Synthetic camera jumps agree at 0.76-0.82,
  /// correct synthetic motion at 0.97-0.99. The in-front fraction above is the test that separates
  /// them.
  double min_consistent_fraction = 0.0;   ///< consistent / overlapping pixels below this -> failed
  double good_consistent_fraction = 0.0;  ///< below this -> degraded
  double min_overlap_fraction =
      0.15;  ///< overlapping / live pixels with depth below this -> failed
  double good_overlap_fraction = 0.35;  ///< below this -> degraded
  /// Last level-0 update larger than this (norm of [m; rad]) -> not converged -> degraded.
  double max_final_step = 2e-3;

  template <class V>
  void visit(V&& v) {
    v("iterations_level0", iterations_level0,
      "Gauss-Newton iterations at full resolution (EF: 10)");
    v("iterations_level1", iterations_level1, "Iterations at 1/2 resolution (EF: 5)");
    v("iterations_level2", iterations_level2, "Iterations at 1/4 resolution and coarser (EF: 4)");
    v("icp_max_dist_m", icp_max_dist_m, "ICP association: max point distance (m) (EF: 0.10)");
    v("icp_max_angle_deg", icp_max_angle_deg, "ICP association: max normal angle (deg) (EF: 20)");
    v("use_icp", use_icp, "Use the point-to-plane ICP term");
    v("use_rgb", use_rgb, "Use the photometric term");
    v("icp_weight", icp_weight, "w_icp: A = w_icp^2 A_icp + A_rgb (EF: 10)");
    v("rgb_max_depth_diff_m", rgb_max_depth_diff_m,
      "Photometric: reject when depths differ by more (m) (EF: 0.07)");
    v("rgb_min_gradient_level0", rgb_min_gradient_level0,
      "Photometric: min |grad I| at level 0 (intensity 0..255 per pixel, Sobel/8)");
    v("rgb_min_gradient_level1", rgb_min_gradient_level1, "Photometric: min |grad I| at level 1");
    v("rgb_min_gradient_level2", rgb_min_gradient_level2, "Photometric: min |grad I| at level 2+");
    v("rgb_max_depth_m", rgb_max_depth_m, "Photometric: max depth of a used pixel (m) (EF: 6)");
    v("icp_huber_m", icp_huber_m,
      "Huber threshold of ICP residuals (m); 0 = plain least squares (EF)");
    v("rgb_huber_sigmas", rgb_huber_sigmas,
      "Huber threshold of photometric residuals, in RMS residuals of the previous iteration; 0 = "
      "off (EF)");
    v("rgb_edge_margin_px", rgb_edge_margin_px,
      "Photometric: skip reference pixels within this many pixels of a depth discontinuity "
      "(mixed colours bias the motion); 0 = off (EF)");
    v("rgb_estimate_gain", rgb_estimate_gain,
      "Photometric: estimate the live image's brightness gain against the map with the pose "
      "(exposure / lighting changes); off = raw intensities (EF)");
    v("rgb_edge_jump_m", rgb_edge_jump_m,
      "Photometric: a depth discontinuity is a neighbour depth difference above this (m) ...");
    v("rgb_edge_jump_per_m", rgb_edge_jump_per_m,
      "... plus this times the depth and the level's pixel size (m per m)");
    v("level0_pixel_step", level0_pixel_step,
      "Use every n-th row and column at level 0 (speed; 1 = all)");
    v("convergence_step", convergence_step, "Stop a level when the update norm is below this");
    v("max_translation_update_m", max_translation_update_m,
      "Reject a frame moving more than this (m) (EF: 0.3)");
    v("max_rotation_update_deg", max_rotation_update_deg,
      "Reject a frame rotating more than this (deg)");
    v("constant_velocity", constant_velocity,
      "Initial guess from the last motion (off: previous pose, as EF)");
    v("min_inliers", min_inliers,
      "Fewer ICP inliers at level 0 (per 640x480, scaled by area) -> frame failed");
    v("min_inlier_fraction", min_inlier_fraction,
      "ICP inliers / overlapping pixels below this -> failed");
    v("good_inlier_fraction", good_inlier_fraction,
      "ICP inliers / overlapping pixels below this -> degraded");
    v("max_icp_rms_m", max_icp_rms_m, "Point-to-plane RMS above this -> failed (m)");
    v("good_icp_rms_m", good_icp_rms_m, "Point-to-plane RMS above this -> degraded (m)");
    v("min_hessian_eigenvalue", min_hessian_eigenvalue,
      "Smallest eigenvalue of the ICP normal matrix per inlier below this -> degraded (geometry "
      "degenerate)");
    v("max_bad_frames", max_bad_frames, "Consecutive degraded frames before LOST (EF: 10)");
    v("consistency_tolerance_m", consistency_tolerance_m,
      "Self-check: a live pixel agrees with the map when depths differ by less than this (m) ...");
    v("consistency_tolerance_per_m", consistency_tolerance_per_m,
      "... plus this times the depth (m per m)");
    v("consistency_noise_sigmas", consistency_noise_sigmas,
      "... or this many sigma(z) of the Kinect noise model (0.0012 + 0.0019 (z-0.4)^2 m) where "
      "larger; 0 = off");
    v("max_in_front_fraction", max_in_front_fraction,
      "Self-check: live pixels in front of the map surface / overlapping pixels above this -> "
      "failed (LOST)");
    v("good_in_front_fraction", good_in_front_fraction, "In-front fraction above this -> degraded");
    v("min_consistent_fraction", min_consistent_fraction,
      "Self-check: agreeing / overlapping pixels below this -> failed (LOST)");
    v("good_consistent_fraction", good_consistent_fraction,
      "Agreeing / overlapping pixels below this -> degraded");
    v("min_overlap_fraction", min_overlap_fraction,
      "Self-check: live pixels landing on the map / live pixels with depth below this -> failed");
    v("good_overlap_fraction", good_overlap_fraction, "Overlap fraction below this -> degraded");
    v("max_final_step", max_final_step,
      "Last full-resolution update norm (m, rad) above this -> not converged -> degraded");
  }
  bool IsValid(std::string* why) const;
};

/// Model maps rendered at the reference pose, as a pyramid (reference camera frame).
struct ModelLevel {
  PinholeIntrinsics K;
  DepthImage depth;
  VertexImage vertex;  ///< ray / surface intersection per pixel (ICP)
  NormalImage normal;
  IntensityImage intensity;  ///< colour of the pixel's surfel
  VertexImage
      color_point;  ///< where that colour was measured: the surfel centre (photometric term)
};
struct ModelPyramid {
  std::vector<ModelLevel> levels;
  /// The frame pyramid level of levels[0]: 0 when rendered at full resolution; 1 when rendered at
  /// half resolution, in which case frame level 0 is aligned against model level 0 (half
  /// resolution).
  int first_level = 0;
};
/// Builds the model pyramid from a full-resolution rendered view (vertex, normal, colour and
/// surfel_centre required).
/// `K` is the rendered view's intrinsics; `first_level` its level in the frame pyramid.
void build_model_pyramid(const RenderedView& view, const PinholeIntrinsics& K, int levels,
                         float max_depth_jump_m, ModelPyramid* out, int first_level = 0);

/// Marks with 1 the pixels of `depth` (m; <= 0: none) farther than `margin_px` pixels (Chebyshev)
/// from a depth discontinuity (8-neighbours whose depths differ by more than
/// jump_m + jump_per_m * z * pixel_scale, pixel_scale = the pixel's size in full-resolution pixels)
/// and from a pixel without depth; 0 elsewhere.
void photometric_edge_mask(const DepthImage& depth, int margin_px, float jump_m, float jump_per_m,
                           float pixel_scale, MaskImage* out);

/// Outcome of one alignment (no state; the SLAM system turns it into OK / DEGRADED / LOST).
struct AlignmentResult {
  SE3 T_ref_cam;  ///< estimate
  bool converged = false;
  bool failed = false;        ///< numerically failed, too few inliers, implausible jump or residual
  bool weak = false;          ///< usable but poor (degraded)
  std::string reason;         ///< why failed / weak ("" when good)
  int icp_inliers = 0;        ///< at level 0, last iteration
  int icp_overlap = 0;        ///< live pixels that projected onto a valid model pixel
  int rgb_count = 0;          ///< photometric residuals used, level 0
  double icp_rms_m = 0;       ///< point-to-plane RMS, level 0
  double rgb_rms = 0;         ///< photometric RMS (0..255), level 0
  double rgb_gain = 1;        ///< live image brightness / the map's (rgb_estimate_gain), level 0
  double min_eigenvalue = 0;  ///< smallest eigenvalue of A_icp / inliers
  int iterations = 0;         ///< total over levels
  double final_step = 0;      ///< norm of the last level-0 update
  // Self-check against the frame's own depth (DepthConsistency), at the final estimate.
  double overlap_fraction = 0;     ///< live pixels with depth that land on the map
  double consistent_fraction = 0;  ///< of those, depth agrees with the map's
  double in_front_fraction = 0;  ///< of those, nearer than the map's surface (free-space violation)
  double behind_fraction = 0;    ///< of those, behind it
};

/// Live pixels with depth moved by T_ref_cam into the reference view and compared with the model's
/// depth at the pixel they land on (level 0 of both pyramids, every `pixel_step`-th row and
/// column).
struct DepthConsistency {
  int live = 0;        ///< live pixels with depth
  int overlap = 0;     ///< ... that land on a model pixel with depth
  int consistent = 0;  ///< ... whose depth agrees within the tolerance
  int in_front = 0;    ///< ... nearer than the model surface
  int behind = 0;      ///< ... behind it (seeing through a mapped surface)
};
/// Tolerance at model depth z: max(tolerance_m + tolerance_per_m z, noise_sigmas sigma(z)).
DepthConsistency depth_consistency(const FrameLevel& live, const ModelLevel& model,
                                   const SE3& T_ref_cam, double tolerance_m, double tolerance_per_m,
                                   int pixel_step, double noise_sigmas = 0.0);

/// Per-iteration normal equations (exposed for the Jacobian tests).
struct NormalEquations {
  Mat6 A = Mat6::Zero();
  Vec6 b = Vec6::Zero();  ///< J^T r
  double sum_sq = 0;      ///< sum r^2
  int count = 0;
  int overlap = 0;  ///< ICP only: projected onto a valid model pixel
  double gain = 1;  ///< photometric only: the live image's brightness gain used (rgb_step)
};

class Tracker {
 public:
  explicit Tracker(const TrackerParams& params = {});
  const TrackerParams& params() const { return params_; }

  /// Aligns `live` against `model` starting from `T_ref_cam_init`.
  AlignmentResult align(const FramePyramid& live, const ModelPyramid& model,
                        const SE3& T_ref_cam_init) const;

  /// One linearisation of each term at `T_ref_cam` on `level` (used by align and the tests).
  NormalEquations icp_step(const FrameLevel& live, const ModelLevel& model, const SE3& T_ref_cam,
                           int pixel_step) const;
  /// `huber_delta` (0..255; <= 0 off) down-weights large photometric residuals. `usable` (optional,
  /// the model level's size): only model pixels where it is non-zero are used. With
  /// rgb_estimate_gain the residuals are gain x live - model at the least-squares gain of this
  /// linearisation (NormalEquations::gain), and A, b are those of the pose with the gain solved
  /// jointly (the gain eliminated); `prior_gain` only sets the Huber weights.
  NormalEquations rgb_step(const FrameLevel& live, const ModelLevel& model, const SE3& T_ref_cam,
                           float min_gradient, int pixel_step, float huber_delta = 0.0f,
                           const MaskImage* usable = nullptr, float prior_gain = 1.0f) const;

 private:
  // The steps of align().
  /// The last linearisation of each term (the figures and gates of the result come from them).
  struct LastTerms {
    NormalEquations icp, rgb;
  };
  /// One pyramid level's images and the photometric term's usable reference pixels (or null).
  struct LevelInputs {
    const FrameLevel& live;
    const ModelLevel& model;
    int level, model_first_level;
    const MaskImage* usable;
  };
  /// Gauss-Newton over the pyramid, coarse to fine; returns the estimate. Sets
  /// *numerically_failed (and res.reason) when a level has too few correspondences or the normal
  /// equations cannot be solved.
  SE3 iterate(const FramePyramid& live, const ModelPyramid& model, const SE3& T_init,
              AlignmentResult& res, LastTerms& last, bool* numerically_failed) const;
  /// The update xi of one iteration at T (both terms weighted, damped); false with `why`.
  bool gauss_newton_step(const LevelInputs& in, const SE3& T, LastTerms& last, float& rgb_sigma,
                         float& rgb_gain, Vec6* xi, std::string* why) const;
  /// res.failed / res.weak and their reason from the result's figures and the `motion` from the
  /// initial estimate.
  void apply_quality_gates(const PinholeIntrinsics& K0, const SE3& motion, bool numerically_failed,
                           AlignmentResult& res) const;

  TrackerParams params_;
};

}  // namespace orpe::slam
