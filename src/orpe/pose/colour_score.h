// Colour evidence for the pose stage: which of the poses that geometry cannot tell apart (a box and
// the same box turned 180 degrees, a can turned about its axis) shows the object's appearance where
// the image shows it.
//
// The appearance of a model (ModelColour) is a set of surface samples in the object frame, each
// with a grey level in [0, 1] and a weight (0 = unknown). Three sources:
//  - the model's own colour: a textured mesh (OBJ + MTL + image, PLY + TextureFile) or per-vertex
//    colours, sampled on the surface (model_colour_from_mesh);
//  - annotated recordings: frames with known object poses (e.g. one YCB-Video clip) project the
//    samples into each image and average the grey levels seen there (ModelColourAccumulator);
//  - the map: the same accumulator fed with keyframes at the object's fused pose (pipeline).
//
// Score of a pose (colour_agreement): the samples facing the camera, inside the instance's mask and
// not occluded (observed depth within `depth_tolerance_m` of the sample's) are projected into the
// image; the score is the weighted normalised cross-correlation (NCC) of their grey levels with the
// image's (3x3 box-filtered) grey levels. NCC is invariant to a gain and an offset of the image, so
// a brighter or dimmer light does not change it; a flipped pose puts the wrong half of the texture
// on the visible pixels and correlates near 0.
#pragma once

#include <iosfwd>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "orpe/core/camera.h"
#include "orpe/core/image.h"
#include "orpe/core/se3.h"

namespace orpe {

struct ObjectModel;
struct TriangleMesh;

struct ModelColour {
  std::vector<Eigen::Vector3f> points;   ///< surface samples, metres, object frame
  std::vector<Eigen::Vector3f> normals;  ///< unit, outward
  std::vector<float> grey;               ///< [0, 1]
  std::vector<float> weight;             ///< >= 0; 0 = colour unknown at this sample
  /// Chromaticity (r, g) / (r + g + b) of each sample, in [0, 1]: its colour without its
  /// brightness, which a Lambert shading scales away (a green and a cream band of about one grey
  /// level still differ here). Empty = grey only (a colour model file of version 1).
  std::vector<Eigen::Vector2f> chroma;
  std::string source;                    ///< "texture", "vertex colours", "learned: ..."

  size_t size() const { return points.size(); }
  bool has_chroma() const { return !points.empty() && chroma.size() == points.size(); }
  /// Samples with a known colour.
  size_t num_known() const;
  /// Sizes consistent and finite values.
  bool IsValid(std::string* why) const;
};

struct ColourScoreParams {
  bool enabled = true;
  double weight = 0.5;
  double geometry_margin = 0.08;
  int min_pixels = 60;
  double depth_tolerance_m = 0.015;
  bool try_flips = true;
  bool try_quarter_turns = true;
  bool refine_turn = true;
  double min_learned_fraction = 0.3;
  std::string evidence = "lambert";  ///< lambert | local_contrast | ncc
  double local_contrast_radius = 0.05;
  double chroma_weight = 0.5;
  double chroma_min_spread = 0.02;
  double chroma_min_grey = 0.08;

