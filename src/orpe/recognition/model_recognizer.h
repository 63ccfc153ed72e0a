// The `model` segmentation back-end: recognises instances of known object models from the depth
// alone (no labels, no training, no ground truth), as detections (class, score, box, soft mask).
//
// Per keyframe (docs/SEMANTIC.md, "model"):
//  1. Scene geometry (scene_geometry.h): the depth as a grid of points, support planes removed, the
//     rest split into connected regions.
//  2. Hypotheses: the objects already known (tracks from earlier keyframes, kept in the world frame
//     with the tracked camera pose) are refined from their last pose; every region, or the part of
//     it the refined objects leave unexplained, is searched: each candidate model is registered
//     (ModelRegistrationEstimator, pose stage) to the region, or, when the region is larger than
//     the model, to crops of it around seeds spread over the region.
//  3. Joint verification: each hypothesis is scored against the whole scene -- the observed points
//     it explains (within inlier_distance_m of the model surface), the fraction of its visible
//     surface on the observed depth (support), the model points in observed free space or below
//     the support plane (violations). Greedy selection, best first: a hypothesis is kept when it
//     explains enough points that no kept hypothesis explains already, so each observed point is
//     explained once (a small model inside a larger object's points loses to the larger object;
//     touching objects are separate hypotheses). Regions no model explains are rejected and, for a
//     while, not searched again.
//  4. Detection: the pixels whose back-projected depth lies within inlier_distance_m of the fitted
//     model (the model render clipped by the observed depth), nearest model wins; probability and
//     score from the fit.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "orpe/core/se3.h"
#include "orpe/pose/model_registration.h"
#include "orpe/pose/object_model.h"
#include "orpe/recognition/resting_search.h"
#include "orpe/recognition/scene_geometry.h"
#include "orpe/semantic/segmenter.h"

