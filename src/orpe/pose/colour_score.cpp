#include "orpe/pose/colour_score.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <limits>
#include <sstream>

#include "orpe/core/atomic_file.h"
#include "orpe/core/error.h"
#include "orpe/core/parse_number.h"
#include "orpe/core/weighted_correlation.h"
#include "orpe/pose/model_search.h"
#include "orpe/pose/object_model.h"
#include "orpe/pose/single_view.h"
#include "orpe/render/mesh.h"
#include "orpe/render/mesh_io.h"

namespace orpe {

size_t ModelColour::num_known() const {
  return static_cast<size_t>(
      std::count_if(weight.begin(), weight.end(), [](float w) { return w > 0; }));
}

bool ModelColour::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  const size_t n = points.size();
  if (normals.size() != n || grey.size() != n || weight.size() != n)
    return fail("points, normals, grey and weight sizes differ");
  for (size_t i = 0; i < n; ++i) {
    if (!points[i].allFinite() || !normals[i].allFinite()) return fail("non-finite sample");
    if (!(grey[i] >= 0 && grey[i] <= 1)) return fail("grey level outside [0, 1]");
    if (!(weight[i] >= 0) || !std::isfinite(weight[i]))
      return fail("negative or non-finite weight");
  }
  if (!chroma.empty() && chroma.size() != n) return fail("chroma and points sizes differ");
  for (const Eigen::Vector2f& c : chroma)
    if (!(c.x() >= 0 && c.y() >= 0 && c.x() + c.y() <= 1.0001f))
      return fail("chromaticity outside the triangle r, g >= 0, r + g <= 1");
  return true;
}

bool ColourScoreParams::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (!(weight >= 0 && weight <= 10)) return fail("colour_weight must be in [0, 10]");
  if (!(geometry_margin >= 0 && geometry_margin <= 2))
    return fail("colour_geometry_margin must be in [0, 2]");
  if (min_pixels < 3) return fail("colour_min_pixels must be >= 3");
  if (!(depth_tolerance_m > 0 && depth_tolerance_m <= 0.5))
    return fail("colour_depth_tolerance_m must be in (0, 0.5]");
  if (!(min_learned_fraction >= 0 && min_learned_fraction <= 1))
    return fail("colour_min_learned_fraction must be in [0, 1]");
  if (evidence != "lambert" && evidence != "local_contrast" && evidence != "ncc")
    return fail("colour_evidence must be lambert, local_contrast or ncc, not '" + evidence + "'");
  if (!(local_contrast_radius > 0 && local_contrast_radius <= 1))
    return fail("colour_local_contrast_radius must be in (0, 1]");
  if (!(chroma_weight >= 0 && chroma_weight <= 1))
    return fail("colour_chroma_weight must be in [0, 1]");
  if (!(chroma_min_spread >= 0 && chroma_min_spread <= 0.5))
    return fail("colour_chroma_min_spread must be in [0, 0.5]");
  if (!(chroma_min_grey >= 0 && chroma_min_grey < 1))
    return fail("colour_chroma_min_grey must be in [0, 1)");
  return true;
}