  template <class V>
  void visit(V&& v) {
    v("colour_enabled", enabled,
      "Rank the candidate poses geometry cannot separate by colour agreement (needs a colour image "
      "and a model with colour: texture, vertex colours or learned)");
    v("colour_weight", weight,
      "Weight of the colour NCC (in [-1, 1]) added to the geometric score of each candidate");
    v("colour_geometry_margin", geometry_margin,
      "Only candidates whose geometric score is within this of the best compete on colour");
    v("colour_min_pixels", min_pixels,
      "Fewer visible coloured samples -> no colour evidence for that candidate (NCC 0)");
    v("colour_depth_tolerance_m", depth_tolerance_m,
      "A sample is visible when the observed depth at its pixel is within this (m) of its own");
    v("colour_try_quarter_turns", try_quarter_turns,
      "Models without a continuous symmetry axis: the 90-degree turns about the principal axes "
      "compete too (refined, within colour_geometry_margin)");
    v("colour_try_flips", try_flips,
      "Also refine the best pose turned 180 degrees about each principal axis of the model (and "
      "by 30-degree steps about a continuous symmetry axis): the modes geometry confuses");
    v("colour_refine_turn", refine_turn,
      "Models with a continuous symmetry axis (cans): choose the turn about the axis by colour "
      "(10-degree steps, then 5, 2.5, 1.25 about the best), which geometry leaves free");
    v("colour_min_learned_fraction", min_learned_fraction,
      "A learned colour model is used only when this fraction of its samples has a colour");
    v("colour_evidence", evidence,
      "What a candidate is ranked by: lambert (lambert_agreement: the share of the image's grey "
      "variation beyond a shading of the normals that the model's shaded albedo explains), "
      "local_contrast (local_contrast_agreement: the NCC of each side minus its local mean) or "
      "ncc (colour_agreement: the plain NCC of grey levels, which a shading gradient across a "
      "curved label can fool)");
    v("colour_local_contrast_radius", local_contrast_radius,
      "colour_evidence=local_contrast: the radius of the local mean, a fraction of the model's "
      "bounding-box diagonal");
    v("colour_chroma_weight", chroma_weight,
      "Share of the chromaticity agreement (chroma_agreement) in a candidate's colour evidence, "
      "the grey evidence the rest; used when the model has chromaticity that varies over the "
      "visible samples (0 = grey only, as before session 22)");
    v("colour_chroma_min_spread", chroma_min_spread,
      "The visible samples' chromaticity must spread by at least this (weighted RMS distance from "
      "their mean; a cream/green label ~0.07, a grey print 0) for chroma evidence");
    v("colour_chroma_min_grey", chroma_min_grey,
      "Image pixels darker than this grey level (3x3 mean, [0, 1]) have too noisy a "
      "chromaticity: left out of the chroma evidence");
  }
  bool IsValid(std::string* why) const;
};

struct ColourAgreement {
  double ncc = 0;  ///< weighted NCC in [-1, 1]; 0 when not valid
  int pixels = 0;  ///< visible coloured samples used
  bool valid = false;
};

/// Grey level in [0, 1] of a colour with channels in [0, 255] (Rec. 601 luma).
inline float grey_of(const Eigen::Vector3f& rgb) {
  return (0.299f * rgb.x() + 0.587f * rgb.y() + 0.114f * rgb.z()) / 255.0f;
}
inline float grey_of(const Rgb8& c) { return grey_of(Eigen::Vector3f(c.r, c.g, c.b)); }

/// Grey levels of a model colour spanning less than this are one colour (no evidence).
constexpr float kUniformGreyRange = 2.0f / 255.0f;

/// Samples `samples` points on the textured or vertex-coloured mesh (object frame, metres), with
/// outward normals from the triangles. nullptr when the mesh has neither texture nor colours, or
/// when its samples all have the same grey level and chromaticity (within kUniformGreyRange: a mesh
/// with one vertex colour everywhere says nothing about the pose). The samples carry chromaticity.
std::shared_ptr<ModelColour> model_colour_from_mesh(const TriangleMesh& mesh, int samples = 20000,
                                                    unsigned seed = 11);

/// Agreement of the image with the model's colour at T_cam_obj (see above).
ColourAgreement colour_agreement(const ModelColour& colour, const SE3& T_cam_obj,
                                 const ColorImage& image, const DepthImage& depth,
                                 const MaskImage& mask, const PinholeIntrinsics& K,
                                 const ColourScoreParams& params);

/// Agreement under an unknown Lambert shading. Under a distant light the image's grey level of a
/// visible sample is y = o + a (c0 + c . n): its albedo a (the mean grey level of the model's
/// visible samples in its 3x3 pixel box, as y is the image's: a print finer than a pixel averages
/// alike on both sides instead of aliasing on the model's; session 19) times a shading
/// linear in its normal n (camera frame; ambient + diffuse where the light reaches it, a gain per
/// face of a box), plus an offset o. Two weighted least-squares fits over the same samples:
///   shading alone:  y ~ [1, n]          (residual sum of squares RSS_s; 4 parameters)
///   shaded albedo:  y ~ [1, a, a n]     (RSS_a; 5 parameters)
/// `ncc` = 1 - RSS_a / RSS_s, clamped to [-1, 1]: 1 when the albedo at this pose explains all the
/// grey variation the shading leaves, 0 for a model of one colour (both fits are then the same),
/// negative when the albedo, put where this pose puts it, fits worse than shading alone. The plain
/// NCC correlates the unshaded albedo with the shaded image; across a can's curved label the
/// shading gradient can dominate the grey levels and a wrong turn of the label match it by chance
/// (docs/RESULTS.md, synthetic textured scenes). Only samples whose 3x3 box of pixels lies on the
/// surface (every neighbour's depth within params.depth_tolerance_m of the pixel's, inside the
/// mask) count: at the outline the box mixes in the background, a misfit no shading or albedo
/// explains that would swamp the print's share of the residual. Not valid with fewer than
/// params.min_pixels samples or when the shading alone explains the image (RSS_s per unit weight
/// under 1e-6).
ColourAgreement lambert_agreement(const ModelColour& colour, const SE3& T_cam_obj,
                                  const ColorImage& image, const DepthImage& depth,
                                  const MaskImage& mask, const PinholeIntrinsics& K,
                                  const ColourScoreParams& params);

/// Agreement of local contrast: the NCC of the model's and the image's grey levels, each minus its
/// own local mean. Both sides are taken over the same visible samples (visible_colour_samples):
/// the model's grey of a sample is the mean over the samples in its 3x3 pixel box (the image's grey
/// is its 3x3 mean: a print finer than a pixel averages alike on both sides), its local mean the mean over
/// the samples in the square of half-side R pixels, R = fx * params.local_contrast_radius * (the
/// model's bounding-box diagonal) / (median depth of the visible samples), at least 1; the image's
/// likewise. The outline and occlusions thus cut both sides alike. A shading that varies slowly
/// across the window (a can's curved side, a light gradient) leaves the image's local contrast near
/// the print's contrast times the local shading, so a wrong turn of a label no longer matches the
/// shading itself. A model of one colour has no local contrast: no evidence. Same validity rules
/// as colour_agreement (params.min_pixels samples, neither side flat).
ColourAgreement local_contrast_agreement(const ModelColour& colour, const SE3& T_cam_obj,
                                         const ColorImage& image, const DepthImage& depth,
                                         const MaskImage& mask, const PinholeIntrinsics& K,
                                         const ColourScoreParams& params);

/// Agreement of chromaticity: the weighted correlation of the model's and the image's (r, g)
/// chromaticity over the visible samples (visible_colour_samples) whose 3x3 pixel box lies on the
/// surface and is not darker than params.chroma_min_grey: sum w (m - m_mean) . (i - i_mean) over
/// the root of the product of both sides' weighted sums of squares, in [-1, 1]. Chromaticity does
/// not change with a white light's brightness or a Lambert shading, so a label whose colours have
/// about one grey level (green and cream) still tells its top from its bottom. Not valid without
/// chromaticity in the model, with fewer than params.min_pixels samples, when the model's visible
/// chromaticity spreads less than params.chroma_min_spread or the image's is flat.
ColourAgreement chroma_agreement(const ModelColour& colour, const SE3& T_cam_obj,
                                 const ColorImage& image, const DepthImage& depth,
                                 const MaskImage& mask, const PinholeIntrinsics& K,
                                 const ColourScoreParams& params);

/// The colour evidence the pose stage ranks candidates by, as params.evidence names it:
/// lambert_agreement, local_contrast_agreement or colour_agreement; with chromaticity in the
/// model (and params.chroma_weight > 0) blended with chroma_agreement when that is valid:
/// (1 - chroma_weight) * grey + chroma_weight * chroma (the chroma alone when the grey evidence is
/// not valid).
ColourAgreement pose_colour_evidence(const ModelColour& colour, const SE3& T_cam_obj,
                                     const ColorImage& image, const DepthImage& depth,
                                     const MaskImage& mask, const PinholeIntrinsics& K,
                                     const ColourScoreParams& params);

/// One model colour sample seen in the image (colour_agreement's visibility test).
struct VisibleColourSample {
  size_t index = 0;        ///< into the ModelColour's samples
  float image_grey = 0;    ///< 3x3 box-filtered grey level of its pixel, [0, 1]
  Eigen::Vector2f image_chroma{1.0f / 3, 1.0f / 3};  ///< chromaticity of the 3x3 mean colour
  Eigen::Vector3f normal;  ///< the sample's normal in the camera frame
  int u = 0, v = 0;        ///< its pixel
};

/// The samples of `colour` with a known colour (weight > 0) that colour_agreement correlates at
/// T_cam_obj: facing the camera, inside `mask` (when not empty), on a pixel whose observed depth
/// lies within `depth_tolerance_m` of the sample's. Empty when the image and depth sizes differ.
std::vector<VisibleColourSample> visible_colour_samples(
    const ModelColour& colour, const SE3& T_cam_obj, const ColorImage& image,
    const DepthImage& depth, const MaskImage& mask, const PinholeIntrinsics& K,
    double depth_tolerance_m);

/// The poses geometry tends to confuse with T_cam_obj: T_cam_obj * S for S = 180-degree turns about
/// the three principal axes of the model points (through their bounding-box centre), and 30-degree
/// steps about the model's continuous symmetry axis when it has one; with `quarter_turns` and no
/// continuous axis, then also the 90-degree turns both ways about each principal axis.
std::vector<SE3> confusable_poses(const ObjectModel& model, const SE3& T_cam_obj,
                                  bool quarter_turns = false);

/// Whether `model` carries a colour model usable under `params`.
bool has_usable_colour(const ObjectModel& model, const ColourScoreParams& params);

/// Builds a colour model from frames with known object poses: each frame's visible samples get the
/// grey level and chromaticity under them, averaged over frames (weight = 1 where seen).
/// Samples start from the model's own points and normals.
class ModelColourAccumulator {
 public:
  explicit ModelColourAccumulator(const ObjectModel& model);
  /// Adds one view. `mask` may be empty (all pixels; the depth test still rejects occlusion).
  /// Returns the samples that received a colour.
  int add_view(const SE3& T_cam_obj, const ColorImage& image, const DepthImage& depth,
               const MaskImage& mask, const PinholeIntrinsics& K, double depth_tolerance_m = 0.01);
  /// Adds another accumulator's views (same model).
  void merge(const ModelColourAccumulator& other);
  int views() const { return views_; }
  /// The averaged colour (a copy); `source` names where it came from.
  std::shared_ptr<ModelColour> result(const std::string& source) const;