namespace orpe {

struct RecognitionParams {
  // Search (registration of a model to a region or crop).
  int search_rotations = 32;  ///< rotation grid of the search (pose stage: 160)
  int search_coarse_points = 40;
  int search_refine_top_k = 2;
  int search_max_points = 250;
  double max_extent_factor = 1.15;  ///< observed extents up to this x the model's (+ slack)
  double min_extent_factor = 0.35;  ///< observed largest extent at least this x the model's
  double extent_slack_m = 0.01;
  bool min_area_extents = false;  ///< extents of the least-area rectangle, not the principal axes
  bool extent_test_by_diameter = true;  ///< points fit the model's diameter (any view does)
  double crop_radius_factor = 0.55;     ///< crops: region points within this x diameter of a seed
  double crop_spacing_factor = 0.45;    ///< seeds this x diameter apart (farthest-point sampling)
  int max_crops = 5;                    ///< per region and model
  // Resting search: boxes on the support at an observed vertical face (resting_search.h).
  bool resting_search = true;
  double resting_min_face_fraction = 0.6;  ///< models with this much of their surface on 3 axes
  int resting_face_min_cells = 60;
  double resting_face_max_tilt_deg = 15;
  double resting_face_max_bottom_m = 0.03;
  double resting_height_tolerance_m = 0.02;
  double resting_width_slack_m = 0.02;
  bool resting_top_faces = true;  ///< also at a top face cut by the image border
  // Verification.
  double inlier_distance_m = 0.01;
  double inlier_distance_per_m2 = 0;  ///< at depth z: max(inlier_distance_m, this x z^2)
  bool surface_distance = false;      ///< distance to the model surface, not to its nearest sample
  double sparse_model_spacing_fraction = 0.5;  ///< spacing / inlier distance: surface distance
  double explain_max_normal_angle_deg = 25;    ///< observed and model normals within this (0 = off)
  double free_space_margin_m = 0.015;
  double below_plane_margin_m = 0.02;
  double min_support = 0.55;           ///< visible model points on the observed depth, fraction
  double min_in_image_fraction = 0.5;  ///< of its camera-facing model points inside the image
  double resting_min_in_image_fraction = 0.1;  ///< the same for one resting on the support
  double max_violation = 0.15;        ///< model points in free space or below the support, fraction
  bool require_standing = true;       ///< a searched object off the support stands on seen surface
  double standing_max_tilt_deg = 25;  ///< what it stands on: normal this close to the support's
  int standing_window_cells = 3;      ///< looked for this many grid cells around its foot points
  int standing_min_points = 2;        ///< foot points with a support cell around them
  double standing_height_tolerance_m = 0.04;  ///< support cell this close to the foot's height
  int min_explained_points = 25;              ///< grid points a hypothesis must newly explain
  double min_colour_ncc = 0.1;  ///< a model with colour: best grey NCC with the image (-1 = off)
  bool colour_shading_correction = true;  ///< regress a + b . normal out of both greys first
  double colour_min_print_contrast = 0;   ///< plain NCC under this; tracks corrected too (0 off)
  double resting_bonus = 0.1;          ///< rank x (1 + this) for an object resting on the support
  double resting_tolerance_m = 0.006;  ///< lowest model point this close to the support plane
  bool rank_by_residual = true;      ///< rank by sum of 1 - (d / inlier distance)^2, not the count
  double solo_leak_weight = 1;       ///< rank x (1 - this x its own outline leak) (0 = off)
  double min_new_fraction = 0.6;     ///< of its explained points not explained by a kept one
  double min_inlier_fraction = 0.5;  ///< of the crop's points the fit explains
  double min_region_coverage = 0.6;  ///< of a region's points the kept objects must explain
  double max_boundary_leak = 0.25;   ///< outline fraction continuing into unexplained surface
  double boundary_continuation_m = 0.015;
  bool fill_outline_holes = true;  ///< holes enclosed by an object are no part of its outline
  bool concave_crease_stops_leak = true;  ///< a concave crease at the outline is no continuation
  double crease_min_angle_deg = 35;       ///< normals this far apart across it
  double smooth_edge_max_angle_deg = 20;  ///< a shared edge without a crease continues the surface
  double smooth_edge_max_step_m =
      0.004;  ///< and the far side within this of the near tangent plane
  double smooth_edge_max_colour_step = 25;  ///< and the colour the same on both sides (0-255)
  int normal_radius_cells = 3;              ///< window of the grid normals (edge test)
  double max_seam_fraction = 0.5;  ///< a shared edge more seamless than this is no object boundary
  int min_seam_pairs = 10;         ///< outline pairs a shared edge needs for that test
  double max_silhouette_overflow = -1;  ///< unexplained surface beyond the model outline (-1 off)
  int silhouette_margin_cells = 1;      ///< the model silhouette widened by this (grid cells)
  double silhouette_support_max_tilt_deg = 0;  ///< the walk stops at the object's support (0 off)
  double silhouette_support_height_m = 0.02;   ///< support: this close to the object's foot
  // Tracks (objects known from earlier keyframes).
  double track_bonus = 1.5;             ///< ranking factor of a refined known object
  double track_crop_distance_m = 0.02;  ///< refine on points this close to the predicted surface
  int track_max_misses = 3;          ///< keyframes in view without being kept before it is dropped
  int reject_memory_keyframes = 10;  ///< keyframes a searched region is not searched again
  /// a searched region's unexplained part smaller than this (grid points) is not remembered
  int reject_memory_min_points = 150;
  double reject_radius_m = 0.03;       ///< a region whose centroid is this close to a rejected one
  double detection_probability = 0.9;  ///< soft mask value on the explained pixels