namespace {

/// Mean colour (r, g, b in [0, 255]) of the 3x3 box around (u, v) (clipped at the border).
Eigen::Vector3f box_rgb(const ColorImage& image, int u, int v) {
  Eigen::Vector3f sum = Eigen::Vector3f::Zero();
  int n = 0;
  for (int dv = -1; dv <= 1; ++dv)
    for (int du = -1; du <= 1; ++du) {
      const int uu = u + du, vv = v + dv;
      if (!image.in_bounds(uu, vv)) continue;
      const Rgb8 c = image.at(uu, vv);
      sum += Eigen::Vector3f(c.r, c.g, c.b);
      ++n;
    }
  return n ? Eigen::Vector3f(sum / static_cast<float>(n)) : Eigen::Vector3f::Zero();
}

/// (r, g) / (r + g + b); black: the neutral (1/3, 1/3).
Eigen::Vector2f chroma_of_rgb(const Eigen::Vector3f& c) {
  const float s = c.sum();
  return s > 1e-3f ? Eigen::Vector2f(c.x() / s, c.y() / s) : Eigen::Vector2f(1.0f / 3, 1.0f / 3);
}

/// Calls f(i, u, v) for every sample facing the camera, projecting inside `mask` (when not empty)
/// onto a pixel whose observed depth is within `tol` of the sample's depth.
template <class F>
void for_each_visible(const std::vector<Eigen::Vector3f>& points,
                      const std::vector<Eigen::Vector3f>& normals, const SE3& T_cam_obj,
                      const DepthImage& depth, const MaskImage& mask, const PinholeIntrinsics& K,
                      double tol, F&& f) {
  const Eigen::Matrix3f R = T_cam_obj.rotation().cast<float>();
  const Eigen::Vector3f t = T_cam_obj.translation().cast<float>();
  const bool use_mask = !mask.empty();
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f pc = R * points[i] + t;
    if (pc.z() <= 0.01f) continue;
    if ((R * normals[i]).dot(pc) > -0.1f * pc.norm()) continue;  // back-facing or grazing
    const int u = static_cast<int>(std::lround(K.fx * pc.x() / pc.z() + K.cx));
    const int v = static_cast<int>(std::lround(K.fy * pc.y() / pc.z() + K.cy));
    if (!depth.in_bounds(u, v)) continue;
    if (use_mask && !mask.at(u, v)) continue;
    const float z = depth.at(u, v);
    if (!(z > 0) || std::abs(z - pc.z()) > static_cast<float>(tol)) continue;
    f(i, u, v);
  }
}

/// Centre of the points' extent along each principal axis, and the axes (columns).
void principal_frame(const std::vector<Eigen::Vector3f>& pts, Vec3& centre, Mat3& axes) {
  Vec3 mean = Vec3::Zero();
  for (const auto& p : pts) mean += p.cast<double>();
  mean /= static_cast<double>(std::max<size_t>(pts.size(), 1));
  Mat3 C = Mat3::Zero();
  for (const auto& p : pts) {
    const Vec3 d = p.cast<double>() - mean;
    C += d * d.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Mat3> eig(C);
  axes = eig.eigenvectors();
  Vec3 lo = Vec3::Constant(1e9), hi = Vec3::Constant(-1e9);
  for (const auto& p : pts) {
    const Vec3 q = axes.transpose() * (p.cast<double>() - mean);
    lo = lo.cwiseMin(q);
    hi = hi.cwiseMax(q);
  }
  centre = mean + axes * (0.5 * (lo + hi));
}

}  // namespace

std::shared_ptr<ModelColour> model_colour_from_mesh(const TriangleMesh& mesh, int samples,
                                                    unsigned seed) {
  if ((!mesh.has_texture() && !mesh.has_colors()) || mesh.triangles.empty() || samples <= 0)
    return nullptr;
  TriangleMesh m = mesh;
  if (m.normals.size() != m.vertices.size()) m.compute_vertex_normals();
  std::vector<Rgb8> colours;
  const std::vector<Eigen::Vector3d> pts =
      sample_surface_points(m, static_cast<size_t>(samples), seed, &colours);
  auto out = std::make_shared<ModelColour>();
  out->source = mesh.has_texture() ? "texture" : "vertex colours";
  // Normals: of the nearest vertex (the samples lie on its triangles).
  std::vector<Eigen::Vector3f> verts = m.vertices;
  const ModelSearchIndex index(verts);
  for (size_t i = 0; i < pts.size(); ++i) {
    const Eigen::Vector3f p = pts[i].cast<float>();
    float d2 = 0;
    const std::uint32_t j = index.nearest(p, &d2);
    out->points.push_back(p);
    out->normals.push_back(m.normals[j].normalized());
    out->grey.push_back(grey_of(colours[i]));
    out->chroma.push_back(chroma_of_rgb(Eigen::Vector3f(colours[i].r, colours[i].g, colours[i].b)));
    out->weight.push_back(1.0f);
  }
  // One grey level everywhere (a YCB mesh whose OBJ gives every vertex the same colour, its texture
  // image not shipped): no evidence about the pose, and it would keep the colour learned from the
  // map from being used.
  const auto [lo, hi] = std::minmax_element(out->grey.begin(), out->grey.end());
  if (lo == out->grey.end()) return nullptr;
  if (*hi - *lo >= kUniformGreyRange) return out;
  // One grey level: still evidence when the hue varies (two colours of one brightness).
  Eigen::Vector2f c_lo = out->chroma.front(), c_hi = c_lo;
  for (const Eigen::Vector2f& c : out->chroma) c_lo = c_lo.cwiseMin(c), c_hi = c_hi.cwiseMax(c);
  if ((c_hi - c_lo).maxCoeff() < kUniformGreyRange) return nullptr;
  return out;
}

