#include "orpe/slam/tracker.h"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

#include "orpe/core/error.h"
#include "orpe/slam/rigid_f.h"

namespace orpe::slam {
namespace {

// Per-row partial sums, reduced in row order afterwards so results do not depend on threads.
struct RowSums {
  double a[21];
  double b[6];
  double ss;
  int count;
  int overlap;
  /// Stores one row's single-precision accumulators.
  void set(const float (&row_a)[21], const float (&row_b)[6], float row_ss, int row_count,
           int row_overlap) {
    for (int k = 0; k < 21; ++k) a[k] = row_a[k];
    for (int k = 0; k < 6; ++k) b[k] = row_b[k];
    ss = row_ss;
    count = row_count;
    overlap = row_overlap;
  }
};

// Per-row sums of the photometric step's brightness-gain terms (rgb_step): with r = live - model
// at gain 1, w the Huber weight and J the Jacobian of the live intensity,
// bl = sum w J live, rl = sum w r live, ll = sum w live^2 (and rl, ll unweighted, for sum_sq).
struct GainRowSums {
  double bl[6];
  double rl, ll, rl_u, ll_u;
};

inline void accumulate(float (&a)[21], float (&b)[6], const float (&J)[6], float r, float w) {
  float wJ[6];
  for (int i = 0; i < 6; ++i) wJ[i] = w * J[i];
  int k = 0;
  for (int i = 0; i < 6; ++i) {
    for (int j = 0; j <= i; ++j) a[k++] += wJ[i] * J[j];
    b[i] += wJ[i] * r;
  }
}

// Huber weight (delta <= 0: plain least squares).
inline float huber_weight(float r, float delta) {
  const float ar = std::fabs(r);
  return (delta <= 0.0f || ar <= delta) ? 1.0f : delta / ar;
}

NormalEquations reduce(const std::vector<RowSums>& rows) {
  NormalEquations ne;
  double a[21] = {};
  for (const RowSums& r : rows) {
    for (int k = 0; k < 21; ++k) a[k] += r.a[k];
    for (int i = 0; i < 6; ++i) ne.b[i] += r.b[i];
    ne.sum_sq += r.ss;
    ne.count += r.count;
    ne.overlap += r.overlap;
  }
  int k = 0;
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j <= i; ++j) {
      ne.A(i, j) = a[k];
      ne.A(j, i) = a[k];
      ++k;
    }
  return ne;
}

inline float bilinear(const Image<float>& img, float u, float v) {
  const int u0 = static_cast<int>(u), v0 = static_cast<int>(v);
  const float fu = u - static_cast<float>(u0), fv = v - static_cast<float>(v0);
  const float* r0 = img.row(v0) + u0;
  const float* r1 = img.row(v0 + 1) + u0;
  return (1 - fv) * ((1 - fu) * r0[0] + fu * r0[1]) + fv * ((1 - fu) * r1[0] + fu * r1[1]);
}

int iterations_for_level(const TrackerParams& p, int level) {
  if (level == 0) return p.iterations_level0;
  if (level == 1) return p.iterations_level1;
  return p.iterations_level2;
}
float gradient_for_level(const TrackerParams& p, int level) {
  if (level == 0) return static_cast<float>(p.rgb_min_gradient_level0);
  if (level == 1) return static_cast<float>(p.rgb_min_gradient_level1);
  return static_cast<float>(p.rgb_min_gradient_level2);
}

// The photometric step with the live image's brightness gain g solved jointly with the pose:
// residuals g live - model = r + (g - 1) live. `ne` holds the sums at g = 1; they become those at
// the least-squares gain (d sum_sq / d g = 0), with the gain eliminated from the pose's normal
// equations (Schur complement): A = g^2 (A1 - bl bl^T / ll), b = g (b1 + (g - 1) bl).
void solve_gain(const std::vector<GainRowSums>& rows, NormalEquations& ne) {
  Vec6 bl = Vec6::Zero();
  double rl = 0, ll = 0, rl_u = 0, ll_u = 0;
  for (const GainRowSums& g : rows) {
    for (int k = 0; k < 6; ++k) bl[k] += g.bl[k];
    rl += g.rl, ll += g.ll, rl_u += g.rl_u, ll_u += g.ll_u;
  }
  if (ne.count < 6 || !(ll > 0)) return;
  // A numerical guard only: brightness between a frame and the map within a factor of 5.
  const double d = std::clamp(-rl / ll, 0.2 - 1.0, 5.0 - 1.0);  // g - 1
  const double g = 1.0 + d;
  ne.gain = g;
  ne.A = g * g * (ne.A - bl * bl.transpose() / ll);
  ne.b = g * (ne.b + d * bl);
  ne.sum_sq = std::max(0.0, ne.sum_sq + 2.0 * d * rl_u + d * d * ll_u);
}

}  // namespace

