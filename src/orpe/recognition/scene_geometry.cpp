#include "orpe/recognition/scene_geometry.h"

#include <spdlog/spdlog.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <random>

namespace orpe {

bool SceneGeometryParams::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (grid_stride_px < 1 || grid_stride_px > 8) return fail("grid_stride_px must be in [1, 8]");
  if (!(min_depth_m >= 0 && max_depth_m > min_depth_m))
    return fail("need 0 <= min_depth_m < max_depth_m");
  if (max_planes < 0 || max_planes > 10) return fail("max_planes must be in [0, 10]");
  if (!(plane_distance_m > 0)) return fail("plane_distance_m must be > 0");
  if (!(min_plane_fraction > 0 && min_plane_fraction <= 1))
    return fail("min_plane_fraction must be in (0, 1]");
  if (!(min_plane_extent_m >= 0)) return fail("min_plane_extent_m must be >= 0");
  if (plane_iterations < 1) return fail("plane_iterations must be >= 1");
  if (!(max_seen_below_fraction >= 0 && max_seen_below_fraction <= 1))
    return fail("max_seen_below_fraction must be in [0, 1]");
  if (!(max_height_above_plane_m >= 0)) return fail("max_height_above_plane_m must be >= 0");
  if (!(region_distance_m > 0) || !(region_distance_per_m >= 0))
    return fail("region_distance_m must be > 0 and region_distance_per_m >= 0");
  if (min_region_points < 1) return fail("min_region_points must be >= 1");
  if (small_region_min_points < 1 || small_region_min_points > min_region_points)
    return fail("small_region_min_points must be in [1, min_region_points]");
  if (!(min_region_area_m2 >= 0)) return fail("min_region_area_m2 must be >= 0");
  if (!(concave_edge_min_angle_deg >= 0 && concave_edge_min_angle_deg < 180))
    return fail("concave_edge_min_angle_deg must be in [0, 180)");
  if (concave_edge_radius_cells < 1 || concave_edge_radius_cells > 10)
    return fail("concave_edge_radius_cells must be in [1, 10]");
  return true;
}

SceneGrid make_scene_grid(const DepthImage& depth, const PinholeIntrinsics& K,
                          const SceneGeometryParams& params) {
  SceneGrid g;
  g.stride = params.grid_stride_px;
  g.fx = K.fx;
  g.fy = K.fy;
  g.width = (depth.width() + g.stride - 1) / g.stride;
  g.height = (depth.height() + g.stride - 1) / g.stride;
  const size_t n = static_cast<size_t>(g.width) * g.height;
  g.points.assign(n, Eigen::Vector3f::Zero());
  g.valid.assign(n, 0);
  g.region.assign(n, -1);
  for (int gv = 0; gv < g.height; ++gv)
    for (int gu = 0; gu < g.width; ++gu) {
      const int u = gu * g.stride, v = gv * g.stride;
      const float z = depth.at(u, v);
      if (!(z >= params.min_depth_m && z <= params.max_depth_m)) continue;
      const int c = g.cell(gu, gv);
      g.points[c] = K.backproject(u, v, z).cast<float>();
      g.valid[c] = 1;
    }
  g.kept = g.valid;
  return g;
}

double seen_area_m2(const SceneGrid& g, const std::vector<int>& cells) {
  const double per_z2 = static_cast<double>(g.stride) * g.stride / (g.fx * g.fy);
  double sum_z2 = 0;
  for (int c : cells) sum_z2 += static_cast<double>(g.points[c].z()) * g.points[c].z();
  return sum_z2 * per_z2;
}

bool region_large_enough(const SceneGrid& g, const std::vector<int>& cells,
                         const SceneGeometryParams& params) {
  const int n = static_cast<int>(cells.size());
  if (n >= params.min_region_points) return true;
  if (n < params.small_region_min_points || !(params.min_region_area_m2 > 0)) return false;
  return seen_area_m2(g, cells) >= params.min_region_area_m2;
}