std::vector<VisibleColourSample> visible_colour_samples(
    const ModelColour& colour, const SE3& T_cam_obj, const ColorImage& image,
    const DepthImage& depth, const MaskImage& mask, const PinholeIntrinsics& K,
    double depth_tolerance_m) {
  std::vector<VisibleColourSample> out;
  if (image.empty() || image.width() != depth.width() || image.height() != depth.height())
    return out;
  const Eigen::Matrix3f R = T_cam_obj.rotation().cast<float>();
  for_each_visible(colour.points, colour.normals, T_cam_obj, depth, mask, K, depth_tolerance_m,
                   [&](size_t i, int u, int v) {
                     if (colour.weight[i] <= 0) return;
                     const Eigen::Vector3f rgb = box_rgb(image, u, v);
                     out.push_back({i, grey_of(rgb), chroma_of_rgb(rgb),
                                    R * colour.normals[i], u, v});
                   });
  return out;
}

namespace {

// The evidences over the visible samples `vis` (visible_colour_samples at the pose): the pose
// stage's blend computes them once for the grey and the chroma evidence.

ColourAgreement ncc_of(const std::vector<VisibleColourSample>& vis, const ModelColour& colour,
                       const ColourScoreParams& params) {
  ColourAgreement out;
  WeightedCorrelation<double> corr;
  for (const VisibleColourSample& s : vis) {
    corr.add(colour.grey[s.index], s.image_grey, colour.weight[s.index]);
    ++out.pixels;
  }
  if (out.pixels < params.min_pixels) return out;
  out.valid = corr.correlation(&out.ncc);  // a flat-coloured model or image says nothing
  return out;
}

/// Weighted least squares of y on the columns of the rows x_i: the residual sum of squares, from
/// the normal equations (a small ridge keeps a rank-deficient design, e.g. one box face in view or
/// an albedo of one colour, defined: it then fits as well as the smaller design).
template <int N>
class WeightedLeastSquares {
 public:
  using Row = Eigen::Matrix<double, N, 1>;
  void add(const Row& x, double y, double w) {
    M_ += w * x * x.transpose();
    b_ += w * y * x;
    syy_ += w * y * y;
  }
  double rss() const {
    Eigen::Matrix<double, N, N> M = M_;
    M.diagonal().array() += 1e-9 * std::max(1.0, M.trace());
    const Row coef = Eigen::LDLT<Eigen::Matrix<double, N, N>>(M).solve(b_);
    return std::max(0.0, syy_ - 2 * coef.dot(b_) + coef.dot(M_ * coef));
  }

