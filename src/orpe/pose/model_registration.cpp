#include "orpe/pose/model_registration.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <numeric>

#include "orpe/core/error.h"
#include "orpe/pose/model_search.h"

namespace orpe {

bool ModelRegistrationParams::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (erode_px < 0 || erode_px > 20) return fail("erode_px must be in [0, 20]");
  if (min_points < 6) return fail("min_points must be >= 6");
  if (max_points < min_points) return fail("max_points must be >= min_points");
  if (outlier_radius_factor < 0) return fail("outlier_radius_factor must be >= 0");
  if (num_rotations < 1) return fail("num_rotations must be >= 1");
  if (coarse_points < 6) return fail("coarse_points must be >= 6");
  if (coarse_iterations < 0 || refine_iterations < 1)
    return fail("ICP iteration counts must be positive");
  if (coarse_max_corr_factor <= 0 || refine_max_corr_factor <= 0)
    return fail("association distance factors must be > 0");
  if (refine_top_k < 1) return fail("refine_top_k must be >= 1");
  if (coarse_grid_cells < 0 || coarse_grid_cells > 200)
    return fail("coarse_grid_cells must be in [0, 200]");
  if (translation_search_occlusion > 1) return fail("translation_search_occlusion must be <= 1");
  if (translation_search_step_factor <= 0 || translation_search_step_factor > 1)
    return fail("translation_search_step_factor must be in (0, 1]");
  if (final_max_corr_m <= 0) return fail("final_max_corr_m must be > 0");
  if (huber_delta_m <= 0) return fail("huber_delta_m must be > 0");
  if (point_to_point_weight < 0) return fail("point_to_point_weight must be >= 0");
  if (inlier_distance_m <= 0) return fail("inlier_distance_m must be > 0");
  if (free_space_margin_m <= 0) return fail("free_space_margin_m must be > 0");
  if (free_space_weight < 0 || free_space_icp_weight < 0 || support_weight < 0)
    return fail("score weights must be >= 0");
  if (free_space_window_px < 0 || free_space_window_px > 10)
    return fail("free_space_window_px must be in [0, 10]");
  if (free_space_model_points < 10) return fail("free_space_model_points must be >= 10");
  if (std::string cwhy; !colour.IsValid(&cwhy) || !colour_learning.IsValid(&cwhy))
    return fail(cwhy);
  if (min_inlier_fraction < 0 || min_inlier_fraction > 1)
    return fail("min_inlier_fraction must be in [0, 1]");
  if (prior_iterations < 1) return fail("prior_iterations must be >= 1");
  if (prior_points < min_points) return fail("prior_points must be >= min_points");
  if (prior_min_inlier_fraction < 0 || prior_min_inlier_fraction > 1 ||
      prior_max_free_space_violation < 0 || prior_max_free_space_violation > 1)
    return fail("prior_min_inlier_fraction and prior_max_free_space_violation must be in [0, 1]");
  if (prior_relative_fraction < 0 || prior_relative_fraction > 1)
    return fail("prior_relative_fraction must be in [0, 1]");
  return true;
}

SegmentedCloudParams ModelRegistrationParams::segmented_cloud() const {
  SegmentedCloudParams p;
  p.erode_px = erode_px;
  p.min_points = min_points;
  p.max_points = max_points;
  p.outlier_radius_factor = outlier_radius_factor;
  p.seed = static_cast<unsigned>(seed);
  return p;
}

std::vector<Mat3> uniform_rotations(int n) {
  std::vector<Mat3> out;
  if (n <= 0) return out;
  out.reserve(static_cast<size_t>(n));
  const double phi = std::sqrt(2.0);
  const double psi = 1.533751168755204288118041;
  for (int i = 0; i < n; ++i) {
    const double s = i + 0.5;
    const double r = std::sqrt(s / n);
    const double R = std::sqrt(1.0 - s / n);
    const double alpha = 2.0 * M_PI * s / phi;
    const double beta = 2.0 * M_PI * s / psi;
    const Eigen::Quaterniond q(R * std::cos(beta), r * std::sin(alpha), r * std::cos(alpha),
                               R * std::sin(beta));
    out.push_back(q.normalized().toRotationMatrix());
  }
  return out;
}