namespace {

/// Fraction of the observed surface over a plane's inliers (their convex hull in the plane,
/// looking along the normal) that lies below the plane: 0 for a support, which hides what is below
/// it; large for the coplanar tops of objects of one height, between which the support they stand
/// on is seen.
double seen_below_fraction(const SceneGrid& g, const Plane& pl, const std::vector<int>& inliers,
                           float tol) {
  const Eigen::Vector3f e1 = pl.normal.unitOrthogonal(), e2 = pl.normal.cross(e1);
  std::vector<cv::Point2f> in2;
  in2.reserve(inliers.size());
  for (int c : inliers) in2.emplace_back(e1.dot(g.points[c]), e2.dot(g.points[c]));
  std::vector<cv::Point2f> hull;
  cv::convexHull(in2, hull);
  if (hull.size() < 3) return 1.0;
  size_t below = 0;
  for (size_t c = 0; c < g.valid.size(); ++c) {
    if (!g.valid[c] || pl.signed_distance(g.points[c]) > -tol) continue;
    const cv::Point2f q(e1.dot(g.points[c]), e2.dot(g.points[c]));
    below += cv::pointPolygonTest(hull, q, false) >= 0;
  }
  return static_cast<double>(below) / static_cast<double>(below + inliers.size());
}

/// Best RANSAC plane over the candidate cells; false when none qualifies.
bool find_plane(const SceneGrid& g, const std::vector<int>& cells,
                const SceneGeometryParams& params, std::mt19937& rng, size_t min_inliers,
                Plane* out) {
  if (cells.size() < 3) return false;
  const float tol = static_cast<float>(params.plane_distance_m);
  // Score on a strided subset for speed.
  const size_t step = std::max<size_t>(1, cells.size() / 4000);
  std::uniform_int_distribution<size_t> pick(0, cells.size() - 1);
  size_t best_count = 0;
  Plane best;
  for (int it = 0; it < params.plane_iterations; ++it) {
    const Eigen::Vector3f& a = g.points[cells[pick(rng)]];
    const Eigen::Vector3f& b = g.points[cells[pick(rng)]];
    const Eigen::Vector3f& c = g.points[cells[pick(rng)]];
    Eigen::Vector3f n = (b - a).cross(c - a);
    if (n.norm() < 1e-6f) continue;
    n.normalize();
    Plane pl{n, -n.dot(a)};
    size_t count = 0;
    for (size_t k = 0; k < cells.size(); k += step)
      count += std::abs(pl.signed_distance(g.points[cells[k]])) < tol;
    if (count > best_count) {
      best_count = count;
      best = pl;
    }
  }
  if (best_count * step < min_inliers) return false;
  // Refine on the inliers, twice; then the size, spread and occlusion tests of a support.
  std::vector<int> in_cells;
  for (int r = 0; r < 2; ++r) {
    in_cells.clear();
    for (int c : cells)
      if (std::abs(best.signed_distance(g.points[c])) < tol) in_cells.push_back(c);
    if (in_cells.size() < min_inliers) return false;
    std::vector<Eigen::Vector3f> in;
    in.reserve(in_cells.size());
    for (int c : in_cells) in.push_back(g.points[c]);
    best = fit_plane(in);
    if (r == 1 && plane_extent(in) < params.min_plane_extent_m) return false;
  }
  if (params.max_seen_below_fraction < 1) {
    const double below = seen_below_fraction(g, best, in_cells, tol);
    spdlog::debug(
        "recognition: plane candidate d {:.3f}: {} inliers, {:.2f} of its hull seen below it",
        best.d, in_cells.size(), below);
    if (below > params.max_seen_below_fraction) return false;
  }
  *out = best;
  return true;
}

}  // namespace

void remove_support_planes(SceneGrid& g, const SceneGeometryParams& params) {
  std::mt19937 rng(static_cast<unsigned>(params.seed));
  size_t valid = 0;
  for (auto v : g.valid) valid += v;
  const size_t min_inliers = std::max<size_t>(
      3, static_cast<size_t>(params.min_plane_fraction * static_cast<double>(valid)));
  const float tol = static_cast<float>(params.plane_distance_m);
  for (int k = 0; k < params.max_planes; ++k) {
    std::vector<int> cells;
    for (size_t c = 0; c < g.kept.size(); ++c)
      if (g.kept[c]) cells.push_back(static_cast<int>(c));
    Plane pl;
    if (!find_plane(g, cells, params, rng, min_inliers, &pl)) break;
    // Remove the plane's points and what lies behind it (below a table, behind a wall: what the
    // sensor sees there is not on the support).
    const bool first = g.planes.empty();
    for (int c : cells) {
      const float s = pl.signed_distance(g.points[c]);
      if (s < tol) g.kept[c] = 0;
      if (first && params.max_height_above_plane_m > 0 && s > params.max_height_above_plane_m)
        g.kept[c] = 0;
    }
    spdlog::debug("recognition: support plane {}: normal ({:.2f} {:.2f} {:.2f}) d {:.3f}", k,
                  pl.normal.x(), pl.normal.y(), pl.normal.z(), pl.d);
    g.planes.push_back(pl);
  }
}

GridNormals::GridNormals(const SceneGrid& g, int radius)
    : g_(g), r_(radius), n_(g.points.size()), done_(g.points.size(), 0) {}

const Eigen::Vector3f& GridNormals::at(int c) {
  if (!done_[c]) {
    n_[c] = fit(c);
    done_[c] = 1;
  }
  return n_[c];
}