 private:
  Eigen::Matrix<double, N, N> M_ = Eigen::Matrix<double, N, N>::Zero();
  Row b_ = Row::Zero();
  double syy_ = 0;
};

/// Whether the 3x3 box around (u, v) lies on one surface: every neighbour inside the image and the
/// mask (when not empty), its depth within `tol` of the centre's.
bool box_on_surface(const DepthImage& depth, const MaskImage& mask, int u, int v, double tol) {
  const float z = depth.at(u, v);
  for (int dv = -1; dv <= 1; ++dv)
    for (int du = -1; du <= 1; ++du) {
      const int uu = u + du, vv = v + dv;
      if (!depth.in_bounds(uu, vv) || (!mask.empty() && !mask.at(uu, vv))) return false;
      if (!(std::abs(depth.at(uu, vv) - z) <= static_cast<float>(tol))) return false;
    }
  return true;
}

/// Integral image of (weight, weight * model grey, weight * image grey) over a pixel rectangle:
/// the sums over any square in O(1).
class SampleBoxSums {
 public:
  SampleBoxSums(const std::vector<VisibleColourSample>& vis, const ModelColour& colour) {
    u0_ = v0_ = std::numeric_limits<int>::max();
    int u1 = std::numeric_limits<int>::min(), v1 = u1;
    for (const auto& s : vis) {
      u0_ = std::min(u0_, s.u), v0_ = std::min(v0_, s.v);
      u1 = std::max(u1, s.u), v1 = std::max(v1, s.v);
    }
    w_ = u1 - u0_ + 2, h_ = v1 - v0_ + 2;  // one row and column of zeros in front
    sums_.assign(static_cast<size_t>(w_) * static_cast<size_t>(h_), Eigen::Vector3d::Zero());
    for (const auto& s : vis) {
      const double w = colour.weight[s.index];
      at(s.u - u0_ + 1, s.v - v0_ + 1) +=
          Eigen::Vector3d(w, w * colour.grey[s.index], w * static_cast<double>(s.image_grey));
    }
    for (int y = 1; y < h_; ++y)
      for (int x = 1; x < w_; ++x) at(x, y) += at(x - 1, y) + at(x, y - 1) - at(x - 1, y - 1);
  }
  /// Sums over the pixels (u, v) with |u - cu| <= r and |v - cv| <= r.
  Eigen::Vector3d box(int cu, int cv, int r) const {
    const int xa = std::clamp(cu - r - u0_, 0, w_ - 1),
              xb = std::clamp(cu + r - u0_ + 1, 0, w_ - 1);
    const int ya = std::clamp(cv - r - v0_, 0, h_ - 1),
              yb = std::clamp(cv + r - v0_ + 1, 0, h_ - 1);
    return at(xb, yb) - at(xa, yb) - at(xb, ya) + at(xa, ya);
  }