bool TrackerParams::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  // Bounded so that no setting can make a frame run for ever (ElasticFusion: 10 / 5 / 4).
  if (iterations_level0 < 0 || iterations_level1 < 0 || iterations_level2 < 0 ||
      iterations_level0 > 1000 || iterations_level1 > 1000 || iterations_level2 > 1000)
    return fail("iterations_level* must be in 0..1000");
  if (!(convergence_step > 0 && convergence_step < 1))
    return fail("convergence_step must be in (0, 1)");
  if (!(icp_max_dist_m > 0)) return fail("icp_max_dist_m must be positive");
  if (!(icp_max_angle_deg > 0 && icp_max_angle_deg <= 180))
    return fail("icp_max_angle_deg must be in (0, 180]");
  if (!use_icp && !use_rgb) return fail("at least one of use_icp, use_rgb must be on");
  if (!(icp_weight > 0)) return fail("icp_weight must be positive");
  if (!(rgb_max_depth_diff_m > 0)) return fail("rgb_max_depth_diff_m must be positive");
  if (rgb_min_gradient_level0 < 0 || rgb_min_gradient_level1 < 0 || rgb_min_gradient_level2 < 0)
    return fail("rgb_min_gradient_* must be >= 0");
  if (rgb_edge_margin_px < 0 || rgb_edge_margin_px > 8)
    return fail("rgb_edge_margin_px must be in 0..8");
  if (!(rgb_edge_jump_m > 0) || !(rgb_edge_jump_per_m >= 0) || !std::isfinite(rgb_edge_jump_per_m))
    return fail("need rgb_edge_jump_m > 0 and rgb_edge_jump_per_m >= 0");
  if (level0_pixel_step < 1 || level0_pixel_step > 4)
    return fail("level0_pixel_step must be in 1..4");
  if (!(max_translation_update_m > 0 && max_rotation_update_deg > 0))
    return fail("max_translation_update_m and max_rotation_update_deg must be positive");
  if (min_inliers < 0) return fail("min_inliers must be >= 0");
  if (!(min_inlier_fraction >= 0 && min_inlier_fraction <= good_inlier_fraction &&
        good_inlier_fraction <= 1))
    return fail("need 0 <= min_inlier_fraction <= good_inlier_fraction <= 1");
  if (!(good_icp_rms_m > 0 && good_icp_rms_m <= max_icp_rms_m))
    return fail("need 0 < good_icp_rms_m <= max_icp_rms_m");
  if (max_bad_frames < 0) return fail("max_bad_frames must be >= 0");
  if (!(consistency_tolerance_m > 0 && consistency_tolerance_per_m >= 0 &&
        consistency_noise_sigmas >= 0))
    return fail(
        "consistency_tolerance_m must be positive, consistency_tolerance_per_m and "
        "consistency_noise_sigmas >= 0");
  if (!(good_in_front_fraction >= 0 && good_in_front_fraction <= max_in_front_fraction &&
        max_in_front_fraction <= 1))
    return fail("need 0 <= good_in_front_fraction <= max_in_front_fraction <= 1");
  if (!(min_consistent_fraction >= 0 && min_consistent_fraction <= good_consistent_fraction &&
        good_consistent_fraction <= 1))
    return fail("need 0 <= min_consistent_fraction <= good_consistent_fraction <= 1");
  if (!(min_overlap_fraction >= 0 && min_overlap_fraction <= good_overlap_fraction &&
        good_overlap_fraction <= 1))
    return fail("need 0 <= min_overlap_fraction <= good_overlap_fraction <= 1");
  if (!(max_final_step > 0)) return fail("max_final_step must be positive");
  return true;
}