namespace {

using Vec3f = Eigen::Vector3f;
using Mat3f = Eigen::Matrix3f;

struct Hypothesis {
  SE3 T_cam_obj;
  double score = -1e9;
  double fit = 0;
  double inliers = 0;
  double violation = 0;
  double support = 0;
  double colour = 0;  ///< colour NCC (rank_by_colour)
};

/// What scoring needs of the frame: depth min-filtered over a window (a model point is a free-space
/// violation only if it is in front of every observed depth around its pixel: robust to mixed
/// pixels and the sensor's depth bleeding at object edges) and subsets of the model points.
struct ScoringContext {
  DepthImage
      depth_min;  ///< window minimum over [roi_u0, ..] x [roi_v0, ..] (a window of the image)
  int roi_u0 = 0, roi_v0 = 0;
  int window_px = 0;
  PinholeIntrinsics K;
  std::vector<Vec3f> model_subset;
  std::vector<Vec3f> normal_subset;
  std::vector<Vec3f> coarse_model_subset;  ///< smaller, for the coarse stage
  std::vector<Vec3f> coarse_normal_subset;
  const DepthImage* depth = nullptr;                 ///< raw depth (metres)
  std::unique_ptr<ModelSearchIndex> observed_index;  ///< over the segmented points (camera frame)
};

/// Minimum of the valid (non-zero) depths over the (2r+1)^2 window around each pixel of the region
/// [u0, u1] x [v0, v1] of `depth` (windows clipped to the image); separable (rows, then columns).
/// Returns the region's image; 0 where the window has no valid depth.
DepthImage min_filter(const DepthImage& depth, int r, int u0, int v0, int u1, int v1) {
  const int w = depth.width(), h = depth.height();
  const int rw = u1 - u0 + 1, rh = v1 - v0 + 1;
  const int ra = std::max(0, v0 - r), rb = std::min(h - 1, v1 + r);  // rows the columns read
  const float inf = std::numeric_limits<float>::infinity();
  Image<float> rows(rw, rb - ra + 1, inf);
  for (int v = ra; v <= rb; ++v)
    for (int u = u0; u <= u1; ++u) {
      float m = inf;
      for (int k = std::max(0, u - r); k <= std::min(w - 1, u + r); ++k) {
        const float z = depth.at(k, v);
        if (z > 0 && z < m) m = z;
      }
      rows.at(u - u0, v - ra) = m;
    }
  DepthImage out(rw, rh, 0.0f);
  for (int v = v0; v <= v1; ++v)
    for (int u = u0; u <= u1; ++u) {
      float m = inf;
      for (int k = std::max(0, v - r); k <= std::min(h - 1, v + r); ++k)
        m = std::min(m, rows.at(u - u0, k - ra));
      out.at(u - u0, v - v0) = std::isfinite(m) ? m : 0.0f;
    }
  return out;
}

/// Window minimum of the valid depths at pixel (u, v) (in the image): from the precomputed region,
/// else computed on the spot (same value).
float min_depth_at(const ScoringContext& ctx, int u, int v) {
  const int x = u - ctx.roi_u0, y = v - ctx.roi_v0;
  if (ctx.depth_min.in_bounds(x, y)) return ctx.depth_min.at(x, y);
  const DepthImage& d = *ctx.depth;
  const int r = ctx.window_px;
  float m = std::numeric_limits<float>::infinity();
  for (int b = std::max(0, v - r); b <= std::min(d.height() - 1, v + r); ++b)
    for (int a = std::max(0, u - r); a <= std::min(d.width() - 1, u + r); ++a) {
      const float z = d.at(a, b);
      if (z > 0 && z < m) m = z;
    }
  return std::isfinite(m) ? m : 0.0f;
}

constexpr std::uint32_t kNone = ModelSearchIndex::kNone;

/// Exact nearest point of `index` to `q` (what nearest() returns) when its squared distance is at
/// most `max_d2`, else kNone. `prev` is the point found for this query in the previous ICP
/// iteration (or kNone): the pose moved little since, so the true nearest point is usually among
/// its precomputed neighbours (ModelSearchIndex::nearest_near). Updated to the point found.
std::uint32_t nearest_warm(const ModelSearchIndex& index, const Eigen::Vector3f& q, float max_d2,
                           std::uint32_t& prev, float* d2) {
  const std::uint32_t j = index.nearest_near(q, prev, max_d2, d2);
  if (j != kNone) prev = j;
  return j;
}

/// Sums of the point-to-point terms w |p + delta x p + dt - m|^2 (Jacobian [I, -hat(p)] per point),
/// added to the normal equations at once: J^T J = [[I, -hat p], [hat p, |p|^2 I - p p^T]] and
/// J^T e = [e; p x e] are linear in w, w p, w p p^T, w e and w p x e.
struct PointToPointSums {
  double w = 0;
  Eigen::Vector3d wp = Eigen::Vector3d::Zero();
  Eigen::Matrix3d wpp = Eigen::Matrix3d::Zero();
  Eigen::Vector3d we = Eigen::Vector3d::Zero();
  Eigen::Vector3d wpxe = Eigen::Vector3d::Zero();
  void add(double wi, const Eigen::Vector3d& p, const Eigen::Vector3d& e) {
    w += wi;
    wp += wi * p;
    wpp.noalias() += wi * p * p.transpose();
    we += wi * e;
    wpxe += wi * p.cross(e);
  }
  void add_to(Mat6& H, Vec6& g) const {
    H.topLeftCorner<3, 3>().diagonal().array() += w;
    H.topRightCorner<3, 3>() -= hat(wp);
    H.bottomLeftCorner<3, 3>() += hat(wp);
    H.bottomRightCorner<3, 3>() += wpp.trace() * Eigen::Matrix3d::Identity() - wpp;
    g.head<3>() += we;
    g.tail<3>() += wpxe;
  }
};

class Registration {
 public:
  Registration(const ModelRegistrationParams& p, const ObjectModel& model,
               const ScoringContext& ctx)
      : p_(p), model_(model), index_(*model.search_index), ctx_(ctx) {}