 private:
  Eigen::Vector3d& at(int x, int y) { return sums_[static_cast<size_t>(y * w_ + x)]; }
  const Eigen::Vector3d& at(int x, int y) const { return sums_[static_cast<size_t>(y * w_ + x)]; }
  int u0_ = 0, v0_ = 0, w_ = 0, h_ = 0;
  std::vector<Eigen::Vector3d> sums_;
};

/// Per visible sample, whether its 3x3 pixel box lies on the surface (box_on_surface): the
/// Lambert fit and the chroma evidence take only those.
std::vector<char> boxes_on_surface(const std::vector<VisibleColourSample>& vis,
                                   const DepthImage& depth, const MaskImage& mask, double tol) {
  std::vector<char> out(vis.size());
  for (size_t k = 0; k < vis.size(); ++k)
    out[k] = box_on_surface(depth, mask, vis[k].u, vis[k].v, tol);
  return out;
}

ColourAgreement lambert_of(const std::vector<VisibleColourSample>& vis,
                           const std::vector<char>& on_surface, const ModelColour& colour,
                           const ColourScoreParams& params) {
  ColourAgreement out;
  WeightedLeastSquares<4> shading;
  WeightedLeastSquares<5> albedo;
  double sw = 0;
  if (vis.empty()) return out;
  const SampleBoxSums sums(vis, colour);
  for (size_t k = 0; k < vis.size(); ++k) {
    const VisibleColourSample& s = vis[k];
    if (!on_surface[k]) continue;
    // The albedo over the sample's 3x3 pixel box, as the image's grey (its 3x3 mean): a print finer
    // than a pixel (small text) averages alike on both sides instead of aliasing on the model's.
    const Eigen::Vector3d px = sums.box(s.u, s.v, 1);
    const double w = colour.weight[s.index], y = s.image_grey, a = px(1) / px(0);
    const Eigen::Vector3d n = s.normal.cast<double>();
    shading.add(Eigen::Vector4d(1, n.x(), n.y(), n.z()), y, w);
    albedo.add((Eigen::Matrix<double, 5, 1>() << 1, a, a * n.x(), a * n.y(), a * n.z()).finished(),
               y, w);
    sw += w;
    ++out.pixels;
  }
  if (out.pixels < params.min_pixels || !(sw > 0)) return out;
  const double rss_shading = shading.rss();
  if (rss_shading / sw < 1e-6) return out;  // the shading alone explains the image
  out.ncc = std::clamp(1.0 - albedo.rss() / rss_shading, -1.0, 1.0);
  out.valid = true;
  return out;
}

ColourAgreement local_contrast_of(const std::vector<VisibleColourSample>& vis,
                                  const ModelColour& colour, const DepthImage& depth,
                                  const PinholeIntrinsics& K, const ColourScoreParams& params) {
  ColourAgreement out;
  out.pixels = static_cast<int>(vis.size());
  if (out.pixels < params.min_pixels) return out;
  std::vector<float> z;
  z.reserve(vis.size());
  for (const auto& s : vis) z.push_back(depth.at(s.u, s.v));
  std::nth_element(z.begin(), z.begin() + static_cast<long>(z.size() / 2), z.end());
  const double z_median = z[z.size() / 2];
  Eigen::Vector3f lo = colour.points.front(), hi = lo;
  for (const auto& p : colour.points) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  const double radius_m = params.local_contrast_radius * static_cast<double>((hi - lo).norm());
  const int r =
      std::max(1, static_cast<int>(std::lround(K.fx * radius_m / std::max(z_median, 0.01))));
  const SampleBoxSums sums(vis, colour);
  WeightedCorrelation<double> corr;
  for (const auto& s : vis) {
    // b(0), px(0) > 0: the sample itself is inside. The model's grey over the 3x3 pixel box, as
    // the image's (its 3x3 mean): a print finer than a pixel averages alike on both sides.
    const Eigen::Vector3d b = sums.box(s.u, s.v, r), px = sums.box(s.u, s.v, 1);
    corr.add(px(1) / px(0) - b(1) / b(0), s.image_grey - b(2) / b(0), colour.weight[s.index]);
  }
  out.valid = corr.correlation(&out.ncc);
  return out;
}

ColourAgreement chroma_of(const std::vector<VisibleColourSample>& vis,
                          const std::vector<char>& on_surface, const ModelColour& colour,
                          const ColourScoreParams& params) {
  ColourAgreement out;
  if (!colour.has_chroma()) return out;
  WeightedCorrelation<Eigen::Vector2d> corr;
  for (size_t k = 0; k < vis.size(); ++k) {
    const VisibleColourSample& s = vis[k];
    if (s.image_grey < params.chroma_min_grey || !on_surface[k]) continue;
    corr.add(colour.chroma[s.index].cast<double>(), s.image_chroma.cast<double>(),
             colour.weight[s.index]);
    ++out.pixels;
  }
  if (out.pixels < params.min_pixels) return out;
  const double min_spread2 = params.chroma_min_spread * params.chroma_min_spread;
  out.valid = corr.correlation(&out.ncc, min_spread2, 1e-8);
  return out;
}

}  // namespace

ColourAgreement colour_agreement(const ModelColour& colour, const SE3& T_cam_obj,
                                 const ColorImage& image, const DepthImage& depth,
                                 const MaskImage& mask, const PinholeIntrinsics& K,
                                 const ColourScoreParams& params) {
  return ncc_of(
      visible_colour_samples(colour, T_cam_obj, image, depth, mask, K, params.depth_tolerance_m),
      colour, params);
}

ColourAgreement lambert_agreement(const ModelColour& colour, const SE3& T_cam_obj,
                                  const ColorImage& image, const DepthImage& depth,
                                  const MaskImage& mask, const PinholeIntrinsics& K,
                                  const ColourScoreParams& params) {
  const auto vis =
      visible_colour_samples(colour, T_cam_obj, image, depth, mask, K, params.depth_tolerance_m);
  return lambert_of(vis, boxes_on_surface(vis, depth, mask, params.depth_tolerance_m), colour,
                    params);
}

ColourAgreement local_contrast_agreement(const ModelColour& colour, const SE3& T_cam_obj,
                                         const ColorImage& image, const DepthImage& depth,
                                         const MaskImage& mask, const PinholeIntrinsics& K,
                                         const ColourScoreParams& params) {
  return local_contrast_of(
      visible_colour_samples(colour, T_cam_obj, image, depth, mask, K, params.depth_tolerance_m),
      colour, depth, K, params);
}