void photometric_edge_mask(const DepthImage& depth, int margin_px, float jump_m, float jump_per_m,
                           float pixel_scale, MaskImage* out) {
  const int W = depth.width(), H = depth.height();
  ensure_size(*out, W, H);
  // Seeds (0): pixels without depth and pixels with a neighbour across a depth discontinuity.
#pragma omp parallel for schedule(static)
  for (int y = 0; y < H; ++y) {
    for (int x = 0; x < W; ++x) {
      const float z = depth.at(x, y);
      bool seed = !(z > 0.0f);
      const float jump = jump_m + jump_per_m * z * pixel_scale;
      for (int dy = -1; dy <= 1 && !seed; ++dy)
        for (int dx = -1; dx <= 1 && !seed; ++dx) {
          const int u = x + dx, v = y + dy;
          if (u < 0 || v < 0 || u >= W || v >= H) continue;
          const float zn = depth.at(u, v);
          seed = !(zn > 0.0f) || std::fabs(zn - z) > jump;
        }
      out->at(x, y) = seed ? 0 : 1;
    }
  }
  if (margin_px <= 0) return;
  // Erode the usable pixels by the margin (a min filter, rows then columns: Chebyshev distance).
  MaskImage rows(W, H);
#pragma omp parallel for schedule(static)
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      std::uint8_t m = 1;
      for (int u = std::max(0, x - margin_px); u <= std::min(W - 1, x + margin_px) && m; ++u)
        m = out->at(u, y);
      rows.at(x, y) = m;
    }
#pragma omp parallel for schedule(static)
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      std::uint8_t m = 1;
      for (int v = std::max(0, y - margin_px); v <= std::min(H - 1, y + margin_px) && m; ++v)
        m = rows.at(x, v);
      out->at(x, y) = m;
    }
}

void build_model_pyramid(const RenderedView& view, const PinholeIntrinsics& K, int levels,
                         float max_depth_jump_m, ModelPyramid* out, int first_level) {
  out->levels.resize(static_cast<size_t>(std::max(1, levels)));
  out->first_level = first_level;
  ModelLevel& L0 = out->levels[0];
  L0.K = K;
  L0.depth = view.depth;
  L0.vertex = view.vertex;
  L0.normal = view.normal;
  L0.color_point = view.surfel_centre;
  color_to_intensity(view.color, &L0.intensity);
  for (int l = 1; l < levels; ++l) {
    const ModelLevel& P = out->levels[static_cast<size_t>(l - 1)];
    ModelLevel& C = out->levels[static_cast<size_t>(l)];
    C.K = K.scaled(l);
    const int w = P.depth.width() / 2, h = P.depth.height() / 2;
    ensure_size(C.depth, w, h);
    ensure_size(C.normal, w, h);
    ensure_size(C.intensity, w, h);
    ensure_size(C.color_point, w, h);
#pragma omp parallel for schedule(static)
    for (int v = 0; v < h; ++v) {
      for (int u = 0; u < w; ++u) {
        float ref = 0.0f, zsum = 0.0f, isum = 0.0f;
        Vec3f nsum = Vec3f::Zero(), csum = Vec3f::Zero();
        int n = 0;
        for (int k = 0; k < 4; ++k) {
          const int x = 2 * u + (k & 1), y = 2 * v + (k >> 1);
          const float z = P.depth.at(x, y);
          if (z <= 0.0f) continue;
          if (ref == 0.0f) ref = z;
          if (std::fabs(z - ref) > max_depth_jump_m) continue;
          zsum += z;
          isum += P.intensity.at(x, y);
          nsum += P.normal.at(x, y);
          csum += P.color_point.at(x, y);
          ++n;
        }
        const float len = nsum.norm();
        if (n == 0 || !(len > 1e-3f)) {
          C.depth.at(u, v) = 0.0f;
          C.normal.at(u, v).setZero();
          C.intensity.at(u, v) = 0.0f;
          C.color_point.at(u, v).setZero();
          continue;
        }
        C.depth.at(u, v) = zsum / static_cast<float>(n);
        C.intensity.at(u, v) = isum / static_cast<float>(n);
        C.normal.at(u, v) = nsum / len;
        C.color_point.at(u, v) = csum / static_cast<float>(n);
      }
    }
    compute_vertex_map(C.depth, C.K, &C.vertex);
  }
}