  /// Robust point-to-plane ICP of the observed points `obs` (camera frame) onto the model.
  /// The association distance shrinks geometrically from corr_start to corr_end.
  SE3 icp(const std::vector<Vec3f>& obs, const SE3& T_cam_obj, int iterations, double corr_start,
          double corr_end, bool coarse) const {
    const std::vector<Vec3f>& model_subset = coarse ? ctx_.coarse_model_subset : ctx_.model_subset;
    SE3 A = T_cam_obj.inverse();  // T_obj_cam: update A <- exp(delta) A
    const bool grid = coarse && p_.coarse_grid_cells > 0;
    const float cell = static_cast<float>(model_.diameter_m / std::max(1, p_.coarse_grid_cells));
    const float margin = static_cast<float>(p_.coarse_max_corr_factor * model_.diameter_m) + cell;
    // Per observed point / free-space model point: its nearest point of the previous iteration.
    std::vector<std::uint32_t> prev(grid ? 0 : obs.size(), kNone);
    std::vector<std::uint32_t> prev_free(model_subset.size(), kNone);
    const float unbounded = std::numeric_limits<float>::infinity();
    for (int it = 0; it < iterations; ++it) {
      const double frac = iterations > 1 ? static_cast<double>(it) / (iterations - 1) : 1.0;
      const double corr = corr_start * std::pow(corr_end / corr_start, frac);
      const float corr2 = static_cast<float>(corr * corr);
      const Mat3f R = A.rotation().cast<float>();
      const Vec3f t = A.translation().cast<float>();
      const Vec3f cam = t;    // camera centre in the object frame
      Mat6 H = Mat6::Zero();  // point-to-plane part: upper triangle only, mirrored below
      Vec6 g = Vec6::Zero();
      PointToPointSums p2p;
      int used = 0;
      const double delta = p_.huber_delta_m;
      const double lambda = p_.point_to_point_weight;
      const double half_spacing = 0.5 * model_.mean_spacing_m;
      for (size_t k = 0; k < obs.size(); ++k) {
        const Vec3f pt = R * obs[k] + t;
        float d2 = 0;
        const std::uint32_t j = grid ? index_.nearest_approx(pt, &d2, cell, margin)
                                     : nearest_warm(index_, pt, corr2, prev[k], &d2);
        if (j == kNone || d2 > corr2) continue;
        const Vec3f& n = model_.normals[j];
        const Vec3f& m = model_.points[j];
        if (p_.reject_back_facing) {
          const Vec3f ray = pt - cam;
          if (n.dot(ray) > 0.3f * ray.norm()) continue;  // clearly back-facing
        }
        const Eigen::Vector3d pd = pt.cast<double>();
        const Eigen::Vector3d nd = n.cast<double>();
        const Eigen::Vector3d e = (pt - m).cast<double>();
        const double r = nd.dot(e);
        const double w = std::abs(r) <= delta ? 1.0 : delta / std::abs(r);
        Vec6 J;
        J.head<3>() = nd;
        J.tail<3>() = pd.cross(nd);
        H.selfadjointView<Eigen::Upper>().rankUpdate(J, w);
        g.noalias() += w * r * J;
        if (lambda > 0) {
          // Tangential offset beyond half the model's sample spacing: pulls points that overhang
          // an edge without the false minima a plain point-to-point term has at lattice shifts.
          const Eigen::Vector3d et = e - r * nd;
          const double etn = et.norm();
          if (etn > half_spacing) {
            const Eigen::Vector3d ed = et * (1.0 - half_spacing / etn);
            const double edn = ed.norm();
            p2p.add(lambda * (edn <= delta ? 1.0 : delta / edn), pd, ed);
          }
        }
        ++used;
      }
      // Free-space term: model points seen in front of the observed depth are pulled to the
      // nearest observed object point (the gradient of the violation count in the score).
      if (p_.free_space_icp_weight > 0 && ctx_.observed_index) {
        const Mat3f Rc = R.transpose();
        const Vec3f tc = -(Rc * t);
        const double wf = p_.free_space_icp_weight;
        for (size_t k = 0; k < model_subset.size(); ++k) {
          const Vec3f& m = model_subset[k];
          const Vec3f pc = Rc * m + tc;
          if (!violates_free_space(pc)) continue;
          float d2 = 0;
          const Vec3f& q =
              ctx_.observed_index
                  ->points()[nearest_warm(*ctx_.observed_index, pc, unbounded, prev_free[k], &d2)];
          const Vec3f pt = R * q + t;
          const Eigen::Vector3d pd = pt.cast<double>();
          const Eigen::Vector3d e = (pt - m).cast<double>();
          const double en = e.norm();
          p2p.add(wf * (en <= delta ? 1.0 : delta / en), pd, e);
        }
      }
      if (used < 6) break;
      H.triangularView<Eigen::StrictlyLower>() = H.transpose();
      p2p.add_to(H, g);
      H.diagonal().array() += 1e-6 * (H.diagonal().maxCoeff() + 1e-12);
      const Vec6 step = -H.ldlt().solve(g);
      if (!step.allFinite()) break;
      A = SE3::exp(step) * A;
      if (step.head<3>().norm() < 1e-5 && step.tail<3>().norm() < 1e-5 && corr <= corr_end * 1.0001)
        break;
    }
    return A.inverse();
  }