Eigen::Vector3f GridNormals::fit(int c) const {
  const int gu = c % g_.width, gv = c / g_.width;
  const Eigen::Vector3f& p = g_.points[c];
  Eigen::Matrix3f cov = Eigen::Matrix3f::Zero();
  Eigen::Vector3f sum = Eigen::Vector3f::Zero();
  int n = 0;
  for (int v = std::max(0, gv - r_); v <= std::min(g_.height - 1, gv + r_); ++v)
    for (int u = std::max(0, gu - r_); u <= std::min(g_.width - 1, gu + r_); ++u) {
      const int k = g_.cell(u, v);
      if (!g_.kept[k] || std::abs(g_.points[k].z() - p.z()) > 0.01f) continue;
      sum += g_.points[k];
      cov += g_.points[k] * g_.points[k].transpose();
      ++n;
    }
  if (n < 6) return Eigen::Vector3f::Zero();
  const Eigen::Vector3f mean = sum / static_cast<float>(n);
  cov = cov / static_cast<float>(n) - mean * mean.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3f> es(cov);
  return es.eigenvectors().col(0).normalized();
}

bool concave_link(const SceneGrid& g, GridNormals& normals, int a, int du, int dv, int radius,
                  float min_cos) {
  const int au = a % g.width - radius * du, av = a / g.width - radius * dv;
  const int bu = a % g.width + (radius + 1) * du, bv = a / g.width + (radius + 1) * dv;
  if (au < 0 || av < 0 || bu < 0 || bv < 0 || au >= g.width || bu >= g.width || av >= g.height ||
      bv >= g.height)
    return false;
  const int ca = g.cell(au, av), cb = g.cell(bu, bv);
  if (!g.kept[ca] || !g.kept[cb]) return false;
  Eigen::Vector3f na = normals.at(ca), nb = normals.at(cb);
  if (na.isZero() || nb.isZero()) return false;
  if (na.dot(g.points[ca]) > 0) na = -na;
  if (nb.dot(g.points[cb]) > 0) nb = -nb;
  if (na.dot(nb) > min_cos) return false;
  const Eigen::Vector3f d = g.points[cb] - g.points[ca];
  return (na - nb).dot(d) > 0.25f * d.norm();
}