DepthConsistency depth_consistency(const FrameLevel& live, const ModelLevel& model,
                                   const SE3& T_ref_cam, double tolerance_m, double tolerance_per_m,
                                   int pixel_step, double noise_sigmas) {
  const RigidF T(T_ref_cam);
  const int W = live.depth.width(), H = live.depth.height();
  const int MW = model.depth.width(), MH = model.depth.height();
  const float fx = static_cast<float>(model.K.fx), fy = static_cast<float>(model.K.fy);
  const float cx = static_cast<float>(model.K.cx), cy = static_cast<float>(model.K.cy);
  const float tol0 = static_cast<float>(tolerance_m), tol1 = static_cast<float>(tolerance_per_m);
  const float k_sigma = static_cast<float>(noise_sigmas);
  const int step = std::max(1, pixel_step);
  int n_live = 0, n_overlap = 0, n_consistent = 0, n_front = 0, n_behind = 0;
#pragma omp parallel for schedule(static) reduction(+ : n_live, n_overlap, n_consistent, n_front, n_behind)
  for (int v = 0; v < H; v += step) {
    const Vec3f* vrow = live.vertex.row(v);
    for (int u = 0; u < W; u += step) {
      const Vec3f& x = vrow[u];
      if (x.z() <= 0.0f) continue;
      ++n_live;
      const Vec3f q = T(x);
      if (q.z() <= 0.0f) continue;
      const int mu = static_cast<int>(std::floor(fx * q.x() / q.z() + cx + 0.5f));
      const int mv = static_cast<int>(std::floor(fy * q.y() / q.z() + cy + 0.5f));
      if (mu < 0 || mv < 0 || mu >= MW || mv >= MH) continue;
      const float zm = model.depth.at(mu, mv);
      if (zm <= 0.0f) continue;
      ++n_overlap;
      const float dz = q.z() - zm;
      const float sigma =
          0.0012f + 0.0019f * (zm - 0.4f) * (zm - 0.4f);  // Kinect axial noise (Nguyen 2012)
      const float tol = std::max(tol0 + tol1 * zm, k_sigma * sigma);
      if (dz > tol)
        ++n_behind;
      else if (dz < -tol)
        ++n_front;
      else
        ++n_consistent;
    }
  }
  return {n_live, n_overlap, n_consistent, n_front, n_behind};
}

Tracker::Tracker(const TrackerParams& params) : params_(params) {
  std::string why;
  if (!params_.IsValid(&why)) throw ConfigError("slam_tracking: " + why);
}