  /// Fit of the observed points plus free-space consistency of the model under T_cam_obj.
  void score(const std::vector<Vec3f>& obs, Hypothesis& h, bool coarse) const {
    const std::vector<Vec3f>& model_subset = coarse ? ctx_.coarse_model_subset : ctx_.model_subset;
    const SE3 A = h.T_cam_obj.inverse();
    const Mat3f R = A.rotation().cast<float>();
    const Vec3f t = A.translation().cast<float>();
    const double tau = p_.inlier_distance_m;
    const float spacing = static_cast<float>(model_.mean_spacing_m);
    double fit = 0;
    int inliers = 0;
    // A point farther than tau + spacing from every model point adds nothing (d >= tau below):
    // the search is bounded there (with a margin), its result otherwise the exact nearest point.
    const float reach = static_cast<float>(tau) + spacing;
    const float reach2 = reach * reach * (1.0f + 1e-4f);
    for (const auto& q : obs) {
      const Vec3f pt = R * q + t;
      float d2 = 0;
      const std::uint32_t j = index_.nearest_within(pt, reach2, &d2);
      if (j == kNone) continue;
      // Distance to the surface: the plane distance, unless the point is farther from the nearest
      // sample than the sampling explains.
      const float dp = std::sqrt(d2);
      const float d =
          std::max(std::abs(model_.normals[j].dot(pt - model_.points[j])), dp - spacing);
      fit += std::max(0.0, 1.0 - d / tau);
      inliers += d < tau;
    }
    h.fit = obs.empty() ? 0.0 : fit / static_cast<double>(obs.size());
    h.inliers = obs.empty() ? 0.0 : static_cast<double>(inliers) / static_cast<double>(obs.size());

    const Mat3f Rc = h.T_cam_obj.rotation().cast<float>();
    const Vec3f tc = h.T_cam_obj.translation().cast<float>();
    const std::vector<Vec3f>& normal_subset =
        coarse ? ctx_.coarse_normal_subset : ctx_.normal_subset;
    int violations = 0, visible = 0;
    double supported = 0;
    for (size_t i = 0; i < model_subset.size(); ++i) {
      const Vec3f pc = Rc * model_subset[i] + tc;
      violations += violates_free_space(pc);
      // Support: a camera-facing model point that nothing observed hides should lie on the observed
      // depth, inside the mask or not (a cut or partial mask still sees the object's depth).
      if (p_.support_weight <= 0 || pc.z() <= 0.01f || (Rc * normal_subset[i]).dot(pc) >= 0)
        continue;
      const int u = static_cast<int>(std::lround(ctx_.K.fx * pc.x() / pc.z() + ctx_.K.cx));
      const int v = static_cast<int>(std::lround(ctx_.K.fy * pc.y() / pc.z() + ctx_.K.cy));
      if (!ctx_.depth->in_bounds(u, v)) continue;
      const float z = ctx_.depth->at(u, v);
      if (!(z > 0) || z < pc.z() - static_cast<float>(tau)) continue;  // unknown or occluded
      ++visible;
      supported += std::max(0.0, 1.0 - std::abs(z - pc.z()) / tau);
    }
    h.violation = static_cast<double>(violations) / static_cast<double>(model_subset.size());
    h.support = visible > 0 ? supported / visible : 0.0;
    h.score = h.fit - p_.free_space_weight * h.violation + p_.support_weight * h.support;
  }

  /// A camera-frame model point in front of the observed depth (window minimum) by more than the
  /// margin, or behind the camera: the sensor saw through where the object would be.
  bool violates_free_space(const Vec3f& pc) const {
    if (pc.z() <= 0.01f) return true;
    const int u = static_cast<int>(std::lround(ctx_.K.fx * pc.x() / pc.z() + ctx_.K.cx));
    const int v = static_cast<int>(std::lround(ctx_.K.fy * pc.y() / pc.z() + ctx_.K.cy));
    if (!ctx_.depth->in_bounds(u, v)) return false;
    const float z = min_depth_at(ctx_, u, v);
    return z > 0 && pc.z() < z - static_cast<float>(p_.free_space_margin_m);
  }

  /// Translation that puts the centroid of the model's camera-facing half (under rotation R) on
  /// the observed centroid.
  Vec3 initial_translation(const Mat3& R, const Vec3f& centroid) const {
    const Mat3f Rf = R.cast<float>();
    const Vec3f ray = centroid.normalized();
    Vec3f sum = Vec3f::Zero();
    int count = 0;
    for (size_t i = 0; i < ctx_.model_subset.size(); ++i) {
      if ((Rf * ctx_.normal_subset[i]).dot(ray) >= 0) continue;
      sum += Rf * ctx_.model_subset[i];
      ++count;
    }
    if (count == 0) {
      for (const auto& m : ctx_.model_subset) sum += Rf * m;
      count = static_cast<int>(ctx_.model_subset.size());
    }
    return (centroid - sum / static_cast<float>(count)).cast<double>();
  }

 private:
  const ModelRegistrationParams& p_;
  const ObjectModel& model_;
  const ModelSearchIndex& index_;
  const ScoringContext& ctx_;
};

/// Fraction of the mask's boundary pixels that have, within 4 px outside the mask, a valid depth
/// more than 2 cm nearer than their own: the boundary is an occluder's edge, not the silhouette.
double occluded_boundary_fraction(const MaskImage& mask, const DepthImage& depth) {
  const int w = mask.width(), h = mask.height(), r = 4;
  int boundary = 0, occluded = 0;
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      if (!mask.at(u, v)) continue;
      const bool edge = u == 0 || v == 0 || u == w - 1 || v == h - 1 || !mask.at(u - 1, v) ||
                        !mask.at(u + 1, v) || !mask.at(u, v - 1) || !mask.at(u, v + 1);
      if (!edge) continue;
      ++boundary;
      const float z = depth.at(u, v);
      if (!(z > 0)) continue;
      bool hit = false;
      for (int dv = -r; dv <= r && !hit; ++dv)
        for (int du = -r; du <= r && !hit; ++du) {
          const int uu = u + du, vv = v + dv;
          if (!mask.in_bounds(uu, vv) || mask.at(uu, vv)) continue;
          const float zz = depth.at(uu, vv);
          hit = zz > 0 && zz < z - 0.02f;
        }
      occluded += hit;
    }
  return boundary ? static_cast<double>(occluded) / boundary : 0.0;
}