ColourAgreement chroma_agreement(const ModelColour& colour, const SE3& T_cam_obj,
                                 const ColorImage& image, const DepthImage& depth,
                                 const MaskImage& mask, const PinholeIntrinsics& K,
                                 const ColourScoreParams& params) {
  if (!colour.has_chroma()) return {};
  const auto vis =
      visible_colour_samples(colour, T_cam_obj, image, depth, mask, K, params.depth_tolerance_m);
  return chroma_of(vis, boxes_on_surface(vis, depth, mask, params.depth_tolerance_m), colour,
                   params);
}

ColourAgreement pose_colour_evidence(const ModelColour& colour, const SE3& T_cam_obj,
                                     const ColorImage& image, const DepthImage& depth,
                                     const MaskImage& mask, const PinholeIntrinsics& K,
                                     const ColourScoreParams& params) {
  const std::vector<VisibleColourSample> vis =
      visible_colour_samples(colour, T_cam_obj, image, depth, mask, K, params.depth_tolerance_m);
  const bool lambert = params.evidence == "lambert";
  const bool with_chroma = params.chroma_weight > 0 && colour.has_chroma();
  // Computed once for the Lambert fit and the chroma evidence.
  const std::vector<char> on_surface =
      lambert || with_chroma ? boxes_on_surface(vis, depth, mask, params.depth_tolerance_m)
                             : std::vector<char>();
  ColourAgreement grey;
  if (lambert)
    grey = lambert_of(vis, on_surface, colour, params);
  else if (params.evidence == "local_contrast")
    grey = local_contrast_of(vis, colour, depth, K, params);
  else
    grey = ncc_of(vis, colour, params);
  if (!with_chroma) return grey;
  const ColourAgreement chroma = chroma_of(vis, on_surface, colour, params);
  if (!chroma.valid) return grey;
  if (!grey.valid) return chroma;
  grey.ncc = (1 - params.chroma_weight) * grey.ncc + params.chroma_weight * chroma.ncc;
  return grey;
}

std::vector<SE3> confusable_poses(const ObjectModel& model, const SE3& T_cam_obj,
                                  bool quarter_turns) {
  std::vector<SE3> out;
  if (model.points.size() < 4) return out;
  Vec3 c;
  Mat3 axes;
  principal_frame(model.points, c, axes);
  auto about = [&](const Vec3& axis, const Vec3& point, double angle) {
    const Mat3 R = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
    return T_cam_obj * SE3(R, point - R * point);
  };
  for (int k = 0; k < 3; ++k) out.push_back(about(axes.col(k), c, M_PI));
  if (model.symmetry.continuous)
    for (int k = 1; k < 12; ++k)
      if (k != 6)
        out.push_back(about(model.symmetry.axis_obj, model.symmetry.axis_point_obj, k * M_PI / 6));
  if (quarter_turns && !model.symmetry.continuous)
    for (int k = 0; k < 3; ++k)
      for (const double angle : {M_PI / 2, -M_PI / 2}) out.push_back(about(axes.col(k), c, angle));
  return out;
}

bool has_usable_colour(const ObjectModel& model, const ColourScoreParams& params) {
  if (!params.enabled || !model.colour || model.colour->size() == 0) return false;
  return static_cast<double>(model.colour->num_known()) >=
         params.min_learned_fraction * static_cast<double>(model.colour->size());
}

ModelColourAccumulator::ModelColourAccumulator(const ObjectModel& model) {
  colour_.points = model.points;
  colour_.normals = model.normals;
  if (colour_.normals.size() != colour_.points.size())
    throw std::invalid_argument("ModelColourAccumulator: the model has no normals (prepare it)");
  sum_.assign(colour_.points.size(), 0.0);
  chroma_sum_.assign(colour_.points.size(), Eigen::Vector2d::Zero());
  count_.assign(colour_.points.size(), 0.0);
}

