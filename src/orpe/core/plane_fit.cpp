#include "orpe/core/plane_fit.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

namespace orpe {

namespace {

/// Mean and covariance (sum of outer products / n) of points.
Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> principal_axes(
    const std::vector<Eigen::Vector3f>& pts, Eigen::Vector3d* mean) {
  *mean = Eigen::Vector3d::Zero();
  for (const auto& p : pts) *mean += p.cast<double>();
  *mean /= static_cast<double>(std::max<size_t>(1, pts.size()));
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : pts) {
    const Eigen::Vector3d q = p.cast<double>() - *mean;
    cov += q * q.transpose();
  }
  cov /= static_cast<double>(std::max<size_t>(1, pts.size()));
  return Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov);
}

/// 4 sigma along the smaller in-plane principal axis (plane_extent).
float extent_of(const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>& es) {
  return static_cast<float>(4.0 * std::sqrt(std::max(0.0, es.eigenvalues()(1))));
}

}  // namespace

Plane fit_plane(const std::vector<Eigen::Vector3f>& points, float* extent) {
  Eigen::Vector3d mean;
  const auto es = principal_axes(points, &mean);
  if (extent) *extent = extent_of(es);
  Eigen::Vector3d n = es.eigenvectors().col(0);
  double d = -n.dot(mean);
  if (d < 0) {
    n = -n;
    d = -d;
  }
  Plane pl;
  pl.normal = n.cast<float>();
  pl.d = static_cast<float>(d);
  return pl;
}

float plane_extent(const std::vector<Eigen::Vector3f>& points) {
  Eigen::Vector3d mean;
  return extent_of(principal_axes(points, &mean));
}

bool find_large_plane(const std::vector<Eigen::Vector3f>& points,
                      const std::vector<std::int32_t>& candidates, const PlaneSearchParams& params,
                      std::mt19937& rng, Plane* out) {
  if (candidates.size() < 3) return false;
  const float tol = static_cast<float>(params.distance_m);
  const size_t step =
      std::max<size_t>(1, candidates.size() / std::max<size_t>(1, params.max_scored));
  // The scored subset, gathered once: the candidates are scattered over a large point array, and
  // every hypothesis reads all of it.
  std::vector<Eigen::Vector3f> scored;
  scored.reserve(candidates.size() / step + 1);
  for (size_t k = 0; k < candidates.size(); k += step) scored.push_back(points[candidates[k]]);
  std::uniform_int_distribution<size_t> pick(0, candidates.size() - 1);
  size_t best_count = 0;
  Plane best;
  for (int it = 0; it < params.iterations; ++it) {
    const Eigen::Vector3f& a = points[candidates[pick(rng)]];
    const Eigen::Vector3f& b = points[candidates[pick(rng)]];
    const Eigen::Vector3f& c = points[candidates[pick(rng)]];
    Eigen::Vector3f n = (b - a).cross(c - a);
    if (n.norm() < 1e-6f) continue;
    n.normalize();
    const Plane pl{n, -n.dot(a)};
    size_t count = 0;
    for (const auto& p : scored) count += std::abs(pl.signed_distance(p)) < tol;
    if (count > best_count) {
      best_count = count;
      best = pl;
    }
  }
  if (best_count * step < params.min_inliers) return false;
  std::vector<Eigen::Vector3f> in;
  in.reserve(candidates.size());
  for (int r = 0; r < 2; ++r) {  // refine on the inliers, twice
    in.clear();
    for (const auto c : candidates)
      if (std::abs(best.signed_distance(points[c])) < tol) in.push_back(points[c]);
    if (in.size() < std::max<size_t>(3, params.min_inliers)) return false;
    float extent = 0;
    best = fit_plane(in, r == 1 ? &extent : nullptr);
    if (r == 1 && extent < params.min_extent_m) return false;
  }
  *out = best;
  return true;
}

}  // namespace orpe