 private:
  ModelColour colour_;
  std::vector<double> sum_;
  std::vector<Eigen::Vector2d> chroma_sum_;
  std::vector<double> count_;
  int views_ = 0;
};

struct SingleViewPose;

/// When an object's colour is learned from the map (models without colour of their own), and how
/// a wrong mode is kept from being locked in: colour learned at a wrong pose would, from then on,
/// confirm that wrong pose. So the colour is seeded only from views whose geometry alone singled
/// out the pose (geometry_margin >= min_geometry_margin: e.g. a handle or a bump in sight) and
/// that the fused pose agrees with (the view joined the reported mode, which has >= min_fused_views
/// views); once seeded, views whose learned colour singles out their pose (colour lead >=
/// min_colour_margin) extend it to the sides seen later. A geometry-decisive view that the fused
/// pose rejects contradicts the learned colour: after `reset_after_contradictions` of them the
/// learned colour is dropped and must be seeded again.
struct ColourLearningParams {
  bool enabled = true;
  int min_fused_views = 3;
  double min_geometry_margin = 0.05;
  double min_colour_margin = 0.2;
  int reset_after_contradictions = 2;
  double depth_tolerance_m = 0.01;

  template <class V>
  void visit(V&& v) {
    v("colour_learn", enabled,
      "Learn the colour of models without their own from the views at the fused pose (needs the "
      "EKF); used on later views");
    v("colour_learn_min_fused_views", min_fused_views,
      "Learn only once the fused pose has this many views");
    v("colour_learn_min_geometry_margin", min_geometry_margin,
      "Seed the colour only from views whose geometric score lead over other rotations is at "
      "least this (geometry alone singled out the pose)");
    v("colour_learn_min_colour_margin", min_colour_margin,
      "Once seeded, also learn from views whose learned colour leads by at least this");
    v("colour_learn_reset_after_contradictions", reset_after_contradictions,
      "Drop the learned colour after this many geometry-decisive views the fused pose rejects");
    v("colour_learn_depth_tolerance_m", depth_tolerance_m,
      "Visibility test of a sample when learning (m)");
  }
  bool IsValid(std::string* why) const;
};

/// The learning rule above for one object (one map instance).
class ColourLearner {
 public:
  /// Throws std::invalid_argument when `base` has no normals.
  ColourLearner(const ObjectModel& base, const ColourLearningParams& params);
  /// One view: the view's single-view estimate `sv` (on the current model()), whether the fusion
  /// put it into the reported mode, that mode's number of views, and the fused pose after the
  /// update moved into this camera. Returns true when the view taught the colour.
  bool observe(const SingleViewPose& sv, bool accepted, int fused_views, const SE3& T_cam_obj_fused,
               const ColorImage& image, const DepthImage& depth, const MaskImage& mask,
               const PinholeIntrinsics& K);
  /// The base model with the learned colour; nullptr before the colour is seeded.
  const ObjectModel* model() const { return model_.get(); }
  int views_learned() const { return views_learned_; }
  int resets() const { return resets_; }