NormalEquations Tracker::icp_step(const FrameLevel& live, const ModelLevel& model,
                                  const SE3& T_ref_cam, int pixel_step) const {
  const RigidF T(T_ref_cam);
  const int W = live.depth.width(), H = live.depth.height();
  const int MW = model.depth.width(), MH = model.depth.height();
  const float fx = static_cast<float>(model.K.fx), fy = static_cast<float>(model.K.fy);
  const float cx = static_cast<float>(model.K.cx), cy = static_cast<float>(model.K.cy);
  const float max_d2 = static_cast<float>(params_.icp_max_dist_m * params_.icp_max_dist_m);
  const float min_cos = static_cast<float>(std::cos(params_.icp_max_angle_deg * M_PI / 180.0));
  const float icp_huber = static_cast<float>(params_.icp_huber_m);
  const int step = std::max(1, pixel_step);
  const int rows = (H + step - 1) / step;
  std::vector<RowSums> sums(static_cast<size_t>(rows));

#pragma omp parallel for schedule(static)
  for (int ri = 0; ri < rows; ++ri) {
    const int v = ri * step;
    float a[21] = {}, b[6] = {}, ss = 0.0f;
    int count = 0, overlap = 0;
    const Vec3f* vrow = live.vertex.row(v);
    const Vec3f* nrow = live.normal.row(v);
    for (int u = 0; u < W; u += step) {
      const Vec3f& x = vrow[u];
      if (x.z() <= 0.0f) continue;
      const Vec3f& nl = nrow[u];
      if (nl.z() == 0.0f && nl.x() == 0.0f && nl.y() == 0.0f) continue;
      const Vec3f q = T(x);
      if (q.z() <= 0.0f) continue;
      const int mu = static_cast<int>(std::floor(fx * q.x() / q.z() + cx + 0.5f));
      const int mv = static_cast<int>(std::floor(fy * q.y() / q.z() + cy + 0.5f));
      if (mu < 0 || mv < 0 || mu >= MW || mv >= MH) continue;
      const Vec3f& vm = model.vertex.at(mu, mv);
      if (vm.z() <= 0.0f) continue;
      const Vec3f& nm = model.normal.at(mu, mv);
      if (nm.squaredNorm() < 0.5f) continue;
      ++overlap;
      const Vec3f diff = q - vm;
      if (diff.squaredNorm() > max_d2) continue;
      if (T.rotate(nl).dot(nm) < min_cos) continue;
      const float r = nm.dot(diff);
      const Vec3f qxn = q.cross(nm);
      const float J[6] = {nm.x(), nm.y(), nm.z(), qxn.x(), qxn.y(), qxn.z()};
      accumulate(a, b, J, r, huber_weight(r, icp_huber));
      ss += r * r;
      ++count;
    }
    sums[static_cast<size_t>(ri)].set(a, b, ss, count, overlap);
  }
  return reduce(sums);
}

NormalEquations Tracker::rgb_step(const FrameLevel& live, const ModelLevel& model,
                                  const SE3& T_ref_cam, float min_gradient, int pixel_step,
                                  float huber_delta, const MaskImage* usable,
                                  float prior_gain) const {
  const RigidF T_cam_ref(T_ref_cam.inverse());
  const int W = live.depth.width(), H = live.depth.height();
  const int MW = model.depth.width(), MH = model.depth.height();
  const float fx = static_cast<float>(live.K.fx), fy = static_cast<float>(live.K.fy);
  const float cx = static_cast<float>(live.K.cx), cy = static_cast<float>(live.K.cy);
  const float max_dz = static_cast<float>(params_.rgb_max_depth_diff_m);
  const float max_z = static_cast<float>(params_.rgb_max_depth_m);
  const float min_g2 = min_gradient * min_gradient;
  const float rgb_huber = huber_delta;
  const int step = std::max(1, pixel_step);
  const int rows = (MH + step - 1) / step;
  std::vector<RowSums> sums(static_cast<size_t>(rows));
  std::vector<GainRowSums> gain_sums(static_cast<size_t>(rows));

#pragma omp parallel for schedule(static)
  for (int ri = 0; ri < rows; ++ri) {
    const int y = ri * step;
    float a[21] = {}, b[6] = {}, ss = 0.0f;
    float bl[6] = {}, rl = 0.0f, ll = 0.0f, rl_u = 0.0f, ll_u = 0.0f;
    int count = 0;
    const Vec3f* vrow = model.color_point.row(y);
    const float* irow = model.intensity.row(y);
    const std::uint8_t* urow = usable ? usable->row(y) : nullptr;
    for (int x = 0; x < MW; x += step) {
      if (urow && !urow[x]) continue;
      const Vec3f& vm = vrow[x];
      if (vm.z() <= 0.0f || vm.z() > max_z) continue;
      const Vec3f p = T_cam_ref(vm);
      if (p.z() <= 0.0f) continue;
      const float iz = 1.0f / p.z();
      const float u = fx * p.x() * iz + cx, v = fy * p.y() * iz + cy;
      if (!(u >= 0.0f && v >= 0.0f && u < static_cast<float>(W - 1) &&
            v < static_cast<float>(H - 1)))
        continue;
      const int ui = static_cast<int>(u + 0.5f), vi = static_cast<int>(v + 0.5f);
      const float dl = live.depth.at(ui, vi);
      if (dl <= 0.0f || std::fabs(dl - p.z()) > max_dz) continue;
      // Gradients at the same sub-pixel point as the (bilinear) residual. With the nearest pixel's
      // gradients the Jacobian no longer matches the residual, and Gauss-Newton converges to where
      // J~^T r = 0 instead of the least-squares minimum: a bias of ~1 cm on the 160x120 test
      // sequence.
      const float gu = bilinear(live.grad_u, u, v), gv = bilinear(live.grad_v, u, v);
      if (gu * gu + gv * gv < min_g2) continue;
      const float il = bilinear(live.intensity, u, v);
      const float r = il - irow[x];
      // d r / d p = grad . d project / d p
      const Vec3f dp(gu * fx * iz, gv * fy * iz, -(gu * fx * p.x() + gv * fy * p.y()) * iz * iz);
      const Vec3f c = T_cam_ref.rotate_inverse(dp);
      const Vec3f cxv = c.cross(vm);
      const float J[6] = {-c.x(), -c.y(), -c.z(), cxv.x(), cxv.y(), cxv.z()};
      const float w = huber_weight(prior_gain * il - irow[x], rgb_huber);
      accumulate(a, b, J, r, w);
      for (int k = 0; k < 6; ++k) bl[k] += w * J[k] * il;
      rl += w * r * il;
      ll += w * il * il;
      rl_u += r * il;
      ll_u += il * il;
      ss += r * r;
      ++count;
    }
    sums[static_cast<size_t>(ri)].set(a, b, ss, count, 0);
    GainRowSums& g = gain_sums[static_cast<size_t>(ri)];
    for (int k = 0; k < 6; ++k) g.bl[k] = bl[k];
    g.rl = rl, g.ll = ll, g.rl_u = rl_u, g.ll_u = ll_u;
  }
  NormalEquations ne = reduce(sums);
  if (params_.rgb_estimate_gain) solve_gain(gain_sums, ne);
  return ne;
}