int ModelColourAccumulator::add_view(const SE3& T_cam_obj, const ColorImage& image,
                                     const DepthImage& depth, const MaskImage& mask,
                                     const PinholeIntrinsics& K, double depth_tolerance_m) {
  if (image.empty() || image.width() != depth.width() || image.height() != depth.height()) return 0;
  int n = 0;
  for_each_visible(colour_.points, colour_.normals, T_cam_obj, depth, mask, K, depth_tolerance_m,
                   [&](size_t i, int u, int v) {
                     const Eigen::Vector3f rgb = box_rgb(image, u, v);
                     sum_[i] += grey_of(rgb);
                     chroma_sum_[i] += chroma_of_rgb(rgb).cast<double>();
                     count_[i] += 1;
                     ++n;
                   });
  ++views_;
  return n;
}

void ModelColourAccumulator::merge(const ModelColourAccumulator& other) {
  if (other.sum_.size() != sum_.size())
    throw std::invalid_argument("ModelColourAccumulator::merge: different models");
  for (size_t i = 0; i < sum_.size(); ++i) {
    sum_[i] += other.sum_[i], count_[i] += other.count_[i];
    chroma_sum_[i] += other.chroma_sum_[i];
  }
  views_ += other.views_;
}

std::shared_ptr<ModelColour> ModelColourAccumulator::result(const std::string& source) const {
  auto out = std::make_shared<ModelColour>(colour_);
  out->source = source;
  out->grey.assign(colour_.points.size(), 0.0f);
  out->weight.assign(colour_.points.size(), 0.0f);
  out->chroma.assign(colour_.points.size(), Eigen::Vector2f(1.0f / 3, 1.0f / 3));
  for (size_t i = 0; i < colour_.points.size(); ++i)
    if (count_[i] > 0) {
      out->grey[i] = static_cast<float>(sum_[i] / count_[i]);
      out->chroma[i] = (chroma_sum_[i] / count_[i]).cast<float>();
      out->weight[i] = 1.0f;
    }
  return out;
}

bool ColourLearningParams::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (min_fused_views < 1) return fail("colour_learn_min_fused_views must be >= 1");
  if (!(min_geometry_margin >= 0)) return fail("colour_learn_min_geometry_margin must be >= 0");
  if (!(min_colour_margin >= 0)) return fail("colour_learn_min_colour_margin must be >= 0");
  if (reset_after_contradictions < 1)
    return fail("colour_learn_reset_after_contradictions must be >= 1");
  if (!(depth_tolerance_m > 0 && depth_tolerance_m <= 0.5))
    return fail("colour_learn_depth_tolerance_m must be in (0, 0.5]");
  return true;
}

ColourLearner::ColourLearner(const ObjectModel& base, const ColourLearningParams& params)
    : base_(base), params_(params) {
  if (!base.has_normals()) throw std::invalid_argument("ColourLearner: the model has no normals");
}

bool ColourLearner::observe(const SingleViewPose& sv, bool accepted, int fused_views,
                            const SE3& T_cam_obj_fused, const ColorImage& image,
                            const DepthImage& depth, const MaskImage& mask,
                            const PinholeIntrinsics& K) {
  if (!params_.enabled || !sv.valid) return false;
  const bool decisive = sv.geometry_margin >= params_.min_geometry_margin;
  if (decisive && !accepted && acc_) {
    if (++contradictions_ >= params_.reset_after_contradictions) {
      acc_.reset();
      model_.reset();
      contradictions_ = 0;
      ++resets_;
    }
    return false;
  }
  if (!accepted || fused_views < params_.min_fused_views) return false;
  const bool confirmed_by_colour =
      acc_ && sv.colour_used && sv.colour_margin >= params_.min_colour_margin;
  if (!decisive && !confirmed_by_colour) return false;
  if (!acc_) acc_ = std::make_unique<ModelColourAccumulator>(base_);
  if (acc_->add_view(T_cam_obj_fused, image, depth, mask, K, params_.depth_tolerance_m) == 0)
    return false;
  if (!model_) model_ = std::make_unique<ObjectModel>(base_);
  model_->colour = acc_->result("learned from the map");
  ++views_learned_;
  return true;
}