std::vector<Vec3f> strided_subset(const std::vector<Vec3f>& pts, int n) {
  if (n <= 0 || static_cast<int>(pts.size()) <= n) return pts;
  std::vector<Vec3f> out;
  out.reserve(static_cast<size_t>(n));
  const double step = static_cast<double>(pts.size()) / n;
  for (int i = 0; i < n; ++i) out.push_back(pts[static_cast<size_t>(i * step)]);
  return out;
}

/// Coarse stage over the rotation grid, then refinement of the best distinct hypotheses (and the
/// caller's prior). Fills `refine` with the refined, scored hypotheses.
void search(const ModelRegistrationParams& params, const std::vector<Mat3>& rotations,
            const Registration& reg, const SegmentedCloud& cloud, double diameter,
            const SingleViewInput& input, bool translation_search,
            std::vector<Hypothesis>& refine) {
  const std::vector<Vec3f> coarse_pts = strided_subset(cloud.points, params.coarse_points);

  // Coarse stage: every rotation of the grid.
  const int n_rot = static_cast<int>(rotations.size());
  std::vector<Hypothesis> coarse(static_cast<size_t>(n_rot));
  const double coarse_start = params.coarse_max_corr_factor * diameter;
  const double coarse_end = std::max(params.final_max_corr_m, 0.1 * diameter);
#pragma omp parallel for schedule(dynamic, 4)
  for (int i = 0; i < n_rot; ++i) {
    const Mat3& R = rotations[static_cast<size_t>(i)];
    Hypothesis h;
    h.T_cam_obj = SE3(R, reg.initial_translation(R, cloud.centroid));
    if (translation_search) {
      // Occluded view: the observed centroid is off the visible model centroid; try a 3x3 grid of
      // shifts across the viewing ray and start from the best-scoring one.
      const Vec3 ray = h.T_cam_obj.translation().normalized();
      const Vec3 side = Vec3::UnitY().cross(ray).normalized();
      const Vec3 up = ray.cross(side).normalized();
      const double a = params.translation_search_step_factor * diameter;
      Hypothesis best = h;
      reg.score(coarse_pts, best, true);
      for (int sx = -1; sx <= 1; ++sx)
        for (int sy = -1; sy <= 1; ++sy) {
          if (sx == 0 && sy == 0) continue;
          Hypothesis c = h;
          c.T_cam_obj.translation() += a * (sx * side + sy * up);
          reg.score(coarse_pts, c, true);
          if (c.score > best.score) best = c;
        }
      h = best;
    }
    h.T_cam_obj = reg.icp(coarse_pts, h.T_cam_obj, params.coarse_iterations, coarse_start,
                          std::min(coarse_start, coarse_end), true);
    reg.score(coarse_pts, h, true);
    coarse[static_cast<size_t>(i)] = h;
  }
  std::vector<int> order(coarse.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return coarse[a].score > coarse[b].score; });

  // Distinct best hypotheses (+ the caller's prior).
  for (int i : order) {
    if (static_cast<int>(refine.size()) >= params.refine_top_k) break;
    const Hypothesis& h = coarse[static_cast<size_t>(i)];
    bool distinct = true;
    for (const auto& r : refine)
      if (rotation_distance_rad(r.T_cam_obj.rotation(), h.T_cam_obj.rotation()) < 0.25 &&
          (r.T_cam_obj.translation() - h.T_cam_obj.translation()).norm() < 0.1 * diameter)
        distinct = false;
    if (distinct) refine.push_back(h);
  }
  if (input.T_cam_obj_prior) {
    Hypothesis h;
    h.T_cam_obj = *input.T_cam_obj_prior;
    refine.push_back(h);
  }

  const double refine_start =
      std::max(params.refine_max_corr_factor * diameter, params.final_max_corr_m);
#pragma omp parallel for schedule(dynamic, 1)
  for (int i = 0; i < static_cast<int>(refine.size()); ++i) {
    Hypothesis& h = refine[static_cast<size_t>(i)];
    h.T_cam_obj = reg.icp(cloud.points, h.T_cam_obj, params.refine_iterations, refine_start,
                          params.final_max_corr_m, false);
    reg.score(cloud.points, h, false);
  }
}

// ---- Colour ranking (step 5; colour_score.h). Kept apart from the geometric search above. ----

/// Score lead of `chosen` over the best candidate at a rotation more than 0.3 rad away (0: none).
double geometry_margin(const std::vector<Hypothesis>& candidates, const Hypothesis& chosen) {
  double other = -1e9;
  for (const auto& h : candidates)
    if (rotation_distance_rad(h.T_cam_obj.rotation(), chosen.T_cam_obj.rotation()) > 0.3)
      other = std::max(other, h.score);
  return other > -1e8 ? chosen.score - other : 0.0;
}