AlignmentResult Tracker::align(const FramePyramid& live, const ModelPyramid& model,
                               const SE3& T_ref_cam_init) const {
  AlignmentResult res;
  LastTerms last;
  bool numerically_failed = false;
  res.T_ref_cam = iterate(live, model, T_ref_cam_init, res, last, &numerically_failed);
  const SE3& T = res.T_ref_cam;
  if (params_.use_icp) {
    res.icp_inliers = last.icp.count;
    res.icp_overlap = last.icp.overlap;
    res.icp_rms_m = last.icp.count > 0 ? std::sqrt(last.icp.sum_sq / last.icp.count) : 0.0;
    if (last.icp.count > 0) {
      const Eigen::SelfAdjointEigenSolver<Mat6> es(last.icp.A / last.icp.count,
                                                   Eigen::EigenvaluesOnly);
      res.min_eigenvalue = es.eigenvalues()(0);
    }
  }
  if (params_.use_rgb) {
    res.rgb_count = last.rgb.count;
    res.rgb_rms = last.rgb.count > 0 ? std::sqrt(last.rgb.sum_sq / last.rgb.count) : 0.0;
    res.rgb_gain = last.rgb.gain;
  }
  const int step = std::max(2, params_.level0_pixel_step);
  const DepthConsistency dc = depth_consistency(
      live.levels[0], model.levels[0], T, params_.consistency_tolerance_m,
      params_.consistency_tolerance_per_m, step, params_.consistency_noise_sigmas);
  res.overlap_fraction = dc.live > 0 ? double(dc.overlap) / dc.live : 0.0;
  res.consistent_fraction = dc.overlap > 0 ? double(dc.consistent) / dc.overlap : 0.0;
  res.in_front_fraction = dc.overlap > 0 ? double(dc.in_front) / dc.overlap : 0.0;
  res.behind_fraction = dc.overlap > 0 ? double(dc.behind) / dc.overlap : 0.0;
  apply_quality_gates(live.levels[0].K, T_ref_cam_init.inverse() * T, numerically_failed, res);
  return res;
}