 private:
  const ObjectModel& base_;
  ColourLearningParams params_;
  std::unique_ptr<ModelColourAccumulator> acc_;
  std::unique_ptr<ObjectModel> model_;
  int views_learned_ = 0, contradictions_ = 0, resets_ = 0;
};

/// Text file of a colour model: "# orpe model colour v2" then "source <text>" then one line per
/// sample "x y z nx ny nz grey weight r g" (r, g: its chromaticity). Version 1 files (written
/// before session 22: 8 numbers per line, no chromaticity) are read too, and written for a colour
/// without chromaticity. Numbers are written with the fewest digits that read back to the same
/// float (7 significant digits before session 25), and a normal of unit length is read as written,
/// so a model written and read back is bit for bit the same (the model cache relies on it:
/// pipeline/model_cache.h). Throws IoError naming the file (and line) on failure.
void write_model_colour(const std::string& path, const ModelColour& colour);
std::shared_ptr<ModelColour> read_model_colour(const std::string& path);
/// The same text on a stream (a part of a larger file); `name` names it in errors. The writer does
/// not check the colour (write_model_colour(path, ...) refuses an invalid one).
void write_model_colour(std::ostream& os, const ModelColour& colour);
std::shared_ptr<ModelColour> read_model_colour(std::istream& is, const std::string& name);

}  // namespace orpe