/// A model with a continuous symmetry axis (a can): geometry leaves the turn about the axis free,
/// the print does not. The colour NCC of the chosen pose turned by 10-degree steps about the axis,
/// then steps halved three times about the best; the best turn replaces `h` when its NCC is higher
/// and its geometric score stays within the colour_geometry_margin of `best_geometry`. Run once per
/// direction of the axis among the competing candidates (the can upright or upside down).
void refine_turn_by_colour(const ModelRegistrationParams& params, const Registration& reg,
                           const SegmentedCloud& cloud, const ObjectModel& model,
                           const SingleViewInput& input, double best_geometry, Hypothesis& h) {
  const ColourScoreParams& cp = params.colour;
  auto ncc_at = [&](double angle) {
    const SE3 T = h.T_cam_obj * model.symmetry.continuous_element(angle);
    return pose_colour_evidence(*model.colour, T, *input.color, *input.depth, *input.mask,
                                input.intrinsics, cp)
        .ncc;
  };
  const double coarse = 10.0 * M_PI / 180.0;
  std::vector<double> ncc(36);
#pragma omp parallel for schedule(static)
  for (int k = 0; k < 36; ++k) ncc[static_cast<size_t>(k)] = ncc_at(k * coarse);
  const int k_best = static_cast<int>(std::max_element(ncc.begin(), ncc.end()) - ncc.begin());
  double angle = k_best * coarse, value = ncc[static_cast<size_t>(k_best)];
  h.colour = ncc[0];
  for (double step = coarse / 2; step > coarse / 10; step /= 2)
    for (const double a : {angle - step, angle + step})
      if (const double v = ncc_at(a); v > value) value = v, angle = a;
  if (value <= h.colour) return;
  // Refined like the confusable poses: the detected axis is not exact, so the turned pose is off
  // the surface by a millimetre or two until ICP puts it back (the turn itself stays).
  Hypothesis turned;
  const double start =
      std::max(params.refine_max_corr_factor * model.diameter_m, params.final_max_corr_m);
  turned.T_cam_obj = reg.icp(cloud.points, h.T_cam_obj * model.symmetry.continuous_element(angle),
                             params.refine_iterations, start, params.final_max_corr_m, false);
  reg.score(cloud.points, turned, false);
  turned.colour = pose_colour_evidence(*model.colour, turned.T_cam_obj, *input.color, *input.depth,
                                       *input.mask, input.intrinsics, cp)
                      .ncc;
  if (turned.score < best_geometry - cp.geometry_margin || turned.colour <= h.colour) return;
  h = turned;
}

/// colour_refine_turn, a model with a continuous symmetry axis (a can): refine_turn_by_colour on
/// the first of `hyps` within colour_geometry_margin of `best_geometry` for each direction of the
/// axis in the camera among them (the can upright or upside down).
void refine_turns_by_colour(const ModelRegistrationParams& params, const Registration& reg,
                            const SegmentedCloud& cloud, const ObjectModel& model,
                            const SingleViewInput& input, double best_geometry,
                            std::vector<Hypothesis>& hyps) {
  const ColourScoreParams& cp = params.colour;
  if (!cp.refine_turn || !model.symmetry.continuous) return;
  std::vector<Vec3> axes;
  for (Hypothesis& h : hyps) {
    if (h.score < best_geometry - cp.geometry_margin) continue;
    const Vec3 axis = h.T_cam_obj.rotation() * model.symmetry.axis_obj;
    if (std::any_of(axes.begin(), axes.end(), [&](const Vec3& a) { return a.dot(axis) > 0.87; }))
      continue;
    axes.push_back(axis);
    refine_turn_by_colour(params, reg, cloud, model, input, best_geometry, h);
  }
}

/// Among `hyps` within colour_geometry_margin of `best_geometry`: each one's colour NCC, and the
/// index of the best score + colour_weight * NCC; `out` gets the chosen pose's NCC and its lead
/// over the best other (distinct) candidate.
int choose_by_colour(const ColourScoreParams& cp, const ObjectModel& model,
                     const SingleViewInput& input, std::vector<Hypothesis>& hyps,
                     double best_geometry, SingleViewPose& out) {
  int chosen = -1;
  double chosen_rank = -1e9;
  for (size_t i = 0; i < hyps.size(); ++i) {
    Hypothesis& h = hyps[i];
    if (h.score < best_geometry - cp.geometry_margin) continue;
    h.colour = pose_colour_evidence(*model.colour, h.T_cam_obj, *input.color, *input.depth,
                                    *input.mask, input.intrinsics, cp)
                   .ncc;
    const double rank = h.score + cp.weight * h.colour;
    if (rank > chosen_rank) chosen_rank = rank, chosen = static_cast<int>(i);
  }
  const Hypothesis& c = hyps[static_cast<size_t>(chosen)];
  double other = -1e9;
  for (const auto& h : hyps)
    if (h.score >= best_geometry - cp.geometry_margin &&
        rotation_distance_rad(h.T_cam_obj.rotation(), c.T_cam_obj.rotation()) > 0.3)
      other = std::max(other, h.colour);
  out.colour_used = true;
  out.colour_ncc = c.colour;
  out.colour_margin = other > -1e8 ? c.colour - other : 0.0;
  return chosen;
}

/// Adds the best hypothesis's confusable poses (refined and scored), scores every candidate's
/// colour and returns the index of the chosen one, or -1 (no colour: keep the geometric choice).
int rank_by_colour(const ModelRegistrationParams& params, const Registration& reg,
                   const SegmentedCloud& cloud, const ObjectModel& model,
                   const SingleViewInput& input, std::vector<Hypothesis>& refine,
                   SingleViewPose& out) {
  const ColourScoreParams& cp = params.colour;
  if (!input.color || input.color->empty() || !has_usable_colour(model, cp) || refine.empty())
    return -1;
  auto geometric_best = [&]() {
    return static_cast<size_t>(
        std::max_element(refine.begin(), refine.end(),
                         [](const auto& a, const auto& b) { return a.score < b.score; }) -
        refine.begin());
  };
  if (cp.try_flips) {
    const std::vector<SE3> flips =
        confusable_poses(model, refine[geometric_best()].T_cam_obj, cp.try_quarter_turns);
    std::vector<Hypothesis> extra(flips.size());
    const double start =
        std::max(params.refine_max_corr_factor * model.diameter_m, params.final_max_corr_m);
#pragma omp parallel for schedule(dynamic, 1)
    for (int i = 0; i < static_cast<int>(flips.size()); ++i) {
      Hypothesis& h = extra[static_cast<size_t>(i)];
      h.T_cam_obj = reg.icp(cloud.points, flips[static_cast<size_t>(i)], params.refine_iterations,
                            start, params.final_max_corr_m, false);
      reg.score(cloud.points, h, false);
    }
    refine.insert(refine.end(), extra.begin(), extra.end());
  }
  const double best_geometry = refine[geometric_best()].score;
  refine_turns_by_colour(params, reg, cloud, model, input, best_geometry, refine);
  return choose_by_colour(cp, model, input, refine, best_geometry, out);
}