namespace {

/// Calls fn(n, du, dv) for each 4-neighbour n = c + (du, dv) of grid cell c inside the grid.
template <class F>
void for_each_neighbour(const SceneGrid& g, int c, F&& fn) {
  const int gu = c % g.width, gv = c / g.width;
  const int nb[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
  for (const auto& d : nb) {
    const int uu = gu + d[0], vv = gv + d[1];
    if (uu < 0 || vv < 0 || uu >= g.width || vv >= g.height) continue;
    fn(g.cell(uu, vv), d[0], d[1]);
  }
}

/// 4-connected components of the kept cells under `joined`.
std::vector<std::vector<int>> components(const SceneGrid& g,
                                         const std::function<bool(int, int, int, int)>& joined,
                                         std::vector<int>& label) {
  std::vector<std::vector<int>> comps;
  std::vector<int> stack;
  label.assign(g.kept.size(), -1);
  for (int start = 0; start < static_cast<int>(g.kept.size()); ++start) {
    if (!g.kept[start] || label[start] >= 0) continue;
    const int id = static_cast<int>(comps.size());
    comps.emplace_back();
    stack = {start};
    label[start] = id;
    while (!stack.empty()) {
      const int c = stack.back();
      stack.pop_back();
      comps[id].push_back(c);
      for_each_neighbour(g, c, [&](int n, int du, int dv) {
        if (label[n] >= 0 || !g.kept[n] || !joined(c, n, du, dv)) return;
        label[n] = id;
        stack.push_back(n);
      });
    }
  }
  return comps;
}

/// The cells of components under min_region_points (`owner` -1) join the large component they
/// touch under `near` (breadth first from every large component at once).
void grow_into_fragments(const SceneGrid& g, const std::vector<int>& label,
                         const std::vector<int>& owner, const std::function<bool(int, int)>& near,
                         std::vector<std::vector<int>>& comps) {
  std::vector<int> frontier;
  for (size_t c = 0; c < label.size(); ++c)
    if (label[c] >= 0 && owner[label[c]] >= 0) frontier.push_back(static_cast<int>(c));
  std::vector<int> assigned(label.size(), -1);
  for (int c : frontier) assigned[c] = owner[label[c]];
  while (!frontier.empty()) {
    std::vector<int> next;
    for (int c : frontier)
      for_each_neighbour(g, c, [&](int n, int, int) {
        if (!g.kept[n] || assigned[n] >= 0 || !near(c, n)) return;
        assigned[n] = assigned[c];
        comps[static_cast<size_t>(assigned[c])].push_back(n);
        next.push_back(n);
      });
    frontier = std::move(next);
  }
}

}  // namespace

std::vector<SceneRegion> split_regions(SceneGrid& g, const SceneGeometryParams& params) {
  std::fill(g.region.begin(), g.region.end(), -1);
  auto near = [&](int a, int b) {
    const float z = g.points[a].z();
    const float tol =
        static_cast<float>(params.region_distance_m + params.region_distance_per_m * z) *
        static_cast<float>(g.stride) * 0.5f;
    return (g.points[a] - g.points[b]).squaredNorm() < tol * tol;
  };
  const bool creases = params.concave_edge_min_angle_deg > 0;
  GridNormals normals(g, params.concave_edge_radius_cells);
  const float min_cos =
      static_cast<float>(std::cos(params.concave_edge_min_angle_deg * M_PI / 180));
  auto joined = [&](int a, int b, int du, int dv) {
    if (!near(a, b)) return false;
    if (!creases) return true;
    // The link a-b is tested in its own direction; (du, dv) points from a to b.
    return !concave_link(g, normals, a, du, dv, params.concave_edge_radius_cells, min_cos);
  };
  std::vector<int> label;
  std::vector<std::vector<int>> comps = components(g, joined, label);
  // Cells the crease cut left in small fragments join a large region they touch (depth rule).
  std::vector<int> owner(comps.size(), -1);
  for (size_t i = 0; i < comps.size(); ++i)
    if (region_large_enough(g, comps[i], params)) owner[i] = static_cast<int>(i);
  if (creases) grow_into_fragments(g, label, owner, near, comps);
  std::vector<SceneRegion> regions;
  for (size_t i = 0; i < comps.size(); ++i) {
    if (owner[i] < 0) continue;
    std::vector<int>& cells = comps[i];
    SceneRegion r;
    std::sort(cells.begin(), cells.end());
    r.cells = std::move(cells);
    Eigen::Vector3f lo = Eigen::Vector3f::Constant(1e9f), hi = -lo;
    for (int c : r.cells) {
      r.centroid += g.points[c];
      lo = lo.cwiseMin(g.points[c]);
      hi = hi.cwiseMax(g.points[c]);
    }
    r.centroid /= static_cast<float>(r.cells.size());
    r.extent_m = (hi - lo).norm();
    regions.push_back(std::move(r));
  }
  std::stable_sort(regions.begin(), regions.end(),
                   [](const auto& a, const auto& b) { return a.cells.size() > b.cells.size(); });
  for (size_t i = 0; i < regions.size(); ++i)
    for (int c : regions[i].cells) g.region[c] = static_cast<int>(i);
  return regions;
}

Eigen::Vector3f principal_extents(const std::vector<Eigen::Vector3f>& pts, bool min_area) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : pts) mean += p.cast<double>();
  mean /= std::max<size_t>(1, pts.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : pts) {
    const Eigen::Vector3d q = p.cast<double>() - mean;
    cov += q * q.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  const Eigen::Matrix3f R = es.eigenvectors().transpose().cast<float>();  // rows: small -> large
  std::vector<Eigen::Vector3f> q(pts.size());
  for (size_t i = 0; i < pts.size(); ++i) q[i] = R * (pts[i] - mean.cast<float>());
  Eigen::Vector3f best = Eigen::Vector3f::Constant(std::numeric_limits<float>::infinity());
  auto extents_at = [&](double deg) {
    const float a = static_cast<float>(deg * M_PI / 180.0), c = std::cos(a), s = std::sin(a);
    Eigen::Vector3f lo = Eigen::Vector3f::Constant(1e9f), hi = -lo;
    for (const auto& v : q) {
      const Eigen::Vector3f r(v.x(), c * v.y() - s * v.z(), s * v.y() + c * v.z());
      lo = lo.cwiseMin(r);
      hi = hi.cwiseMax(r);
    }
    return Eigen::Vector3f(hi - lo);
  };
  double best_deg = 0;
  // 5-degree steps over the quarter turn, then half-degree steps around the best.
  for (int step = 0; step < (min_area ? 18 : 1); ++step) {
    const Eigen::Vector3f e = extents_at(5.0 * step);
    if (e.y() * e.z() < best.y() * best.z()) best = e, best_deg = 5.0 * step;
  }
  const double coarse = best_deg;
  for (int step = -4; min_area && step <= 4; ++step) {
    const Eigen::Vector3f e = extents_at(coarse + 0.5 * step);
    if (e.y() * e.z() < best.y() * best.z()) best = e;
  }
  std::sort(best.data(), best.data() + 3, std::greater<float>());
  return best;
}

}  // namespace orpe