SE3 Tracker::iterate(const FramePyramid& live, const ModelPyramid& model, const SE3& T_init,
                     AlignmentResult& res, LastTerms& last, bool* numerically_failed) const {
  SE3 T = T_init;
  const int levels = static_cast<int>(
      std::min(live.levels.size(), model.levels.size() + static_cast<size_t>(model.first_level)));
  float rgb_sigma = 0.0f;  // RMS photometric residual of the previous iteration (0: none yet)
  float rgb_gain = 1.0f;   // brightness gain of the previous iteration (Huber weights only)
  for (int level = levels - 1; level >= 0 && !*numerically_failed; --level) {
    const FrameLevel& L = live.levels[static_cast<size_t>(level)];
    const int model_level = std::max(0, level - model.first_level);
    const ModelLevel& M = model.levels[static_cast<size_t>(model_level)];
    // Reference pixels near depth discontinuities are left out of the photometric term at full
    // resolution, where the estimate is settled (coarser levels only bring it into the basin, and
    // at their coarse pixels the margin would take too much of a cluttered view away).
    MaskImage usable;
    const bool edge_mask = params_.use_rgb && params_.rgb_edge_margin_px > 0 && level == 0;
    if (edge_mask)
      photometric_edge_mask(M.depth, params_.rgb_edge_margin_px,
                            static_cast<float>(params_.rgb_edge_jump_m),
                            static_cast<float>(params_.rgb_edge_jump_per_m),
                            static_cast<float>(1 << (model_level + model.first_level)), &usable);
    const LevelInputs in{L, M, level, model.first_level, edge_mask ? &usable : nullptr};
    const int iters = iterations_for_level(params_, level);
    Vec6 prev_xi = Vec6::Zero();
    for (int it = 0; it < iters; ++it) {
      ++res.iterations;
      Vec6 xi;
      if (!gauss_newton_step(in, T, last, rgb_sigma, rgb_gain, &xi, &res.reason)) {
        *numerically_failed = true;
        break;
      }
      // A step that mostly undoes the previous one is a limit cycle of the data association (the
      // projective correspondences flip between two sets): take half of it, which lands between
      // the two poses of the cycle instead of jumping back.
      if (it > 0 && xi.dot(prev_xi) < -0.5 * xi.norm() * prev_xi.norm()) xi *= 0.5;
      prev_xi = xi;
      T = SE3::exp(xi) * T;
      if (level == 0) res.final_step = xi.norm();
      if (xi.norm() < params_.convergence_step) {
        if (level == 0) res.converged = true;
        break;
      }
    }
  }
  return T;
}

bool Tracker::gauss_newton_step(const LevelInputs& in, const SE3& T, LastTerms& last,
                                float& rgb_sigma, float& rgb_gain, Vec6* xi,
                                std::string* why) const {
  const int step = in.level == 0 ? params_.level0_pixel_step : 1;
  // The photometric loop runs over model pixels: sparser already when the model is coarser.
  const int rgb_step_px =
      (in.level == 0 && in.model_first_level == 0) ? params_.level0_pixel_step : 1;
  const double w2 = params_.icp_weight * params_.icp_weight;
  Mat6 A = Mat6::Zero();
  Vec6 b = Vec6::Zero();
  if (params_.use_icp) {
    last.icp = icp_step(in.live, in.model, T, step);
    A += w2 * last.icp.A;
    b += w2 * last.icp.b;
  }
  if (params_.use_rgb) {
    const float delta = static_cast<float>(params_.rgb_huber_sigmas) * rgb_sigma;
    last.rgb = rgb_step(in.live, in.model, T, gradient_for_level(params_, in.level), rgb_step_px,
                        delta, in.usable, rgb_gain);
    rgb_gain = static_cast<float>(last.rgb.gain);
    if (last.rgb.count > 0) {
      const double sigma2 = std::max(last.rgb.sum_sq / last.rgb.count, 1.0);
      rgb_sigma = static_cast<float>(std::sqrt(sigma2));
      A += last.rgb.A / sigma2;
      b += last.rgb.b / sigma2;
    }
  }
  if ((params_.use_icp ? last.icp.count : 0) + (params_.use_rgb ? last.rgb.count : 0) < 6) {
    *why = "no correspondences at level " + std::to_string(in.level);
    return false;
  }
  // Levenberg-style tiny damping keeps a degenerate direction from exploding.
  A.diagonal().array() += 1e-9 * A.diagonal().maxCoeff() + 1e-12;
  const Eigen::LDLT<Mat6> ldlt(A);
  if (ldlt.info() != Eigen::Success) {
    *why = "singular normal equations";
    return false;
  }
  *xi = ldlt.solve(-b);
  if (!xi->allFinite()) {
    *why = "non-finite update";
    return false;
  }
  return true;
}

