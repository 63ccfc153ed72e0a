#include "orpe/recognition/model_recognizer.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <functional>
#include <limits>
#include <numeric>
#include <optional>
#include <sstream>

#include "orpe/core/error.h"
#include "orpe/pose/colour_score.h"
#include "orpe/pose/model_search.h"
#include "orpe/recognition/normal_agreement.h"
#include "orpe/recognition/shading_corrected_colour.h"
#include "orpe/recognition/silhouette_overflow.h"

namespace orpe {

bool RecognitionParams::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (search_rotations < 1) return fail("search_rotations must be >= 1");
  if (search_coarse_points < 6) return fail("search_coarse_points must be >= 6");
  if (search_refine_top_k < 1) return fail("search_refine_top_k must be >= 1");
  if (search_max_points < 30) return fail("search_max_points must be >= 30");
  if (!(max_extent_factor > 0) || !(min_extent_factor >= 0) ||
      !(min_extent_factor < max_extent_factor))
    return fail("need 0 <= min_extent_factor < max_extent_factor");
  if (!(crop_radius_factor > 0) || !(crop_spacing_factor > 0))
    return fail("crop_radius_factor and crop_spacing_factor must be > 0");
  if (max_crops < 1) return fail("max_crops must be >= 1");
  if (!(resting_min_face_fraction >= 0 && resting_min_face_fraction <= 1) ||
      resting_face_min_cells < 3 || !(resting_face_max_tilt_deg > 0) ||
      !(resting_face_max_bottom_m > 0) || !(resting_height_tolerance_m > 0) ||
      !(resting_width_slack_m >= 0))
    return fail(
        "resting_min_face_fraction must be in [0, 1], resting_face_min_cells >= 3, the resting "
        "tilt, bottom and height tolerance > 0, resting_width_slack_m >= 0");
  if (!(inlier_distance_per_m2 >= 0)) return fail("inlier_distance_per_m2 must be >= 0");
  if (!(colour_min_print_contrast >= 0 && colour_min_print_contrast <= 1))
    return fail("colour_min_print_contrast must be in [0, 1]");
  if (!(sparse_model_spacing_fraction >= 0))
    return fail("sparse_model_spacing_fraction must be >= 0");
  if (!(explain_max_normal_angle_deg >= 0 && explain_max_normal_angle_deg < 90))
    return fail("explain_max_normal_angle_deg must be in [0, 90)");
  if (!(inlier_distance_m > 0) || !(free_space_margin_m > 0) || !(below_plane_margin_m > 0))
    return fail("inlier_distance_m, free_space_margin_m, below_plane_margin_m must be > 0");
  for (double f :
       {min_support, max_violation, min_new_fraction, min_inlier_fraction, min_region_coverage})
    if (!(f >= 0 && f <= 1))
      return fail("min_support, max_violation, min_new_fraction, min_inlier_fraction in [0, 1]");
  if (min_explained_points < 1) return fail("min_explained_points must be >= 1");
  if (!(max_boundary_leak >= 0 && max_boundary_leak <= 1) || !(boundary_continuation_m > 0))
    return fail("max_boundary_leak must be in [0, 1], boundary_continuation_m > 0");
  if (!(smooth_edge_max_angle_deg >= 0 && smooth_edge_max_angle_deg <= 90))
    return fail("smooth_edge_max_angle_deg must be in [0, 90]");
  if (!(crease_min_angle_deg > 0 && crease_min_angle_deg < 180))
    return fail("crease_min_angle_deg must be in (0, 180)");
  if (!(smooth_edge_max_step_m >= 0)) return fail("smooth_edge_max_step_m must be >= 0");
  if (!(max_silhouette_overflow >= -1) || silhouette_margin_cells < 0)
    return fail("max_silhouette_overflow must be >= -1 (-1 = off), silhouette_margin_cells >= 0");
  if (!(silhouette_support_max_tilt_deg >= 0 && silhouette_support_max_tilt_deg < 90) ||
      !(silhouette_support_height_m > 0))
    return fail(
        "silhouette_support_max_tilt_deg must be in [0, 90) (0 = off), "
        "silhouette_support_height_m > 0");
  if (!(max_seam_fraction >= 0 && max_seam_fraction <= 1) || min_seam_pairs < 1)
    return fail("max_seam_fraction must be in [0, 1], min_seam_pairs >= 1");
  if (!(smooth_edge_max_colour_step >= 0 && smooth_edge_max_colour_step <= 256))
    return fail("smooth_edge_max_colour_step must be in [0, 256]");
  if (normal_radius_cells < 1 || normal_radius_cells > 10)
    return fail("normal_radius_cells must be in [1, 10]");
  if (!(min_in_image_fraction >= 0 && min_in_image_fraction <= 1))
    return fail("min_in_image_fraction must be in [0, 1]");
  if (!(standing_max_tilt_deg > 0 && standing_max_tilt_deg < 90) || standing_window_cells < 0 ||
      standing_min_points < 1 || !(standing_height_tolerance_m > 0))
    return fail(
        "standing_max_tilt_deg must be in (0, 90), standing_window_cells >= 0, "
        "standing_min_points >= 1 and standing_height_tolerance_m > 0");
  if (!(resting_min_in_image_fraction >= 0 && resting_min_in_image_fraction <= 1))
    return fail("resting_min_in_image_fraction must be in [0, 1]");
  if (!(solo_leak_weight >= 0 && solo_leak_weight <= 1))
    return fail("solo_leak_weight must be in [0, 1]");
  if (!(resting_bonus >= 0) || !(resting_tolerance_m > 0))
    return fail("resting_bonus must be >= 0 and resting_tolerance_m > 0");
  if (!(track_bonus >= 1)) return fail("track_bonus must be >= 1");
  if (!(track_crop_distance_m >= 0)) return fail("track_crop_distance_m must be >= 0");
  if (track_max_misses < 1) return fail("track_max_misses must be >= 1");
  if (reject_memory_keyframes < 0) return fail("reject_memory_keyframes must be >= 0");
  if (reject_memory_min_points < 0) return fail("reject_memory_min_points must be >= 0");
  if (!(min_colour_ncc >= -1 && min_colour_ncc <= 1))
    return fail("min_colour_ncc must be in [-1, 1]");
  if (!(reject_radius_m >= 0)) return fail("reject_radius_m must be >= 0");
  if (!(detection_probability > 0.5 && detection_probability <= 1))
    return fail("detection_probability must be in (0.5, 1]");
  return true;
}