// ---------------------------------------------------------------------------------------------
// Prior fast path (ModelRegistrationParams::prior_*): an object the caller already knows (its
// fused pose moved into this camera) needs a local refinement, not the global rotation search.

/// The score a refined prior must reach to fit: prior_min_score, lowered to
/// prior_relative_fraction of the object's reference score when the caller gives one.
double prior_min_score(const ModelRegistrationParams& p, const SingleViewInput& in) {
  if (p.prior_relative_fraction > 0 && in.prior_reference_score > 0)
    return std::min(p.prior_min_score, p.prior_relative_fraction * in.prior_reference_score);
  return p.prior_min_score;
}

/// ICP from the prior on a strided subset of the points, scored on that subset. Returns whether
/// the refined prior fits (inlier fraction and free space within their thresholds, score >=
/// `min_score`); `out` gets it either way.
bool refine_from_prior(const ModelRegistrationParams& p, const Registration& reg,
                       const SegmentedCloud& cloud, double diameter, const SE3& T_cam_obj_prior,
                       double min_score, Hypothesis* out) {
  const std::vector<Vec3f> pts = strided_subset(cloud.points, p.prior_points);
  const double start = std::max(p.refine_max_corr_factor * diameter, p.final_max_corr_m);
  Hypothesis h;
  h.T_cam_obj = reg.icp(pts, T_cam_obj_prior, p.prior_iterations, start, p.final_max_corr_m, false);
  reg.score(pts, h, false);
  *out = h;
  return h.inliers >= p.prior_min_inlier_fraction &&
         h.violation <= p.prior_max_free_space_violation && h.score >= min_score;
}

/// prior_flips: the refined prior's three 180-degree turns about the model's principal axes, each
/// refined and scored like the prior (in parallel); appended to `hyps`. Then the best is chosen by
/// score + colour_weight * NCC among those within colour_geometry_margin when the model has colour,
/// else by score. Returns the index of the chosen hypothesis.
int compare_prior_modes(const ModelRegistrationParams& p, const Registration& reg,
                        const SegmentedCloud& cloud, const ObjectModel& model,
                        const SingleViewInput& input, std::vector<Hypothesis>& hyps,
                        SingleViewPose& out) {
  const bool colour = input.color && !input.color->empty() && has_usable_colour(model, p.colour);
  std::vector<SE3> turns =
      confusable_poses(model, hyps.front().T_cam_obj, colour && p.colour.try_quarter_turns);
  if (model.symmetry.continuous)
    turns.resize(std::min<size_t>(turns.size(), 3));  // the principal flips, not the axis turns
  std::vector<Hypothesis> extra(turns.size());
#pragma omp parallel for schedule(dynamic, 1)
  for (int i = 0; i < static_cast<int>(turns.size()); ++i)
    refine_from_prior(p, reg, cloud, model.diameter_m, turns[static_cast<size_t>(i)],
                      p.prior_min_score, &extra[static_cast<size_t>(i)]);
  hyps.insert(hyps.end(), extra.begin(), extra.end());
  int best = 0;
  for (int i = 1; i < static_cast<int>(hyps.size()); ++i)
    if (hyps[static_cast<size_t>(i)].score > hyps[static_cast<size_t>(best)].score) best = i;
  out.prior_modes_compared = true;
  const ColourScoreParams& cp = p.colour;
  if (!colour) return best;
  // A can's turn about its axis is not among the principal flips: searched by colour as in the
  // global path (else the fast path keeps the prior's turn, right or wrong, for good).
  const double best_geometry = hyps[static_cast<size_t>(best)].score;
  refine_turns_by_colour(p, reg, cloud, model, input, best_geometry, hyps);
  return choose_by_colour(cp, model, input, hyps, best_geometry, out);
}

}  // namespace

ModelRegistrationEstimator::ModelRegistrationEstimator(const ModelRegistrationParams& params)
    : params_(params) {
  std::string why;
  if (!params.IsValid(&why)) throw ConfigError("pose_registration: " + why);
  rotations_ = uniform_rotations(params.num_rotations);
}

SingleViewPose ModelRegistrationEstimator::estimate(const SingleViewInput& input) const {
  return run(input, nullptr);
}

SingleViewPose ModelRegistrationEstimator::evaluate(const SingleViewInput& input,
                                                    const SE3& T_cam_obj) const {
  return run(input, &T_cam_obj);
}