void write_model_colour(std::ostream& os, const ModelColour& colour) {
  const bool chroma = colour.has_chroma();
  os << "# orpe model colour " << (chroma ? "v2" : "v1") << "\nsource " << colour.source << "\n";
  std::string line;
  for (size_t i = 0; i < colour.size(); ++i) {
    line.clear();
    const float values[] = {colour.points[i].x(),  colour.points[i].y(),  colour.points[i].z(),
                            colour.normals[i].x(), colour.normals[i].y(), colour.normals[i].z(),
                            colour.grey[i],        colour.weight[i]};
    for (float v : values) append_exact(line, v), line += ' ';
    if (chroma) {
      append_exact(line, colour.chroma[i].x());
      line += ' ';
      append_exact(line, colour.chroma[i].y());
    } else {
      line.pop_back();
    }
    line += '\n';
    os << line;
  }
}

void write_model_colour(const std::string& path, const ModelColour& colour) {
  std::string why;
  if (!colour.IsValid(&why))
    throw IoError(path, "refusing to write an invalid colour model: " + why);
  write_file_atomic(path, [&](std::ostream& os) { write_model_colour(os, colour); });
}

namespace {

/// One sample line of a colour model file (version 1: 8 numbers, 2: 10) into `out`.
void read_colour_sample(const std::string& line, int version, const std::string& name, int line_no,
                        ModelColour& out) {
  float v[10];
  v[8] = v[9] = 1.0f / 3;
  if (!parse_number_fields(line, v, version == 1 ? 8 : 10))
    throw IoError(name,
                  "line " + std::to_string(line_no) +
                      (version == 1 ? ": expected 8 numbers 'x y z nx ny nz grey weight'"
                                    : ": expected 10 numbers 'x y z nx ny nz grey weight r g'"));
  const Eigen::Vector3f p(v[0], v[1], v[2]);
  Eigen::Vector3f n(v[3], v[4], v[5]);
  const Eigen::Vector2f c(v[8], v[9]);
  const float g = v[6], w = v[7];
  if (!p.allFinite() || !n.allFinite() || !(n.norm() > 0.5f) || !(g >= 0 && g <= 1) || !(w >= 0) ||
      !std::isfinite(w) || !(c.x() >= 0 && c.y() >= 0 && c.sum() <= 1.0001f))
    throw IoError(name, "line " + std::to_string(line_no) +
                            ": non-finite value, zero normal, grey outside [0, 1], negative "
                            "weight or chromaticity outside r, g >= 0, r + g <= 1");
  // A normal of unit length to float precision is kept as written: a written model reads back
  // bit for bit (normalising again may move the last bit).
  if (std::abs(n.squaredNorm() - 1.0f) > 4 * std::numeric_limits<float>::epsilon()) n.normalize();
  out.points.push_back(p);
  out.normals.push_back(n);
  out.grey.push_back(g);
  out.weight.push_back(w);
  if (version == 2) out.chroma.push_back(c);
}

}  // namespace

std::shared_ptr<ModelColour> read_model_colour(std::istream& is, const std::string& name) {
  auto out = std::make_shared<ModelColour>();
  std::string line;
  int line_no = 0;
  int version = 0;
  while (std::getline(is, line)) {
    ++line_no;
    if (line_no == 1) {
      version = line == "# orpe model colour v1" ? 1 : line == "# orpe model colour v2" ? 2 : 0;
      if (version == 0)
        throw IoError(name,
                      "line 1: expected '# orpe model colour v1' or '# orpe model colour v2'");
      continue;
    }
    if (line.empty() || line[0] == '#') continue;
    if (line.rfind("source ", 0) == 0) {
      out->source = line.substr(7);
      continue;
    }
    read_colour_sample(line, version, name, line_no, *out);
  }
  if (version == 0)
    throw IoError(name,
                  "empty file (expected '# orpe model colour v1' or '# orpe model colour v2')");
  if (out->points.empty()) throw IoError(name, "no samples");
  return out;
}

std::shared_ptr<ModelColour> read_model_colour(const std::string& path) {
  std::ifstream is(path);
  if (!is) throw IoError(path, "cannot open the colour model");
  return read_model_colour(is, path);
}

}  // namespace orpe