std::vector<int> resolve_model_classes(const std::string& spec,
                                       const std::map<int, std::string>& class_names,
                                       const std::vector<int>& classes_with_models) {
  auto has_model = [&](int id) {
    return std::find(classes_with_models.begin(), classes_with_models.end(), id) !=
           classes_with_models.end();
  };
  auto known = [&]() {
    std::string s;
    for (int id : classes_with_models) {
      if (!s.empty()) s += ", ";
      const auto it = class_names.find(id);
      s += it != class_names.end() ? fmt::format("{} ({})", it->second, id) : std::to_string(id);
    }
    return s.empty() ? std::string("none") : s;
  };
  if (classes_with_models.empty())
    throw ConfigError(
        "segmentation.backend=model: the dataset has no object models (nothing to recognise)");
  std::vector<int> out;
  if (spec.find_first_not_of(" ,") == std::string::npos) {
    out = classes_with_models;
  } else {
    std::stringstream ss(spec);
    std::string item;
    while (std::getline(ss, item, ',')) {
      const auto b = item.find_first_not_of(' '), e = item.find_last_not_of(' ');
      if (b == std::string::npos) continue;
      item = item.substr(b, e - b + 1);
      int id = 0;
      for (const auto& [cid, name] : class_names)
        if (name == item) id = cid;
      if (id == 0 && item.find_first_not_of("0123456789") == std::string::npos && item.size() < 9)
        id = std::stoi(item);
      if (id == 0 || !has_model(id))
        throw ConfigError("segmentation.model_classes: unknown class '" + item +
                          "' (classes with a model: " + known() + ")");
      out.push_back(id);
    }
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

namespace {

using Vec3f = Eigen::Vector3f;

ModelRegistrationParams search_params(const RecognitionParams& p) {
  ModelRegistrationParams r;
  r.num_rotations = p.search_rotations;
  r.coarse_points = p.search_coarse_points;
  r.refine_top_k = p.search_refine_top_k;
  r.max_points = p.search_max_points;
  r.min_points = 20;
  r.erode_px = 1;
  r.refine_iterations = 15;
  r.translation_search_occlusion = -1;  // crops cut regions: their borders are no occlusion cue
  r.min_inlier_fraction = p.min_inlier_fraction;
  // Exact nearest model points in the coarse stage too: the recogniser's figures (docs/RESULTS.md)
  // were measured so; with the pose stage's grid approximation the crate of
  // ModelRecognizer.AConcaveCreaseAtTheOutlineIsNoLeak is not found (not investigated further).
  r.coarse_grid_cells = 0;
  return r;
}

/// A refinement from a prior: one grid rotation (the prior is the other hypothesis).
ModelRegistrationParams refine_params(const RecognitionParams& p) {
  ModelRegistrationParams r = search_params(p);
  r.num_rotations = 1;
  r.refine_top_k = 1;
  r.translation_search_occlusion = -1;
  return r;
}

}  // namespace

// Named (not anonymous): ModelRecognizer::Pass holds these.
namespace recognition_detail {

struct Hypothesis {
  int model = 0;  // index into models_
  SE3 T_cam_obj;
  std::vector<int> explained;  // grid cells, sorted
  double support = 0, violation = 0;
  double fit = 0;       // sum over the explained points of 1 - (distance / inlier distance)^2
  double lowest_m = 0;  // lowest model point's height over the support plane (inf: no plane)
  bool from_track = false;
  bool resting = false;  // placed by the resting search
  int track = -1;
  double rank = 0;
  bool dropped = false;   // by a clutter rule, out of the later selections of the cascade
  double colour = 1;      // best colour NCC over the pose and its confusable turns (1: not tested)
  double solo_leak = -1;  // outline leak of the hypothesis alone (-1: not measured)
  double in_image = 1;    // of its camera-facing model points, the fraction inside the image
  int stands = -1;        // stands on the support or observed surface (-1: not measured)
};

}  // namespace recognition_detail

namespace {

using recognition_detail::Hypothesis;
using Vec3f = Eigen::Vector3f;

/// The inlier distance at depth z: a triangulating sensor's depth error grows with z^2.
float inlier_distance_at(const RecognitionParams& p, float z) {
  return static_cast<float>(std::max(p.inlier_distance_m, p.inlier_distance_per_m2 * z * z));
}

/// Squared distance of a point (object frame) to the model: to its nearest sample, or with
/// `surface` to the surface the samples stand for -- the nearest sample's tangent plane, unless
/// the point lies farther from it than the sampling explains (the pose stage's fit distance). A
/// model's samples are a fixed number (2620 by default) spread over its area, so a large model's
/// are centimetres apart: with the nearest-sample distance a third of a 0.40 m box's own surface
/// lies beyond a 1 cm inlier distance even at its exact pose.
float model_distance2(const ObjectModel& model, const Vec3f& q, bool surface,
                      std::uint32_t* nearest = nullptr) {
  float d2 = 0;
  const std::uint32_t j = model.search_index->nearest(q, &d2);
  if (nearest) *nearest = j;
  if (!surface || !model.has_normals()) return d2;
  const float plane = std::abs(model.normals[j].dot(q - model.points[j]));
  const float beyond = std::sqrt(d2) - static_cast<float>(model.mean_spacing_m);
  const float d = std::max(plane, beyond);
  return d * d;
}

/// Whether a model's distances are taken to its surface: surface_distance, or a model whose mean
/// sample spacing is at least sparse_model_spacing_fraction x the inlier distance (its own surface
/// is partly farther than the inlier distance from every sample).
bool surface_distance_for(const ObjectModel& model, const RecognitionParams& p) {
  return p.surface_distance ||
         (p.sparse_model_spacing_fraction > 0 &&
          model.mean_spacing_m >= p.sparse_model_spacing_fraction * p.inlier_distance_m);
}

/// What verify may use beyond the grid: the kept cells' normals (explain_max_normal_angle_deg >
/// 0); null = not used.
struct VerifyAids {
  const std::vector<Vec3f>* cell_normals = nullptr;
};

/// A hypothesis against the whole scene: explained kept cells, support and violations. With
/// cell normals, an explained cell adds to the fit only where its normal agrees with the model's.
void verify(const SceneGrid& g, const DepthImage& depth, const PinholeIntrinsics& K,
            const ObjectModel& model, const RecognitionParams& p, const VerifyAids& aids,
            Hypothesis& h) {
  const std::vector<Vec3f>* cell_normals = aids.cell_normals;
  const SE3 T_obj_cam = h.T_cam_obj.inverse();
  const Eigen::Matrix3f R_oc = T_obj_cam.rotation().cast<float>();
  const Vec3f t_oc = T_obj_cam.translation().cast<float>();
  const Vec3f centre = (h.T_cam_obj * Vec3::Zero()).cast<float>();
  const float reach = static_cast<float>(model.diameter_m + 2 * p.inlier_distance_m);
  const bool by_normal = cell_normals && model.has_normals();
  const float min_cos = static_cast<float>(std::cos(p.explain_max_normal_angle_deg * M_PI / 180.0));
  const bool surface = surface_distance_for(model, p);
  h.explained.clear();
  h.fit = 0;
  for (size_t c = 0; c < g.kept.size(); ++c) {
    if (!g.kept[c] || (g.points[c] - centre).squaredNorm() > reach * reach) continue;
    std::uint32_t j = 0;
    const float dist2 = model_distance2(model, R_oc * g.points[c] + t_oc, surface, &j);
    const float d_in = inlier_distance_at(p, g.points[c].z());
    if (dist2 < d_in * d_in) {
      h.explained.push_back(static_cast<int>(c));
      if (!by_normal || normal_agrees(R_oc * (*cell_normals)[c], model.normals[j], min_cos))
        h.fit += 1.0 - dist2 / (d_in * d_in);
    }
  }
  // Visible model points against the observed depth; every model point against the support.
  const Eigen::Matrix3f R = h.T_cam_obj.rotation().cast<float>();
  const Vec3f t = h.T_cam_obj.translation().cast<float>();
  const size_t n = model.points.size();
  const size_t step = std::max<size_t>(1, n / 400);
  int supported = 0, violated = 0, checked = 0, below = 0, facing = 0, inside = 0;
  h.lowest_m = std::numeric_limits<double>::infinity();
  const float margin = static_cast<float>(p.free_space_margin_m);
  for (size_t k = 0; k < n; k += step) {
    const Vec3f q = R * model.points[k] + t;
    ++checked;
    if (!g.planes.empty())
      h.lowest_m = std::min(h.lowest_m, static_cast<double>(g.planes.front().signed_distance(q)));
    if (!g.planes.empty() &&
        g.planes.front().signed_distance(q) < -static_cast<float>(p.below_plane_margin_m)) {
      ++below;
      continue;
    }
    if (q.z() <= 0.05f) continue;
    if (model.has_normals() && (R * model.normals[k]).dot(q) >= 0) continue;  // back-facing
    const int u = static_cast<int>(std::lround(K.fx * q.x() / q.z() + K.cx));
    const int v = static_cast<int>(std::lround(K.fy * q.y() / q.z() + K.cy));
    ++facing;
    if (!depth.in_bounds(u, v)) continue;
    ++inside;
    const float z = depth.at(u, v);
    if (!(z > 0)) continue;
    if (q.z() < z - margin)
      ++violated;
    else if (q.z() < z + margin)
      ++supported;
  }
  h.support =
      supported + violated > 0 ? static_cast<double>(supported) / (supported + violated) : 0;
  h.violation = checked > 0 ? static_cast<double>(violated + below) / checked : 1;
  h.in_image = facing > 0 ? static_cast<double>(inside) / facing : 0;
}

/// How the image's grey levels agree with a model's own colour (texture, vertex colours) at a
/// hypothesis: the best NCC over its pose and the poses geometry confuses with it (180-degree
/// turns, steps about a symmetry axis), on the model samples facing the camera whose observed
/// depth lies on them (colour_agreement, pose stage). A flat-painted object of the model's shape
/// correlates ~0 with any turn of a printed model. 1 when there is no evidence (no colour image,
/// a model without colour, too few visible samples).
double best_colour_ncc(const ObjectModel& model, const SE3& T_cam_obj, const RgbdFrame& frame,
                       const PinholeIntrinsics& K, bool shading_correction,
                       double min_print_contrast) {
  const ColourScoreParams cp;
  if (frame.color.empty() || !has_usable_colour(model, cp)) return 1;
  std::vector<SE3> poses = confusable_poses(model, T_cam_obj);
  poses.push_back(T_cam_obj);
  double best = -1;
  bool any = false;
  for (const SE3& T : poses) {
    double contrast = 0;
    ColourAgreement a;
    if (shading_correction)
      a = shading_corrected_agreement(*model.colour, T, frame.color, frame.depth, K, cp, &contrast);
    // A print of little contrast besides its shading: the corrected NCC is left with noise.
    if (!shading_correction || contrast < min_print_contrast)
      a = colour_agreement(*model.colour, T, frame.color, frame.depth, MaskImage(), K, cp);
    if (!a.valid) continue;
    any = true;
    best = std::max(best, a.ncc);
  }
  return any ? best : 1;
}

/// Largest distance between two of the cells' points (over an even subsample of at most 256).
float cells_diameter(const SceneGrid& g, const std::vector<int>& cells) {
  const size_t step = std::max<size_t>(1, cells.size() / 256);
  std::vector<Vec3f> pts;
  for (size_t i = 0; i < cells.size(); i += step) pts.push_back(g.points[cells[i]]);
  float best = 0;
  for (size_t i = 0; i < pts.size(); ++i)
    for (size_t j = i + 1; j < pts.size(); ++j)
      best = std::max(best, (pts[i] - pts[j]).squaredNorm());
  return std::sqrt(best);
}

/// Whether observed points (extents `obs`, largest first, and diameter `obs_diameter`) can be a
/// view of a model with extents `model`: with extent_test_by_diameter, the points fit in the
/// model's diameter (any view of the model does, whatever its axes); else their principal extents
/// fit the model's.
bool extents_compatible(const Vec3f& obs, float obs_diameter, const Vec3f& model,
                        const ObjectModel& m, const RecognitionParams& p) {
  const float slack = static_cast<float>(p.extent_slack_m);
  if (obs[0] < p.min_extent_factor * model[0]) return false;
  if (p.extent_test_by_diameter) return obs_diameter <= p.max_extent_factor * m.diameter_m + slack;
  return obs[0] <= p.max_extent_factor * model[0] + slack &&
         obs[1] <= p.max_extent_factor * model[1] + slack;
}

/// Fraction of the outward neighbours (two cells out) of a kept object's explained cells that
/// continue its surface (kept cells within boundary_continuation_m) without being explained by
/// any kept object, or across an edge shared with another kept object that shows no crease
/// (normals within smooth_edge_max_angle_deg): a smooth surface running across two hypotheses is
/// one surface tiled by them, not two objects.
/// Mean colour over the 3x3 pixels around a grid cell's pixel.
Eigen::Vector3f mean_colour(const ColorImage& im, int u, int v) {
  Eigen::Vector3f sum = Eigen::Vector3f::Zero();
  int n = 0;
  for (int y = std::max(0, v - 1); y <= std::min(im.height() - 1, v + 1); ++y)
    for (int x = std::max(0, u - 1); x <= std::min(im.width() - 1, u + 1); ++x) {
      const Rgb8& c = im.at(x, y);
      sum += Eigen::Vector3f(c.r, c.g, c.b);
      ++n;
    }
  return n ? Eigen::Vector3f(sum / static_cast<float>(n)) : sum;
}

/// Whether the colour is the same on both sides (largest channel difference of the 3x3 means under
/// max_colour_step); true without a colour image (geometry alone decides).
bool same_colour(const SceneGrid& g, const ColorImage& im, int a, int b, double max_step) {
  if (im.empty() || im.width() <= g.pixel_u(a) || im.height() <= g.pixel_v(a)) return true;
  const Eigen::Vector3f d =
      mean_colour(im, g.pixel_u(a), g.pixel_v(a)) - mean_colour(im, g.pixel_u(b), g.pixel_v(b));
  return d.cwiseAbs().maxCoeff() < static_cast<float>(max_step);
}

struct OutlineTest {
  double leak = 0;     ///< fraction of the outline continuing (unexplained or seamless)
  int seam_with = -1;  ///< the neighbour whose shared edge is most seamless
  double seam = 0;     ///< its fraction of seamless pairs
};

/// Per grid cell, whether it lies outside object i's explained cells: not explained by i and,
/// with `fill_holes`, reachable from beyond their bounding box without crossing them (holes
/// enclosed by the object -- depth noise, dents the model does not have -- are inside: no outline).
std::vector<std::uint8_t> outside_of(const SceneGrid& g, const std::vector<int>& explained_by,
                                     int i, bool fill_holes) {
  std::vector<std::uint8_t> out(explained_by.size());
  for (size_t c = 0; c < out.size(); ++c) out[c] = explained_by[c] != i;
  if (!fill_holes) return out;
  int u0 = g.width, v0 = g.height, u1 = -1, v1 = -1;
  for (size_t c = 0; c < out.size(); ++c)
    if (!out[c]) {
      const int u = static_cast<int>(c) % g.width, v = static_cast<int>(c) / g.width;
      u0 = std::min(u0, u), u1 = std::max(u1, u), v0 = std::min(v0, v), v1 = std::max(v1, v);
    }
  if (u1 < 0) return out;
  u0 = std::max(0, u0 - 1), v0 = std::max(0, v0 - 1);
  u1 = std::min(g.width - 1, u1 + 1), v1 = std::min(g.height - 1, v1 + 1);
  std::vector<std::uint8_t> reached(out.size(), 0);
  std::vector<int> stack;
  for (int v = v0; v <= v1; ++v)
    for (int u = u0; u <= u1; ++u)
      if ((u == u0 || u == u1 || v == v0 || v == v1) && out[g.cell(u, v)]) {
        reached[g.cell(u, v)] = 1;
        stack.push_back(g.cell(u, v));
      }
  while (!stack.empty()) {
    const int c = stack.back();
    stack.pop_back();
    const int gu = c % g.width, gv = c / g.width;
    const int nb[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
    for (const auto& d : nb) {
      const int uu = gu + d[0], vv = gv + d[1];
      if (uu < u0 || vv < v0 || uu > u1 || vv > v1) continue;
      const int n = g.cell(uu, vv);
      if (reached[n] || !out[n]) continue;
      reached[n] = 1;
      stack.push_back(n);
    }
  }
  for (int v = v0; v <= v1; ++v)
    for (int u = u0; u <= u1; ++u)
      if (!reached[g.cell(u, v)]) out[g.cell(u, v)] = 0;
  return out;
}

OutlineTest boundary_leak(const SceneGrid& g, const ColorImage& colour,
                          const std::vector<int>& explained_by, int i, const RecognitionParams& p,
                          GridNormals& normals) {
  int tested = 0, leaks = 0;
  std::map<int, std::pair<int, int>> shared;  // neighbour -> (pairs, seamless pairs)
  const float reach = static_cast<float>(p.boundary_continuation_m);
  const float coplanar = static_cast<float>(p.smooth_edge_max_step_m);
  const float min_cos = static_cast<float>(std::cos(p.smooth_edge_max_angle_deg * M_PI / 180.0));
  const float crease_cos = static_cast<float>(std::cos(p.crease_min_angle_deg * M_PI / 180.0));
  const int steps[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
  const std::vector<std::uint8_t> outside = outside_of(g, explained_by, i, p.fill_outline_holes);
  for (size_t c = 0; c < explained_by.size(); ++c) {
    if (explained_by[c] != i) continue;
    const int gu = static_cast<int>(c) % g.width, gv = static_cast<int>(c) / g.width;
    for (const auto& s : steps) {
      const int u1 = gu + s[0], v1 = gv + s[1];
      if (u1 < 0 || v1 < 0 || u1 >= g.width || v1 >= g.height) continue;
      if (!outside[g.cell(u1, v1)]) continue;  // not on the outline in this direction
      const int u2 = gu + 2 * s[0], v2 = gv + 2 * s[1];
      if (u2 < 0 || v2 < 0 || u2 >= g.width || v2 >= g.height) continue;
      const int n = g.cell(u2, v2);
      ++tested;
      if (!g.kept[n] || !outside[n]) continue;
      if (explained_by[n] >= 0) ++shared[explained_by[n]].first;
      if ((g.points[n] - g.points[c]).norm() >= reach) continue;
      if (explained_by[n] < 0) {
        // Across a concave crease the surface does not continue: another object rests on or
        // leans against this one there.
        if (!(p.concave_crease_stops_leak && concave_link(g, normals, static_cast<int>(c), s[0],
                                                          s[1], p.normal_radius_cells, crease_cos)))
          ++leaks;
        continue;
      }
      const Vec3f& a = normals.at(static_cast<int>(c));
      const Vec3f& b = normals.at(n);
      if (!a.isZero() && !b.isZero() && std::abs(a.dot(b)) >= min_cos &&
          std::abs(a.dot(g.points[n] - g.points[c])) < coplanar &&
          same_colour(g, colour, static_cast<int>(c), n, p.smooth_edge_max_colour_step)) {
        ++leaks;
        ++shared[explained_by[n]].second;
      }
    }
  }
  OutlineTest out;
  out.leak = tested ? static_cast<double>(leaks) / tested : 0.0;
  for (const auto& [j, counts] : shared) {
    const double f = static_cast<double>(counts.second) / counts.first;
    if (counts.first >= p.min_seam_pairs && f > out.seam) out.seam = f, out.seam_with = j;
  }
  spdlog::debug("recognition: outline of {}: {} tested, leak {:.2f}, seam {:.2f} with {}", i,
                tested, out.leak, out.seam, out.seam_with);
  return out;
}

/// Full-image mask of a crop's grid cells (stride x stride blocks).
MaskImage crop_mask(const SceneGrid& g, const std::vector<int>& cells, int W, int H) {
  MaskImage mask(W, H, 0);
  for (int c : cells) {
    const int u0 = g.pixel_u(c), v0 = g.pixel_v(c);
    for (int dv = 0; dv < g.stride && v0 + dv < H; ++dv)
      for (int du = 0; du < g.stride && u0 + du < W; ++du) mask.at(u0 + du, v0 + dv) = 1;
  }
  return mask;
}

/// Crops of a region for a model: the whole region when its extents fit the model's, else balls
/// around seeds spread by farthest-point sampling; crops whose extents do not fit are dropped.
// Not inlined: inlined into search_regions, GCC 12 warns (-Wfree-nonheap-object, a false
// positive) on its vector's destructor.
[[gnu::noinline]] std::vector<std::vector<int>> region_crops(const SceneGrid& g,
                                                             const std::vector<int>& cells,
                                                             const ObjectModel& model,
                                                             const Vec3f& model_extents,
                                                             const RecognitionParams& p) {
  std::vector<std::vector<int>> crops;
  auto extents_of = [&](const std::vector<int>& cs) {
    std::vector<Vec3f> pts;
    pts.reserve(cs.size());
    for (int c : cs) pts.push_back(g.points[c]);
    return principal_extents(pts, p.min_area_extents);
  };
  const Vec3f whole = extents_of(cells);
  spdlog::trace("crops for {}: region extents {:.3f} {:.3f} {:.3f}, model {:.3f} {:.3f} {:.3f}",
                model.name, whole[0], whole[1], whole[2], model_extents[0], model_extents[1],
                model_extents[2]);
  const float whole_diameter = p.extent_test_by_diameter ? cells_diameter(g, cells) : 0.f;
  const bool fits_whole =
      p.extent_test_by_diameter
          ? whole_diameter <= p.max_extent_factor * model.diameter_m + p.extent_slack_m
          : whole[0] <= p.max_extent_factor * model_extents[0] + p.extent_slack_m;
  if (fits_whole) {
    if (extents_compatible(whole, whole_diameter, model_extents, model, p)) crops.push_back(cells);
    return crops;
  }
  const double d = model.diameter_m;
  const float spacing = static_cast<float>(p.crop_spacing_factor * d);
  const float radius = static_cast<float>(p.crop_radius_factor * d);
  std::vector<float> dist(cells.size(), std::numeric_limits<float>::infinity());
  size_t next = 0;
  for (int s = 0; s < p.max_crops; ++s) {
    const Vec3f seed = g.points[cells[next]];
    std::vector<int> crop;
    for (size_t i = 0; i < cells.size(); ++i) {
      const float di = (g.points[cells[i]] - seed).norm();
      dist[i] = std::min(dist[i], di);
      if (di < radius) crop.push_back(cells[i]);
    }
    if (static_cast<int>(crop.size()) >= p.min_explained_points &&
        extents_compatible(extents_of(crop),
                           p.extent_test_by_diameter ? cells_diameter(g, crop) : 0.f, model_extents,
                           model, p))
      crops.push_back(std::move(crop));
    next = static_cast<size_t>(std::max_element(dist.begin(), dist.end()) - dist.begin());
    if (dist[next] < spacing) break;
  }
  return crops;
}

}  // namespace

ModelRecognizer::ModelRecognizer(const SegmentationParams& segmentation,
                                 const RecognitionParams& params,
                                 const SceneGeometryParams& geometry,
                                 std::vector<ObjectModel> models)
    : segmentation_(segmentation),
      params_(params),
      geometry_(geometry),
      models_(std::move(models)),
      search_(search_params(params)),
      refine_(refine_params(params)) {
  std::string why;
  if (!params_.IsValid(&why)) throw ConfigError("recognition: " + why);
  if (!geometry_.IsValid(&why)) throw ConfigError("recognition_geometry: " + why);
  if (models_.empty()) throw ConfigError("segmentation.backend=model: no object model to look for");
  for (auto& m : models_) {
    if (!m.prepared() || !m.has_normals()) prepare_object_model(m);
    model_extents_.push_back(principal_extents(m.points, params_.min_area_extents));
    model_face_axes_.push_back(model_face_axes(m));
    spdlog::debug(
        "recognition: {} face axes {:.3f} x {:.3f} x {:.3f} m, {:.2f} of its normals; sample "
        "spacing {:.4f} m{}",
        m.name, model_face_axes_.back().extents[0], model_face_axes_.back().extents[1],
        model_face_axes_.back().extents[2], model_face_axes_.back().face_fraction, m.mean_spacing_m,
        surface_distance_for(m, params_) ? " (surface distance)" : "");
  }
}

std::vector<Detection> ModelRecognizer::detect(const RgbdFrame& frame) const {
  return run(frame, SE3(), nullptr);
}

std::vector<Detection> ModelRecognizer::detect_in_context(const RgbdFrame& frame,
                                                          const SegmentationContext& context) {
  return run(frame, context.T_world_cam, &state_);
}

namespace {

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

/// One call of the recogniser: the frame's geometry, the hypotheses and the selection.
struct ModelRecognizer::Pass {
  Pass(const ModelRecognizer& r, const RgbdFrame& f, const SE3& T_wc, State* s)
      : rec(r), p(r.params_), frame(f), T_world_cam(T_wc), T_cam_world(T_wc.inverse()), state(s) {
    K = frame.intrinsics;
    W = frame.depth.width(), H = frame.depth.height();
    K.width = W, K.height = H;
    g = make_scene_grid(frame.depth, K, rec.geometry_);
    remove_support_planes(g, rec.geometry_);
    regions = split_regions(g, rec.geometry_);
    if (p.explain_max_normal_angle_deg > 0)
      cell_normals = kept_cell_normals(g, p.normal_radius_cells);
  }

  bool register_crop(int mi, const std::vector<int>& cells, const SE3* prior, Hypothesis* out,
                     bool track = false) const;
  void refine_tracks();
  void keep_near_model(const ObjectModel& model, const SE3& T_cam_obj,
                       std::vector<int>& cells) const;
  void search_regions();
  void add_resting_tasks(const std::vector<int>& rest,
                         std::vector<std::pair<int, std::vector<int>>>& tasks,
                         std::vector<std::optional<SE3>>& priors);
  RecognizedObject score(int mi, const SE3& T_cam_obj);
  void measure_solo_leaks();
  void select();
  double min_in_image(const Hypothesis& h) const;
  bool stands(Hypothesis& h);
  void reject_clutter();
  int worst_silhouette_overflow();
  std::vector<Detection> detections();
  void update_tracks();
  void remember_searches();

  const ModelRecognizer& rec;
  const RecognitionParams& p;
  const RgbdFrame& frame;
  const SE3 T_world_cam, T_cam_world;
  State* state;
  PinholeIntrinsics K;
  int W = 0, H = 0;
  SceneGrid g;
  std::vector<SceneRegion> regions;
  std::vector<Hypothesis> hyps;
  std::vector<int> explained_by;       ///< per grid cell: the kept hypothesis explaining it, or -1
  std::vector<int> kept;               ///< indices into hyps
  std::optional<GridNormals> normals;  ///< of the grid, on demand (outline tests)
  std::vector<Vec3f> cell_normals;     ///< every kept cell's, with explain_max_normal_angle_deg
  struct Searched {
    Vec3 centroid_world;
  };
  std::vector<Searched> searched;
  int refinements = 0, searches = 0;
};

bool ModelRecognizer::Pass::register_crop(int mi, const std::vector<int>& cells, const SE3* prior,
                                          Hypothesis* out, bool track) const {
  if (static_cast<int>(cells.size()) < p.min_explained_points) return false;
  const MaskImage mask = crop_mask(g, cells, W, H);
  SingleViewInput in;
  in.mask = &mask;
  in.depth = &frame.depth;
  in.intrinsics = K;
  in.model = &rec.models_[static_cast<size_t>(mi)];
  in.class_id = in.model->class_id;
  if (prior) in.T_cam_obj_prior = *prior;
  const SingleViewPose pose = (prior ? rec.refine_ : rec.search_).estimate(in);
  if (!pose.valid) {
    spdlog::trace("recognition: {} on {} points at px {},{}: no pose ({})", in.model->name,
                  cells.size(), g.pixel_u(cells.front()), g.pixel_v(cells.front()), pose.reason);
    return false;
  }
  out->model = mi;
  out->T_cam_obj = pose.T_cam_obj;
  VerifyAids aids;
  if (!cell_normals.empty()) aids.cell_normals = &cell_normals;
  verify(g, frame.depth, K, *in.model, p, aids, *out);
  if (p.min_colour_ncc > -1 && out->support >= p.min_support && out->violation <= p.max_violation)
    // A known object passed the shading-corrected test when it was found: it is held to the
    // plain one (a print of little contrast besides its shading, the YCB-Video banana, passes
    // the corrected test in some views only).
    out->colour =
        best_colour_ncc(*in.model, out->T_cam_obj, frame, K,
                        p.colour_shading_correction && (!track || p.colour_min_print_contrast > 0),
                        p.colour_min_print_contrast);
  return true;
}

/// Of `cells`, those within track_crop_distance_m of the model at pose T_cam_obj.
void ModelRecognizer::Pass::keep_near_model(const ObjectModel& model, const SE3& T_cam_obj,
                                            std::vector<int>& cells) const {
  const SE3 T_obj_cam = T_cam_obj.inverse();
  const Eigen::Matrix3f R = T_obj_cam.rotation().cast<float>();
  const Vec3f t = T_obj_cam.translation().cast<float>();
  const float d = static_cast<float>(p.track_crop_distance_m);
  const bool surface = surface_distance_for(model, p);
  std::erase_if(
      cells, [&](int c) { return model_distance2(model, R * g.points[c] + t, surface) >= d * d; });
}

/// Known objects, refined from their last pose on the kept points around it.
void ModelRecognizer::Pass::refine_tracks() {
  if (!state) return;
  for (size_t ti = 0; ti < state->tracks.size(); ++ti) {
    const Track& t = state->tracks[ti];
    int mi = -1;
    for (size_t m = 0; m < rec.models_.size(); ++m)
      if (rec.models_[m].class_id == t.class_id) mi = static_cast<int>(m);
    if (mi < 0) continue;
    const SE3 prior = T_cam_world * t.T_world_obj;
    const Vec3f c = prior.translation().cast<float>();
    const float r = static_cast<float>(0.6 * rec.models_[mi].diameter_m);
    std::vector<int> cells;
    for (size_t k = 0; k < g.kept.size(); ++k)
      if (g.kept[k] && (g.points[k] - c).squaredNorm() < r * r)
        cells.push_back(static_cast<int>(k));
    if (p.track_crop_distance_m > 0) keep_near_model(rec.models_[mi], prior, cells);
    Hypothesis h;
    ++refinements;
    if (!register_crop(mi, cells, &prior, &h, true)) continue;
    h.from_track = true;
    h.track = static_cast<int>(ti);
    hyps.push_back(std::move(h));
  }
}

/// Every region's part the current selection leaves unexplained, searched with every model whose
/// size fits (in parallel); regions near one whose search recently added nothing are skipped.
void ModelRecognizer::Pass::search_regions() {
  for (const SceneRegion& region : regions) {
    std::vector<int> rest;
    for (int c : region.cells)
      if (explained_by[c] < 0) rest.push_back(c);
    if (!region_large_enough(g, rest, rec.geometry_)) continue;
    Vec3f centroid = Vec3f::Zero();
    for (int c : rest) centroid += g.points[c];
    centroid /= static_cast<float>(rest.size());
    const Vec3 centroid_world = T_world_cam * centroid.cast<double>();
    if (state && std::any_of(state->rejected.begin(), state->rejected.end(), [&](const auto& r) {
          return (r.centroid_world - centroid_world).norm() < p.reject_radius_m;
        }))
      continue;
    std::vector<std::pair<int, std::vector<int>>> tasks;
    for (size_t mi = 0; mi < rec.models_.size(); ++mi)
      for (auto& crop : region_crops(g, rest, rec.models_[mi], rec.model_extents_[mi], p))
        tasks.emplace_back(static_cast<int>(mi), std::move(crop));
    std::vector<std::optional<SE3>> priors(tasks.size());
    add_resting_tasks(rest, tasks, priors);
    std::vector<Hypothesis> found(tasks.size());
    std::vector<char> ok(tasks.size(), 0);
#pragma omp parallel for schedule(dynamic, 1)
    for (int k = 0; k < static_cast<int>(tasks.size()); ++k)
      ok[k] = register_crop(tasks[k].first, tasks[k].second, priors[k] ? &*priors[k] : nullptr,
                            &found[k]);
    searches += static_cast<int>(tasks.size());
    for (size_t k = 0; k < tasks.size(); ++k) {
      if (!ok[k]) continue;
      found[k].resting = priors[k].has_value();
      spdlog::trace(
          "recognition: {} on {} crop points at px {},{}: explains {} (fit {:.0f}), support "
          "{:.2f}, "
          "violation {:.2f}, lowest {:.3f}, colour {:.2f}, at {:.3f} {:.3f} {:.3f} (#{}{})",
          rec.models_[found[k].model].name, tasks[k].second.size(),
          g.pixel_u(tasks[k].second.front()), g.pixel_v(tasks[k].second.front()),
          found[k].explained.size(), found[k].fit, found[k].support, found[k].violation,
          found[k].lowest_m, found[k].colour, found[k].T_cam_obj.translation().x(),
          found[k].T_cam_obj.translation().y(), found[k].T_cam_obj.translation().z(), hyps.size(),
          found[k].resting ? ", resting" : "");
      hyps.push_back(std::move(found[k]));
    }
    if (static_cast<int>(rest.size()) >= p.reject_memory_min_points)
      searched.push_back({centroid_world});
    spdlog::debug("recognition: region of {} points ({} unexplained): {} searches",
                  region.cells.size(), rest.size(), tasks.size());
  }
}

/// Resting search of a region's unexplained cells: each box model placed on the support at each
/// vertical face they show (resting_search.h), to be refined from there on the cells inside the
/// placed box (+1.5 cm).
void ModelRecognizer::Pass::add_resting_tasks(const std::vector<int>& rest,
                                              std::vector<std::pair<int, std::vector<int>>>& tasks,
                                              std::vector<std::optional<SE3>>& priors) {
  if (!p.resting_search || g.planes.empty()) return;
  if (!normals) normals.emplace(g, p.normal_radius_cells);
  RestingFaceParams fp;
  fp.min_cells = p.resting_face_min_cells;
  fp.max_tilt_deg = p.resting_face_max_tilt_deg;
  fp.max_bottom_m = p.resting_face_max_bottom_m;
  fp.height_tolerance_m = p.resting_height_tolerance_m;
  fp.width_slack_m = p.resting_width_slack_m;
  const Plane& support = g.planes.front();
  // Each box model at each pose, refined from there on the cells inside the placed box (+1.5 cm).
  auto add = [&](size_t mi, const std::vector<SE3>& poses) {
    const ModelFaceAxes& ax = rec.model_face_axes_[mi];
    const Vec3f half = 0.5f * ax.extents + Vec3f::Constant(0.015f);
    for (const SE3& T : poses) {
      const SE3 T_obj_cam = T.inverse();
      const Eigen::Matrix3f R = ax.axes.transpose() * T_obj_cam.rotation().cast<float>();
      const Vec3f t = ax.axes.transpose() * (T_obj_cam.translation().cast<float>() - ax.centre);
      std::vector<int> cells;
      for (int c : rest)
        if (((R * g.points[c] + t).cwiseAbs() - half).maxCoeff() <= 0) cells.push_back(c);
      if (static_cast<int>(cells.size()) < p.min_explained_points) continue;
      tasks.emplace_back(static_cast<int>(mi), std::move(cells));
      priors.push_back(T);
    }
  };
  auto is_box = [&](size_t mi) {
    return rec.model_face_axes_[mi].face_fraction >= p.resting_min_face_fraction;
  };
  for (const VerticalFace& f : vertical_faces(g, *normals, rest, support, fp)) {
    spdlog::trace("recognition: vertical face of {} cells, {:.3f} wide, heights {:.3f}-{:.3f}",
                  f.cells, f.s_max - f.s_min, f.bottom, f.top);
    for (size_t mi = 0; mi < rec.models_.size(); ++mi)
      if (is_box(mi)) add(mi, resting_poses(rec.model_face_axes_[mi], f, support, fp));
  }
  if (!p.resting_top_faces) return;
  for (const TopFace& f : top_faces(g, *normals, rest, support, fp)) {
    if (!f.at_border) continue;
    spdlog::trace("recognition: top face of {} cells at {:.3f} m, hull of {}", f.cells, f.height,
                  f.hull.size());
    for (size_t mi = 0; mi < rec.models_.size(); ++mi)
      if (is_box(mi)) add(mi, resting_poses_on_top(rec.model_face_axes_[mi], f, support, fp));
  }
}

/// One given pose of model mi, verified and ranked alone.
RecognizedObject ModelRecognizer::Pass::score(int mi, const SE3& T_cam_obj) {
  Hypothesis h;
  h.model = mi;
  h.T_cam_obj = T_cam_obj;
  VerifyAids aids;
  if (!cell_normals.empty()) aids.cell_normals = &cell_normals;
  verify(g, frame.depth, K, rec.models_[static_cast<size_t>(mi)], p, aids, h);
  hyps = {h};
  select();
  const Hypothesis& s = hyps.front();
  RecognizedObject out{rec.models_[static_cast<size_t>(mi)].class_id,
                       s.T_cam_obj,
                       static_cast<int>(s.explained.size()),
                       s.support,
                       s.violation,
                       false};
  out.fit = s.fit;
  out.solo_leak = s.solo_leak;
  out.rank = s.rank;
  out.in_image = s.in_image;
  out.stands = stands(hyps.front());
  return out;
}

/// Each admissible hypothesis' outline leak as if it were alone (solo_leak_weight > 0), once.
void ModelRecognizer::Pass::measure_solo_leaks() {
  if (!(p.solo_leak_weight > 0)) return;
  if (!normals) normals.emplace(g, p.normal_radius_cells);
  std::vector<int> alone(g.kept.size(), -1);
  for (size_t i = 0; i < hyps.size(); ++i) {
    Hypothesis& h = hyps[i];
    if (h.solo_leak >= 0 || h.support < p.min_support || h.violation > p.max_violation) continue;
    for (int c : h.explained) alone[c] = static_cast<int>(i);
    h.solo_leak = boundary_leak(g, frame.color, alone, static_cast<int>(i), p, *normals).leak;
    for (int c : h.explained) alone[c] = -1;
  }
}

/// The fraction of its camera-facing model points a searched hypothesis needs inside the image.
double ModelRecognizer::Pass::min_in_image(const Hypothesis& h) const {
  const bool resting = std::abs(h.lowest_m) < p.resting_tolerance_m;
  return resting ? std::min(p.min_in_image_fraction, p.resting_min_in_image_fraction)
                 : p.min_in_image_fraction;
}

/// Whether a hypothesis rests on the support plane or stands on observed surface (a stacked
/// object on the top of what holds it); measured once. Always true with require_standing off.
bool ModelRecognizer::Pass::stands(Hypothesis& h) {
  // A foot within resting_tolerance_m of the support plane rests on it. (Not the looser
  // standing_height_tolerance_m: a model 1-4 cm over the table beside a crate explains a part of
  // the crate's side, and stands on nothing.)
  if (!p.require_standing || g.planes.empty() || !std::isfinite(h.lowest_m) ||
      h.lowest_m < p.resting_tolerance_m)
    return true;
  if (h.stands < 0) {
    if (!normals) normals.emplace(g, p.normal_radius_cells);
    h.stands = stands_on_observed_surface(g, *normals, K, rec.models_[static_cast<size_t>(h.model)],
                                          h.T_cam_obj, static_cast<float>(h.lowest_m),
                                          static_cast<float>(p.standing_height_tolerance_m),
                                          static_cast<float>(p.standing_max_tilt_deg),
                                          p.standing_window_cells, p.standing_min_points);
    if (!h.stands)
      spdlog::trace("recognition: {} with its foot {:.3f} m over the support stands on nothing",
                    rec.models_[static_cast<size_t>(h.model)].name, h.lowest_m);
  }
  return h.stands > 0;
}

/// Greedy selection, best first: a hypothesis is kept when it newly explains enough points.
void ModelRecognizer::Pass::select() {
  measure_solo_leaks();
  for (auto& h : hyps)
    h.rank = (p.rank_by_residual ? h.fit : static_cast<double>(h.explained.size())) * h.support *
             (h.from_track ? p.track_bonus : 1.0) *
             (std::abs(h.lowest_m) < p.resting_tolerance_m ? 1.0 + p.resting_bonus : 1.0) *
             (h.solo_leak > 0 ? std::max(0.0, 1.0 - p.solo_leak_weight * h.solo_leak) : 1.0);
  std::vector<int> order(hyps.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return hyps[a].rank > hyps[b].rank; });
  kept.clear();
  explained_by.assign(g.kept.size(), -1);
  for (int i : order) {
    const Hypothesis& h = hyps[static_cast<size_t>(i)];
    if (h.dropped || h.support < p.min_support || h.violation > p.max_violation ||
        h.colour < p.min_colour_ncc ||
        (!h.from_track && (h.in_image < min_in_image(h) || !stands(hyps[static_cast<size_t>(i)]))))
      continue;
    int fresh = 0;
    for (int c : h.explained) fresh += explained_by[c] < 0;
    if (fresh < p.min_explained_points ||
        fresh < p.min_new_fraction * static_cast<double>(h.explained.size())) {
      spdlog::trace("recognition: #{} {} (rank {:.0f}, solo leak {:.2f}): {} of {} points new", i,
                    rec.models_[h.model].name, h.rank, h.solo_leak, fresh, h.explained.size());
      continue;
    }
    for (int c : h.explained)
      if (explained_by[c] < 0) explained_by[c] = i;
    kept.push_back(i);
  }
}

/// Clutter: an object whose observed surface continues past its outline (into points no kept
/// object explains, or smoothly into a neighbour's) is a part of something larger; a region the
/// kept objects explain poorly holds no object. Both are dropped, then the selection runs again.
void ModelRecognizer::Pass::reject_clutter() {
  if (!normals) normals.emplace(g, p.normal_radius_cells);
  // Each round drops at least one hypothesis for good, so this ends; the last selection is
  // always checked (a clutter surface with many candidate models refills itself round after round).
  for (size_t round = 0; round <= hyps.size(); ++round) {
    // The worst leaking object only: its neighbours' outlines change once it is replaced (a wrong
    // hypothesis next to a right one makes the right one's outline leak too). Failing that, of
    // two objects whose shared edge is mostly seamless (one surface tiled by two hypotheses),
    // the lower-ranked one.
    int worst = -1, seam_drop = -1;
    double worst_leak = p.max_boundary_leak, worst_seam = p.max_seam_fraction;
    for (int i : kept) {
      if (hyps[static_cast<size_t>(i)].from_track) continue;  // passed when it was found
      const OutlineTest t = boundary_leak(g, frame.color, explained_by, i, p, *normals);
      if (t.leak > worst_leak) worst_leak = t.leak, worst = i;
      if (t.seam > worst_seam) {
        worst_seam = t.seam;
        seam_drop = hyps[static_cast<size_t>(t.seam_with)].rank < hyps[i].rank ? t.seam_with : i;
      }
    }
    const char* why = worst >= 0 ? "outline leak" : "seam";
    if (worst < 0) worst = seam_drop;
    if (worst < 0 && (worst = worst_silhouette_overflow()) >= 0) why = "silhouette overflow";
    if (worst >= 0) {
      spdlog::debug("recognition: drop {} ({} points, {}): {}",
                    rec.models_[hyps[static_cast<size_t>(worst)].model].name,
                    hyps[static_cast<size_t>(worst)].explained.size(), worst, why);
      hyps[static_cast<size_t>(worst)].dropped = true;  // out of the next selection
      select();
      continue;
    }
    std::vector<int> explained(regions.size(), 0);
    std::map<int, std::map<int, int>> owned;  // hypothesis -> region -> cells
    for (size_t c = 0; c < explained_by.size(); ++c)
      if (explained_by[c] >= 0 && g.region[c] >= 0) {
        ++explained[g.region[c]];
        ++owned[explained_by[c]][g.region[c]];
      }
    bool dropped = false;
    for (int i : kept) {
      int total = 0, in_poor = 0;
      for (const auto& [r, n] : owned[i]) {
        total += n;
        if (explained[r] < p.min_region_coverage * regions[r].cells.size()) in_poor += n;
      }
      // A known object (confirmed on an earlier keyframe) is not dropped for its region: an
      // unknown object touching it leaves the region poorly explained, not the object wrong.
      if (total > 0 && in_poor > total / 2 && !hyps[static_cast<size_t>(i)].from_track) {
        spdlog::debug("recognition: drop {} ({} points, {}): region coverage",
                      rec.models_[hyps[static_cast<size_t>(i)].model].name,
                      hyps[static_cast<size_t>(i)].explained.size(), i);
        hyps[static_cast<size_t>(i)].dropped = true;
        dropped = true;
      }
    }
    if (!dropped) break;
    select();
  }
}

/// The kept object (not a known one) whose observed surface continues farthest beyond its model's
/// silhouette, when that exceeds max_silhouette_overflow x its explained cells; -1 = none.
int ModelRecognizer::Pass::worst_silhouette_overflow() {
  if (p.max_silhouette_overflow < 0) return -1;
  int worst = -1;
  double worst_f = p.max_silhouette_overflow;
  for (int i : kept) {
    const Hypothesis& h = hyps[static_cast<size_t>(i)];
    if (h.from_track || h.explained.empty()) continue;
    const auto sil = model_silhouette(g, K, rec.models_[static_cast<size_t>(h.model)], h.T_cam_obj,
                                      p.silhouette_margin_cells);
    const int n = static_cast<int>(h.explained.size());
    const int limit = static_cast<int>(std::ceil(4 * p.max_silhouette_overflow * n)) + 1;
    std::function<bool(int)> support;
    if (p.silhouette_support_max_tilt_deg > 0 && !g.planes.empty() && std::isfinite(h.lowest_m)) {
      if (!normals) normals.emplace(g, p.normal_radius_cells);
      support = [&](int c) {
        return is_support_cell(g, *normals, g.planes.front(), c, static_cast<float>(h.lowest_m),
                               static_cast<float>(p.silhouette_support_height_m),
                               static_cast<float>(p.silhouette_support_max_tilt_deg));
      };
    }
    const double f =
        silhouette_overflow(g, explained_by, i, sil, static_cast<float>(p.boundary_continuation_m),
                            limit, support) /
        static_cast<double>(n);
    spdlog::debug("recognition: silhouette of {}: overflow {:.2f}", i, f);
    if (f > worst_f) worst_f = f, worst = i;
  }
  return worst;
}

/// Per kept object, the pixels within the inlier distance of its model (nearest model wins).
std::vector<Detection> ModelRecognizer::Pass::detections() {
  Image<float> best(W, H, std::numeric_limits<float>::infinity());
  Image<int> owner(W, H, -1);
  for (int i : kept) {
    const Hypothesis& h = hyps[static_cast<size_t>(i)];
    const ObjectModel& model = rec.models_[static_cast<size_t>(h.model)];
    BoxPx box;
    for (int c : h.explained) box.include(g.pixel_u(c), g.pixel_v(c));
    const int pad = g.stride + 2;
    const SE3 T_obj_cam = h.T_cam_obj.inverse();
    const Eigen::Matrix3f R = T_obj_cam.rotation().cast<float>();
    const Vec3f t = T_obj_cam.translation().cast<float>();
    const bool surface = surface_distance_for(model, p);
    for (int v = std::max(0, box.v_min - pad); v <= std::min(H - 1, box.v_max + pad); ++v)
      for (int u = std::max(0, box.u_min - pad); u <= std::min(W - 1, box.u_max + pad); ++u) {
        const float z = frame.depth.at(u, v);
        if (!(z > 0)) continue;
        const int c = g.cell(u / g.stride, v / g.stride);
        if (explained_by[c] >= 0 && explained_by[c] != i) continue;
        const Vec3f q = K.backproject(u, v, z).cast<float>();
        const float dist = std::sqrt(model_distance2(model, R * q + t, surface));
        if (dist < inlier_distance_at(p, z) && dist < best.at(u, v)) {
          best.at(u, v) = dist;
          owner.at(u, v) = i;
        }
      }
  }
  std::vector<Detection> out;
  rec.last_objects_.clear();
  const float prob = static_cast<float>(p.detection_probability);
  const SegmentationParams& sp = rec.segmentation_;
  for (int i : kept) {
    const Hypothesis& h = hyps[static_cast<size_t>(i)];
    Detection d;
    d.class_id = rec.models_[static_cast<size_t>(h.model)].class_id;
    d.score = static_cast<float>(std::clamp(0.5 + 0.5 * h.support - h.violation, 0.0, 1.0));
    d.probability = ProbabilityImage(W, H, 0.0f);
    for (int v = 0; v < H; ++v)
      for (int u = 0; u < W; ++u)
        if (owner.at(u, v) == i) {
          d.probability.at(u, v) = prob;
          d.box.include(u, v);
        }
    if (d.score < sp.min_score ||
        mask_area(d.probability, static_cast<float>(sp.mask_threshold)) < sp.min_mask_area_px)
      continue;
    out.push_back(std::move(d));
    rec.last_objects_.push_back({out.back().class_id, h.T_cam_obj,
                                 static_cast<int>(h.explained.size()), h.support, h.violation,
                                 h.from_track, h.fit, h.solo_leak, h.rank, h.in_image});
  }
  return out;
}

/// Kept objects update (or start) their tracks; known objects in view but not kept miss.
void ModelRecognizer::Pass::update_tracks() {
  if (!state) return;
  std::vector<int> confirmed(state->tracks.size(), 0);
  for (int i : kept) {
    const Hypothesis& h = hyps[static_cast<size_t>(i)];
    const ObjectModel& model = rec.models_[static_cast<size_t>(h.model)];
    const SE3 T_world_obj = T_world_cam * h.T_cam_obj;
    int ti = h.track;
    for (size_t k = 0; ti < 0 && k < state->tracks.size(); ++k)
      if (state->tracks[k].class_id == model.class_id &&
          (state->tracks[k].T_world_obj.translation() - T_world_obj.translation()).norm() <
              0.3 * model.diameter_m)
        ti = static_cast<int>(k);
    if (ti < 0) {
      state->tracks.push_back({model.class_id, T_world_obj, 0, 0});
      confirmed.push_back(0);
      ti = static_cast<int>(state->tracks.size()) - 1;
    }
    Track& t = state->tracks[static_cast<size_t>(ti)];
    t.T_world_obj = T_world_obj;
    ++t.hits;
    t.misses = 0;
    confirmed[static_cast<size_t>(ti)] = 1;
  }
  std::vector<Track> alive;
  for (size_t k = 0; k < state->tracks.size(); ++k) {
    Track t = state->tracks[k];
    if (!confirmed[k]) {
      const Vec3 c = T_cam_world * t.T_world_obj.translation();
      const Eigen::Vector2d px = c.z() > 0.05 ? K.project(c) : Eigen::Vector2d(-1, -1);
      if (px.x() >= 0 && px.y() >= 0 && px.x() < W && px.y() < H) ++t.misses;
    }
    if (t.misses < p.track_max_misses) alive.push_back(t);
  }
  state->tracks = std::move(alive);
}

/// Every searched region (of reject_memory_min_points unexplained points or more: a smaller one's
/// search is cheap and runs again) is not searched again for reject_memory_keyframes keyframes:
/// what its search found is a known object from now on (refined, not searched), what it did not
/// find (clutter, an unknown object) would be found again. Later keyframes then cost the
/// refinements of the known objects and the search of new surface only.
void ModelRecognizer::Pass::remember_searches() {
  if (!state) return;
  for (const Searched& s : searched) state->rejected.push_back({s.centroid_world, state->keyframe});
  std::erase_if(state->rejected, [&](const Rejected& r) {
    return state->keyframe - r.keyframe >= p.reject_memory_keyframes;
  });
}

RecognizedObject ModelRecognizer::score_pose(const RgbdFrame& frame, int class_id,
                                             const SE3& T_cam_obj) const {
  for (size_t mi = 0; mi < models_.size(); ++mi)
    if (models_[mi].class_id == class_id) {
      Pass pass(*this, frame, SE3(), nullptr);
      return pass.score(static_cast<int>(mi), T_cam_obj);
    }
  throw ConfigError(fmt::format("recognition: no model of class {}", class_id));
}

std::vector<Detection> ModelRecognizer::run(const RgbdFrame& frame, const SE3& T_world_cam,
                                            State* state) const {
  const auto t0 = std::chrono::steady_clock::now();
  const std::clock_t cpu0 = std::clock();
  RecognitionTiming& timing = last_timing_;
  timing = {};
  if (state) ++state->keyframe;
  Pass pass(*this, frame, T_world_cam, state);
  timing.geometry_ms = ms_since(t0);
  auto t = std::chrono::steady_clock::now();
  pass.refine_tracks();
  pass.select();
  timing.tracks_ms = ms_since(t);
  t = std::chrono::steady_clock::now();
  pass.search_regions();
  timing.search_ms = ms_since(t);
  t = std::chrono::steady_clock::now();
  pass.select();
  pass.reject_clutter();
  for (int i : pass.kept)
    spdlog::debug("recognition: kept #{} {} (rank {:.0f}, solo leak {:.2f})", i,
                  models_[pass.hyps[static_cast<size_t>(i)].model].name,
                  pass.hyps[static_cast<size_t>(i)].rank,
                  pass.hyps[static_cast<size_t>(i)].solo_leak);
  timing.verify_ms = ms_since(t);
  t = std::chrono::steady_clock::now();
  std::vector<Detection> out = pass.detections();
  pass.update_tracks();
  pass.remember_searches();
  timing.detections_ms = ms_since(t);
  timing.total_ms = ms_since(t0);
  timing.cpu_ms = 1000.0 * static_cast<double>(std::clock() - cpu0) / CLOCKS_PER_SEC;
  timing.refinements = pass.refinements;
  timing.searches = pass.searches;
  return out;
}

}  // namespace orpe