namespace {

/// What the scores of one object's view need besides the model: the free-space test's window
/// minimum around the mask, the model subsets, the depth, and an index over the segmented points.
ScoringContext scoring_context(const ModelRegistrationParams& params, const SingleViewInput& input,
                               const SegmentedCloud& cloud, const ObjectModel& model) {
  ScoringContext ctx;
  {
    // The free-space test's window minimum, precomputed around the mask (the segmented points'
    // box grown by half its size: where model points of plausible hypotheses project).
    int u0 = input.depth->width(), v0 = input.depth->height(), u1 = -1, v1 = -1;
    for (const auto& p : cloud.points) {
      const Eigen::Vector2d uv = input.intrinsics.project(p.cast<double>());
      u0 = std::min(u0, static_cast<int>(uv.x())), u1 = std::max(u1, static_cast<int>(uv.x()));
      v0 = std::min(v0, static_cast<int>(uv.y())), v1 = std::max(v1, static_cast<int>(uv.y()));
    }
    const int grow = std::max(u1 - u0, v1 - v0) / 2 + 2;
    u0 = std::max(0, u0 - grow), v0 = std::max(0, v0 - grow);
    u1 = std::min(input.depth->width() - 1, u1 + grow);
    v1 = std::min(input.depth->height() - 1, v1 + grow);
    ctx.window_px = params.free_space_window_px;
    ctx.roi_u0 = u0, ctx.roi_v0 = v0;
    ctx.depth_min = min_filter(*input.depth, ctx.window_px, u0, v0, u1, v1);
  }
  ctx.K = input.intrinsics;
  const size_t n = model.points.size();
  const size_t want = static_cast<size_t>(params.free_space_model_points);
  const double step = n > want ? static_cast<double>(n) / want : 1.0;
  for (double k = 0; k < n; k += step) {
    ctx.model_subset.push_back(model.points[static_cast<size_t>(k)]);
    ctx.normal_subset.push_back(model.normals[static_cast<size_t>(k)]);
  }
  ctx.coarse_model_subset = strided_subset(ctx.model_subset, params.coarse_points);
  ctx.coarse_normal_subset = strided_subset(ctx.normal_subset, params.coarse_points);
  ctx.depth = input.depth;
  ctx.observed_index = std::make_unique<ModelSearchIndex>(cloud.points);
  return ctx;
}

}  // namespace

SingleViewPose ModelRegistrationEstimator::run(const SingleViewInput& input,
                                               const SE3* fixed_pose) const {
  const ModelRegistrationParams& params = params_;
  const auto start = std::chrono::steady_clock::now();
  SingleViewPose out;
  auto finish = [&]() {
    out.time_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    return out;
  };
  std::string why;
  if (!input.IsValid(&why)) {
    out.reason = why;
    return finish();
  }
  // The model must be prepared (index, normals, diameter); prepare a copy if the caller did not.
  ObjectModel local;
  const ObjectModel* model = input.model;
  if (!model->prepared() || !model->has_normals() || model->mean_spacing_m <= 0) {
    local = *model;
    try {
      prepare_object_model(local);
    } catch (const std::exception& e) {
      out.reason = e.what();
      return finish();
    }
    model = &local;
  }

  const SegmentedCloud cloud = extract_segmented_cloud(*input.mask, *input.depth, input.intrinsics,
                                                       model->diameter_m, params.segmented_cloud());
  out.num_points = static_cast<int>(cloud.points.size());
  if (out.num_points < params.min_points) {
    out.reason = "too few segmented points with valid depth (" + std::to_string(out.num_points) +
                 " of " + std::to_string(cloud.mask_pixels) + " mask pixels, need " +
                 std::to_string(params.min_points) + ")";
    return finish();
  }

  const ScoringContext ctx = scoring_context(params, input, cloud, *model);
  const Registration reg(params_, *model, ctx);
  const double diameter = model->diameter_m;
  std::vector<Hypothesis> refine;
  if (fixed_pose) {
    Hypothesis h;
    h.T_cam_obj = *fixed_pose;
    reg.score(cloud.points, h, false);
    refine.push_back(h);
  } else if (Hypothesis h;
             input.T_cam_obj_prior && params.prior_refinement &&
             refine_from_prior(params, reg, cloud, diameter, *input.T_cam_obj_prior,
                               prior_min_score(params, input), &h)) {
    refine.push_back(h);
    out.from_prior = true;
  } else {
    const double occluded = occluded_boundary_fraction(*input.mask, *input.depth);
    const bool translation_search =
        params.translation_search_occlusion >= 0 && occluded >= params.translation_search_occlusion;
    search(params_, rotations_, reg, cloud, diameter, input, translation_search, refine);
  }
  // The refined prior keeps the caller's mode (colour ranks the modes in the global search), unless
  // prior_flips compares it with its turns.
  const int by_colour =
      fixed_pose       ? -1
      : out.from_prior ? (params.prior_flips
                              ? compare_prior_modes(params_, reg, cloud, *model, input, refine, out)
                              : -1)
                       : rank_by_colour(params_, reg, cloud, *model, input, refine, out);
  const auto best =
      by_colour >= 0
          ? refine.begin() + by_colour
          : std::max_element(refine.begin(), refine.end(),
                             [](const auto& a, const auto& b) { return a.score < b.score; });

  out.T_cam_obj = best->T_cam_obj;
  out.score = best->score;
  out.geometry_margin = geometry_margin(refine, *best);
  out.inlier_fraction = best->inliers;
  out.free_space_violation = best->violation;
  out.mu_m = mean_model_distance_m(cloud.points, *model, out.T_cam_obj);
  out.valid = best->inliers >= params.min_inlier_fraction;
  if (!out.valid)
    out.reason = "best hypothesis explains only " + std::to_string(best->inliers) +
                 " of the segmented points (min_inlier_fraction " +
                 std::to_string(params.min_inlier_fraction) + ")";
  return finish();
}

}  // namespace orpe