void Tracker::apply_quality_gates(const PinholeIntrinsics& K0, const SE3& motion,
                                  bool numerically_failed, AlignmentResult& res) const {
  const int step0 = params_.level0_pixel_step;
  const double area = static_cast<double>(K0.width) * K0.height / (640.0 * 480.0) / (step0 * step0);
  const double inlier_fraction =
      res.icp_overlap > 0 ? double(res.icp_inliers) / res.icp_overlap : 0.0;
  if (numerically_failed) {
    res.failed = true;
  } else if (motion.translation().norm() > params_.max_translation_update_m) {
    res.failed = true;
    res.reason =
        "translation update " + std::to_string(motion.translation().norm()) + " m too large";
  } else if (motion.rotation_angle_deg() > params_.max_rotation_update_deg) {
    res.failed = true;
    res.reason =
        "rotation update " + std::to_string(motion.rotation_angle_deg()) + " deg too large";
  } else if (params_.use_icp && res.icp_inliers < params_.min_inliers * area) {
    res.failed = true;
    res.reason = "too few ICP inliers (" + std::to_string(res.icp_inliers) + ")";
  } else if (params_.use_icp && inlier_fraction < params_.min_inlier_fraction) {
    res.failed = true;
    res.reason = "inlier fraction " + std::to_string(inlier_fraction) + " too low";
  } else if (params_.use_icp && res.icp_rms_m > params_.max_icp_rms_m) {
    res.failed = true;
    res.reason = "ICP RMS " + std::to_string(res.icp_rms_m) + " m too high";
  } else if (res.overlap_fraction < params_.min_overlap_fraction) {
    res.failed = true;
    res.reason = fmt::format("only {:.2f} of the frame overlaps the map", res.overlap_fraction);
  } else if (res.in_front_fraction > params_.max_in_front_fraction) {
    res.failed = true;
    res.reason = fmt::format(
        "{:.3f} of the overlap lies in front of the map's surfaces (seen as free space)",
        res.in_front_fraction);
  } else if (res.consistent_fraction < params_.min_consistent_fraction) {
    res.failed = true;
    res.reason = fmt::format("depth agrees with the map at only {:.2f} of the overlap",
                             res.consistent_fraction);
  } else if (params_.use_icp && inlier_fraction < params_.good_inlier_fraction) {
    res.weak = true;
    res.reason = "low inlier fraction " + std::to_string(inlier_fraction);
  } else if (params_.use_icp && res.icp_rms_m > params_.good_icp_rms_m) {
    res.weak = true;
    res.reason = "high ICP RMS " + std::to_string(res.icp_rms_m) + " m";
  } else if (params_.use_icp && res.min_eigenvalue < params_.min_hessian_eigenvalue) {
    res.weak = true;
    res.reason = "degenerate geometry (eigenvalue " + std::to_string(res.min_eigenvalue) + ")";
  } else if (res.overlap_fraction < params_.good_overlap_fraction) {
    res.weak = true;
    res.reason = fmt::format("low overlap with the map {:.2f}", res.overlap_fraction);
  } else if (res.in_front_fraction > params_.good_in_front_fraction) {
    res.weak = true;
    res.reason = fmt::format("{:.3f} of the overlap lies in front of the map's surfaces",
                             res.in_front_fraction);
  } else if (res.consistent_fraction < params_.good_consistent_fraction) {
    res.weak = true;
    res.reason =
        fmt::format("depth agrees with the map at {:.2f} of the overlap", res.consistent_fraction);
  } else if (res.final_step > params_.max_final_step) {
    res.weak = true;
    res.reason = fmt::format("not converged (last step {:.2g})", res.final_step);
  }
}

}  // namespace orpe::slam