  template <class V>
  void visit(V&& v) {
    v("search_rotations", search_rotations, "Rotation hypotheses per model and region (search)");
    v("search_coarse_points", search_coarse_points, "Points per rotation in the coarse stage");
    v("search_refine_top_k", search_refine_top_k, "Coarse hypotheses refined per search");
    v("search_max_points", search_max_points, "Points of a region used for refinement and scoring");
    v("max_extent_factor", max_extent_factor,
      "A region whose principal extents are at most this x the model's (+ extent_slack_m) is "
      "fitted whole; larger ones in crops");
    v("min_extent_factor", min_extent_factor,
      "A region (crop) whose largest extent is under this x the model's is not searched for it");
    v("extent_slack_m", extent_slack_m, "Slack (m) of the extent test (depth noise, mixed pixels)");
    v("min_area_extents", min_area_extents,
      "Extents along the two dominant principal axes turned to the bounding rectangle of least "
      "area (on a face close to square the principal axes are the diagonals, whose extents exceed "
      "the sides); false = the principal axes' extents");
    v("extent_test_by_diameter", extent_test_by_diameter,
      "Size test of a region (crop) for a model: its diameter (largest distance between two of "
      "its points) at most max_extent_factor x the model's (+ extent_slack_m), whatever the view "
      "(a box seen by three faces has principal axes along no edge of it, and its principal "
      "extents exceed the box's); false = its two largest principal extents against the model's");
    v("crop_radius_factor", crop_radius_factor,
      "Crop of a large region: its points within this x the model diameter of a seed");
    v("crop_spacing_factor", crop_spacing_factor,
      "Seeds of the crops this x the model diameter apart (farthest-point sampling)");
    v("max_crops", max_crops, "Crops per region and model");
    v("resting_search", resting_search,
      "Besides the crops, every region is searched for boxes resting on the support on one of "
      "their faces at each vertical face it shows (the box's face on the observed face, its "
      "bottom on the plane), refined from there: a box touched by other objects is held by no "
      "crop alone; false = crops only");
    v("resting_min_face_fraction", resting_min_face_fraction,
      "Resting search: models with at least this fraction of their surface normals within 10 "
      "degrees of three orthogonal axes (boxes) are placed");
    v("resting_face_min_cells", resting_face_min_cells,
      "Resting search: grid cells of a vertical face (normal within resting_face_max_tilt_deg of "
      "horizontal, one offset within 1.5 cm)");
    v("resting_face_max_tilt_deg", resting_face_max_tilt_deg,
      "Resting search: a face's normals at most this far (deg) from the support plane");
    v("resting_face_max_bottom_m", resting_face_max_bottom_m,
      "Resting search: a face whose lowest points (2nd percentile) are higher than this (m) over "
      "the support does not reach it (the plane removal takes its lowest plane_distance_m)");
    v("resting_height_tolerance_m", resting_height_tolerance_m,
      "Resting search: the model's extent along the support normal within this (m) of the face's "
      "top (98th percentile of its heights)");
    v("resting_width_slack_m", resting_width_slack_m,
      "Resting search: the face may be this much (m) wider than the model's side along it; a "
      "face narrower by more is partly hidden and the model is aligned with either end of it");
    v("resting_top_faces", resting_top_faces,
      "Resting search: boxes are also placed at each top face a region shows that the image "
      "border cuts (normals within resting_face_max_tilt_deg of the support normal, "
      "resting_face_min_cells cells, some on the border): standing on the support on the axis "
      "whose extent is the face's height, turned along the face's outline, centred on it or "
      "flush with either end of it. A box close to the camera at the bottom border shows its top "
      "and little of its sides (vertical faces whose foot leaves the image are searched too); "
      "top faces inside the image are not searched: there the vertical faces hold the box, and "
      "the top-face poses let a smaller box standing on its end outrank a lying block (YCB-Video "
      "clip 0002's wood block as a sugar box); false = vertical faces only");
    v("inlier_distance_m", inlier_distance_m,
      "An observed point within this distance (m) of the model surface is explained");
    v("inlier_distance_per_m2", inlier_distance_per_m2,
      "The inlier distance grows with the depth z as max(inlier_distance_m, this x z^2, m): a "
      "triangulating sensor's depth error grows with z^2 (Kinect-type: quantisation step 2.9 mm "
      "and noise sigma ~2 mm at 1 m, 3x and 2x at 1.3 m); 0 = inlier_distance_m everywhere");
    v("surface_distance", surface_distance,
      "An observed point's distance to a model (explained points, fit, masks) is to the surface "
      "its samples stand for: the nearest sample's tangent plane, unless the point lies farther "
      "from that sample than the model's mean sample spacing explains (the pose stage's fit "
      "distance); false = to the nearest sample (a large model's samples are centimetres apart, "
      "so its own surface is partly unexplained even at the exact pose)");
    v("sparse_model_spacing_fraction", sparse_model_spacing_fraction,
      "A model whose samples lie on average at least this fraction of inlier_distance_m apart "
      "(mean distance to the nearest other sample) is measured with the surface distance (as "
      "surface_distance=true) whatever surface_distance says: a model has a fixed number of "
      "samples, so a large one's holes between samples reach the inlier distance and the "
      "nearest-sample distance leaves channels of its own surface unexplained at its exact pose "
      "(the 0.40 x 0.30 x 0.24 m synthetic crate, 7.4 mm mean spacing, was dropped for the "
      "outline they leak); densely sampled models (the YCB-Video ones: 0.8-3.1 mm) keep the "
      "nearest-sample distance; 0 = off (surface_distance alone decides)");
    v("explain_max_normal_angle_deg", explain_max_normal_angle_deg,
      "An observed point is explained by a model (explained points, fit, selection) only where "
      "its normal (grid plane fit, normal_radius_cells) is within this angle (deg) of the model's "
      "at its nearest sample: a curved model 1 cm from a flat face crosses it at an angle where "
      "it curves away (a bottle lying on its side against a box's face); points without a normal "
      "pass; 0 = off (distance alone)");
    v("free_space_margin_m", free_space_margin_m,
      "A visible model point this far (m) in front of the observed depth is a violation");
    v("below_plane_margin_m", below_plane_margin_m,
      "A model point this far (m) below the support plane is a violation");
    v("min_support", min_support,
      "A hypothesis needs this fraction of its visible model points on the observed depth");
    v("min_in_image_fraction", min_in_image_fraction,
      "A searched hypothesis (not a known object) needs this fraction of its camera-facing model "
      "points to project inside the image: a model fitted to a strip of clutter at the image "
      "border is held by the little of it the frame shows; 0 = off");
    v("resting_min_in_image_fraction", resting_min_in_image_fraction,
      "The min_in_image_fraction of a searched hypothesis resting on the support plane (its "
      "lowest model point within resting_tolerance_m of it; the smaller of the two applies): an "
      "object standing on the table with its top in view and its foot beyond the image border is "
      "held by its height over the table as well as by what the frame shows of it (a box close "
      "to the camera at the bottom border, 14-17 % of its camera-facing points in view); 0 = "
      "no image-border test for resting objects");
    v("require_standing", require_standing,
      "A searched hypothesis whose lowest model point is more than resting_tolerance_m over the "
      "support plane must stand on observed surface: at least standing_min_points of its foot "
      "points (model points within 1 cm of its lowest) have, within standing_window_cells grid "
      "cells of their projection, a kept cell within standing_height_tolerance_m of the foot's "
      "height whose normal is within standing_max_tilt_deg of the support's (the top of the crate "
      "a can is stacked on), or lie on another removed plane (a shelf board). A can model fitted "
      "to the top end of a taller cylinder floats: under its foot the cylinder's side goes on "
      "down. Foot points outside the image are no evidence either way; known objects are not "
      "tested; false = off");
    v("standing_max_tilt_deg", standing_max_tilt_deg,
      "Standing test: a support cell's normal is within this angle (deg) of the support plane's");
    v("standing_window_cells", standing_window_cells,
      "Standing test: half-width (grid cells) of the window around a foot point's projection");
    v("standing_min_points", standing_min_points,
      "Standing test: foot points that must find a support cell");
    v("standing_height_tolerance_m", standing_height_tolerance_m,
      "Standing test: a support cell lies within this distance (m) of the foot's height over the "
      "support plane (a searched pose of a stacked can may float 2-3 cm over the crate's top "
      "before its refinement)");
    v("max_violation", max_violation,
      "A hypothesis may have at most this fraction of model points in free space / below the "
      "support");
    v("min_colour_ncc", min_colour_ncc,
      "A hypothesis of a model with its own colour (texture or vertex colours) whose grey levels "
      "correlate with the image's (NCC over the visible samples, best of its pose and the turns "
      "geometry confuses with it) less than this is rejected: a flat-painted object of the "
      "model's shape and size correlates ~0 with its print; no colour image, a model without "
      "colour or too few visible samples: no test; -1 = off");
    v("colour_shading_correction", colour_shading_correction,
      "The colour test's NCC is taken after a least-squares fit of a constant and the three "
      "components of the sample normal (camera frame) is subtracted from the model's and the "
      "image's grey levels: under a distant light a flat-painted surface's shading is linear in "
      "its normal and can correlate with some turn of a print by chance; false = the plain NCC");
    v("colour_min_print_contrast", colour_min_print_contrast,
      "Shading-corrected colour test: at a pose where the model's residual grey levels (after the "
      "shading fit, 0-1) vary less than this (weighted standard deviation: a print of little "
      "contrast besides its shading, the YCB-Video banana 0.03-0.13, the cracker box 0.21-0.23) "
      "the plain NCC is taken instead; and with it on, known objects (tracks) are held to the "
      "corrected test too, not to the plain one; 0 = off (tracks keep the plain NCC)");
    v("min_explained_points", min_explained_points,
      "Grid points a hypothesis must newly explain to be kept");
    v("resting_bonus", resting_bonus,
      "Objects rest on something: a hypothesis whose lowest model point lies on the support "
      "plane (within resting_tolerance_m) ranks this fraction higher than one hovering over it "
      "(a can cut by the image border is explained as well by a 5 mm thinner can 12 mm shorter, "
      "which floats 11 mm above the table); stacked objects, whose support is not the plane, are "
      "not tested (they compete with hypotheses of their own points, which rarely reach the "
      "plane without violating free space); 0 = off");
    v("resting_tolerance_m", resting_tolerance_m,
      "Distance (m) of the lowest model point from the support plane under which it rests on it");
    v("rank_by_residual", rank_by_residual,
      "Hypotheses are ranked by how closely they explain their points (sum over the explained "
      "points of 1 - (distance / inlier distance)^2, times the support): of two models of "
      "nearly one size (cans whose radii differ by 4 mm) the one that fits the surface wins, not "
      "the one whose inlier band happens to hold a few more points; false = the explained count");
    v("solo_leak_weight", solo_leak_weight,
      "A hypothesis' rank is multiplied by 1 - this x its own outline leak: the fraction of its "
      "outline where the observed surface continues (boundary_continuation_m, no concave crease) "
      "into points it does not explain, measured as if it were alone. Of two models explaining "
      "one face, the one whose surface ends where the object's does wins (a wood block explains "
      "its front face, its top and its edges; a bottle lying against that face leaves the top "
      "and the ends as continuing surface); 0 = off");
    v("min_new_fraction", min_new_fraction,
      "Fraction of a hypothesis' explained points that no kept hypothesis explains");
    v("min_inlier_fraction", min_inlier_fraction,
      "Fraction of the searched crop's points the fit must explain");
    v("min_region_coverage", min_region_coverage,
      "A region whose points the kept objects explain less than this fraction of is clutter: the "
      "objects it mostly holds are dropped");
    v("max_boundary_leak", max_boundary_leak,
      "An object whose outline continues, for more than this fraction, into observed surface no "
      "kept object explains is a part of something larger (clutter) and dropped");
    v("boundary_continuation_m", boundary_continuation_m,
      "Outline test: a point two grid cells outside within this distance (m) continues the "
      "surface");
    v("fill_outline_holes", fill_outline_holes,
      "Outline test: cells enclosed by an object's explained cells (depth noise, dents or print "
      "the model does not have) are inside it, not outline; false = every unexplained neighbour "
      "is outline");
    v("concave_crease_stops_leak", concave_crease_stops_leak,
      "Outline test: where the surface beyond the outline folds inwards (a concave crease, the "
      "normals crease_min_angle_deg or more apart), it does not continue the object (another "
      "object rests on or leans against it there): no leak; false = such cells leak too");
    v("crease_min_angle_deg", crease_min_angle_deg,
      "Angle (deg) between the normals of the two sides of a concave crease (outline test)");
    v("smooth_edge_max_angle_deg", smooth_edge_max_angle_deg,
      "Outline test across two kept objects' shared edge: where the surface continues (within "
      "boundary_continuation_m) with normals within this angle (deg), no crease or depth step "
      "separates them, so the edge counts as leaking (clutter tiled by hypotheses)");
    v("smooth_edge_max_step_m", smooth_edge_max_step_m,
      "... and the far side of the edge lies within this distance (m) of the near side's tangent "
      "plane (no step)");
    v("smooth_edge_max_colour_step", smooth_edge_max_colour_step,
      "... and the colour (3x3 means, largest channel difference, 0-255) differs by less than "
      "this across it (no colour image: geometry alone)");
    v("normal_radius_cells", normal_radius_cells,
      "Half-width (grid cells) of the window whose points' plane fit gives a cell's normal");
    v("max_seam_fraction", max_seam_fraction,
      "Two kept objects whose shared edge is seamless (surface, normals and colour continue) for "
      "more than this fraction of its outline pairs tile one surface: the lower-ranked is dropped");
    v("min_seam_pairs", min_seam_pairs, "Outline pairs a shared edge needs for the seam test");
    v("max_silhouette_overflow", max_silhouette_overflow,
      "An object whose observed surface continues (steps under boundary_continuation_m, one "
      "region, no kept object explaining it) beyond the outline its model projects to, over more "
      "grid cells than this fraction of the cells it explains, is a part of something larger (a "
      "distractor longer than the model fitted to one end of it) and dropped; -1 = off");
    v("silhouette_margin_cells", silhouette_margin_cells,
      "The projected model outline of the silhouette test widened by this many grid cells (pose "
      "error, mixed pixels)");
    v("silhouette_support_max_tilt_deg", silhouette_support_max_tilt_deg,
      "Silhouette test: the walk does not enter what the object stands on -- cells within "
      "silhouette_support_height_m of the height of its lowest model point over the support "
      "plane whose normal is within this angle (deg) of the plane's (the top of an unexplained "
      "crate a can is stacked on); the vertical side of a distractor below a model fitted to its "
      "top end is no support; 0 = off");
    v("silhouette_support_height_m", silhouette_support_height_m,
      "Silhouette test: a support cell lies within this distance (m) of the height of the "
      "object's lowest model point over the support plane");
    v("track_bonus", track_bonus, "Ranking factor of a known object refined from its last pose");
    v("track_crop_distance_m", track_crop_distance_m,
      "A known object is refined on the kept points within this distance (m) of its model at the "
      "predicted pose (its last pose seen from the tracked camera), not on every point within 0.6 "
      "diameters of its centre: a box next to another object otherwise slides over to explain "
      "both, and its track bonus then outranks the neighbour; 0 = the ball");
    v("track_max_misses", track_max_misses,
      "A known object in view but not confirmed this many keyframes is forgotten");
    v("reject_memory_keyframes", reject_memory_keyframes,
      "Keyframes during which a searched region is not searched again (what it held is known "
      "and refined from then on; what no model explained would not be found either)");
    v("reject_memory_min_points", reject_memory_min_points,
      "A searched region whose unexplained part has fewer grid points than this is not "
      "remembered, but searched again on the next keyframe: its search is cheap (a crop per "
      "model), and a small or far object's first few dozen points may not register where a "
      "later view's do; 0 = remember every region");
    v("reject_radius_m", reject_radius_m,
      "A region whose unexplained part's centroid is within this distance (m) of a searched one "
      "is skipped");
    v("detection_probability", detection_probability,
      "Soft mask probability of the pixels a kept hypothesis explains");
  }
  bool IsValid(std::string* why) const;
};

/// The class ids named by `spec` (comma-separated names or ids; empty = every class of
/// `class_names` that `has_model` accepts), sorted. Throws ConfigError for an unknown name or id,
/// or when no class is left.
std::vector<int> resolve_model_classes(const std::string& spec,
                                       const std::map<int, std::string>& class_names,
                                       const std::vector<int>& classes_with_models);

/// Where the time of one call went (wall ms per step; cpu_ms = process CPU time over all threads,
/// which bounds the wall time of the call on an idle machine).
struct RecognitionTiming {
  double geometry_ms = 0;    ///< grid, support planes, regions
  double tracks_ms = 0;      ///< refinement of the known objects
  double search_ms = 0;      ///< searches of the unexplained regions
  double verify_ms = 0;      ///< joint selection and clutter rejection
  double detections_ms = 0;  ///< masks
  double total_ms = 0;
  double cpu_ms = 0;
  int refinements = 0, searches = 0;
};

/// One verified object hypothesis (for diagnosis and tests).
struct RecognizedObject {
  int class_id = 0;
  SE3 T_cam_obj;
  int explained_points = 0;  ///< grid points
  double support = 0;
  double violation = 0;
  bool from_track = false;
  double fit = 0;         ///< sum over the explained points of 1 - (d / inlier distance)^2
  double solo_leak = -1;  ///< outline leak as if alone (-1: not measured)
  double rank = 0;
  double in_image = 1;  ///< of its camera-facing model points, the fraction inside the image
  bool stands = true;   ///< rests on the support or stands on observed surface (require_standing)
};

class ModelRecognizer final : public Segmenter {
 public:
  /// `models`: the candidate models (prepared). Throws ConfigError for invalid params or no model.
  ModelRecognizer(const SegmentationParams& segmentation, const RecognitionParams& params,
                  const SceneGeometryParams& geometry, std::vector<ObjectModel> models);
  std::string name() const override { return "model"; }
  /// One frame on its own (no memory of earlier keyframes).
  std::vector<Detection> detect(const RgbdFrame& frame) const override;
  /// With the tracked pose: known objects are refined, then the rest is searched.
  std::vector<Detection> detect_in_context(const RgbdFrame& frame,
                                           const SegmentationContext& context) override;
  /// The model of `class_id` at a given pose, scored against the frame as a searched hypothesis
  /// would be (explained points, fit, support, violation, solo leak, rank; diagnosis and tests).
  /// Throws ConfigError for a class without a model.
  RecognizedObject score_pose(const RgbdFrame& frame, int class_id, const SE3& T_cam_obj) const;
  /// The objects kept in the last call.
  const std::vector<RecognizedObject>& last_objects() const { return last_objects_; }
  /// Registrations run in the last call (searches and refinements).
  int last_registrations() const { return last_timing_.refinements + last_timing_.searches; }
  const RecognitionTiming& last_timing() const { return last_timing_; }

  struct Track {
    int class_id = 0;
    SE3 T_world_obj;
    int hits = 0, misses = 0;
  };
  struct Rejected {
    Vec3 centroid_world;
    int keyframe = 0;
  };
  struct State {
    std::vector<Track> tracks;
    std::vector<Rejected> rejected;
    int keyframe = 0;
  };

 private:
  struct Pass;  ///< one call's working set (model_recognizer.cpp)
  std::vector<Detection> run(const RgbdFrame& frame, const SE3& T_world_cam, State* state) const;
  SegmentationParams segmentation_;
  RecognitionParams params_;
  SceneGeometryParams geometry_;
  std::vector<ObjectModel> models_;
  std::vector<Eigen::Vector3f> model_extents_;  ///< principal extents, largest first
  std::vector<ModelFaceAxes> model_face_axes_;  ///< the resting search's box axes
  ModelRegistrationEstimator search_, refine_;
  State state_;
  mutable std::vector<RecognizedObject> last_objects_;
  mutable RecognitionTiming last_timing_;
};

}  // namespace orpe
