#include "orpe/semantic/segment_guard.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <unordered_map>

namespace orpe {
namespace {

struct Box {
  int u0 = std::numeric_limits<int>::max(), v0 = std::numeric_limits<int>::max(), u1 = -1, v1 = -1;
};

/// Sliding minimum over [i - r, i + r] of `in` (n values, stride `step`), into `out`.
void sliding_min(const float* in, float* out, int n, int step, int r) {
  for (int i = 0; i < n; ++i) {
    float m = std::numeric_limits<float>::infinity();
    for (int k = std::max(0, i - r); k <= std::min(n - 1, i + r); ++k)
      m = std::min(m, in[k * step]);
    out[i * step] = m;
  }
}

/// Separable (2r+1) x (2r+1) minimum filter of a w x h row-major image, in place.
void min_filter(std::vector<float>& img, int w, int h, int r) {
  std::vector<float> tmp(img.size());
  for (int y = 0; y < h; ++y) sliding_min(&img[y * w], &tmp[y * w], w, 1, r);
  for (int x = 0; x < w; ++x) sliding_min(&tmp[x], &img[x], h, w, r);
}

}  // namespace

int drop_pixels_behind_mask_edges(const DepthImage& depth, LabelImage* labels,
                                  ProbabilityImage* probability, int band_px, double tolerance_m,
                                  double focal_px, double slope) {
  const int W = labels->width(), H = labels->height();
  std::map<std::int32_t, Box> boxes;
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      const std::int32_t l = labels->at(u, v);
      if (l <= 0) continue;
      Box& b = boxes[l];
      b.u0 = std::min(b.u0, u), b.v0 = std::min(b.v0, v);
      b.u1 = std::max(b.u1, u), b.v1 = std::max(b.v1, v);
    }
  const float inf = std::numeric_limits<float>::infinity();
  const auto tol = static_cast<float>(tolerance_m);
  const auto recede = static_cast<float>(slope * band_px / focal_px);  // x z_near
  int dropped = 0;
  for (const auto& [label, box] : boxes) {
    const int u0 = std::max(0, box.u0 - band_px), v0 = std::max(0, box.v0 - band_px);
    const int u1 = std::min(W - 1, box.u1 + band_px), v1 = std::min(H - 1, box.v1 + band_px);
    const int w = u1 - u0 + 1, h = v1 - v0 + 1;
    // near: the nearest depth of the label's pixels around; other: -(is another label or none),
    // min-filtered so that -1 marks pixels with a non-label pixel within the band.
    std::vector<float> near(static_cast<size_t>(w) * h), other(near.size());
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const bool mine = labels->at(u0 + x, v0 + y) == label;
        const float z = depth.at(u0 + x, v0 + y);
        near[y * w + x] = mine && z > 0 ? z : inf;
        other[y * w + x] = mine ? 0.0f : -1.0f;
      }
    min_filter(near, w, h, band_px);
    min_filter(other, w, h, band_px);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        std::int32_t& l = labels->at(u0 + x, v0 + y);
        const float z = depth.at(u0 + x, v0 + y);
        const float z_near = near[y * w + x];
        if (l != label || z <= 0 || other[y * w + x] == 0.0f ||
            !(z > z_near + std::max(tol, recede * z_near)))
          continue;
        l = 0;
        probability->at(u0 + x, v0 + y) = 0.0f;
        ++dropped;
      }
  }
  return dropped;
}

std::vector<int> segment_components(const std::vector<Eigen::Vector3f>& points, float link_m) {
  // Occupied cells of size link_m, 26-connected (union-find over cells).
  auto key = [&](const Eigen::Vector3f& p) {
    const auto c = (p / link_m).array().floor().cast<std::int64_t>();
    return ((c.x() & 0x1fffff) << 42) | ((c.y() & 0x1fffff) << 21) | (c.z() & 0x1fffff);
  };
  std::unordered_map<std::int64_t, int> cell_of;
  std::vector<int> point_cell(points.size());
  std::vector<Eigen::Vector3i> cells;
  for (size_t i = 0; i < points.size(); ++i) {
    const std::int64_t k = key(points[i]);
    auto [it, added] = cell_of.emplace(k, static_cast<int>(cells.size()));
    if (added) cells.push_back((points[i] / link_m).array().floor().cast<int>());
    point_cell[i] = it->second;
  }
  std::vector<int> parent(cells.size());
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  };
  for (size_t c = 0; c < cells.size(); ++c)
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          const Eigen::Vector3i n = cells[c] + Eigen::Vector3i(dx, dy, dz);
          const std::int64_t k = ((static_cast<std::int64_t>(n.x()) & 0x1fffff) << 42) |
                                 ((static_cast<std::int64_t>(n.y()) & 0x1fffff) << 21) |
                                 (static_cast<std::int64_t>(n.z()) & 0x1fffff);
          const auto it = cell_of.find(k);
          if (it != cell_of.end()) parent[find(static_cast<int>(c))] = find(it->second);
        }
  // Number the components by decreasing point count (ties: lower root first).
  std::unordered_map<int, int> size_of_root;
  for (int c : point_cell) ++size_of_root[find(c)];
  std::vector<std::pair<int, int>> by_size(size_of_root.begin(), size_of_root.end());
  std::sort(by_size.begin(), by_size.end(), [](const auto& a, const auto& b) {
    return a.second != b.second ? a.second > b.second : a.first < b.first;
  });
  std::unordered_map<int, int> rank;
  for (size_t r = 0; r < by_size.size(); ++r) rank[by_size[r].first] = static_cast<int>(r);
  std::vector<int> out(points.size());
  for (size_t i = 0; i < points.size(); ++i) out[i] = rank[find(point_cell[i])];
  return out;
}

namespace {

std::vector<Eigen::Vector3f> positions(const slam::SurfelMap& map,
                                       const std::vector<std::int32_t>& idx) {
  std::vector<Eigen::Vector3f> pts;
  pts.reserve(idx.size());
  for (const auto i : idx) pts.push_back(map.position_world[i]);
  return pts;
}

/// Surfels touch when closer than the sum of their radii: on a coarse map (low resolution, far
/// surfaces) the link grows from link_m to twice the median radius of the surfels `idx`.
float segment_link_m(const slam::SurfelMap& map, const std::vector<std::int32_t>& idx,
                     float link_m) {
  std::vector<float> radius;
  radius.reserve(idx.size());
  for (const auto i : idx) radius.push_back(map.radius_m[i]);
  std::nth_element(radius.begin(), radius.begin() + radius.size() / 2, radius.end());
  return std::max(link_m, 2.0f * radius[radius.size() / 2]);
}

}  // namespace

int release_detached_surfels(slam::SurfelMap& map, float link_m, double min_fraction,
                             const SE3* T_cam_world, bool clear_always_active) {
  std::map<std::int32_t, std::vector<std::int32_t>> members;
  for (size_t i = 0; i < map.size(); ++i)
    if (map.instance_id[i] > 0) members[map.instance_id[i]].push_back(static_cast<std::int32_t>(i));
  Eigen::Vector3f view_z = Eigen::Vector3f::Zero();  // camera z of a world point: view_z . p + z0
  float z0 = 0;
  if (T_cam_world) {
    view_z = T_cam_world->rotation().row(2).transpose().cast<float>();
    z0 = static_cast<float>(T_cam_world->translation().z());
  }
  int released = 0;
  for (const auto& [id, idx] : members) {
    const std::vector<Eigen::Vector3f> pts = positions(map, idx);
    const float link = segment_link_m(map, idx, link_m);
    const std::vector<int> comp = segment_components(pts, link);
    const int n_comp = comp.empty() ? 0 : *std::max_element(comp.begin(), comp.end()) + 1;
    if (n_comp <= 1) continue;
    std::vector<int> size(n_comp, 0);
    std::vector<float> z_min(n_comp, std::numeric_limits<float>::infinity()),
        z_max(n_comp, -std::numeric_limits<float>::infinity());
    for (size_t k = 0; k < idx.size(); ++k) {
      ++size[comp[k]];
      const float z = view_z.dot(pts[k]) + z0;
      z_min[comp[k]] = std::min(z_min[comp[k]], z);
      z_max[comp[k]] = std::max(z_max[comp[k]], z);
    }
    const double keep = min_fraction * static_cast<double>(idx.size());
    std::vector<char> drop(n_comp, 0);
    // Behind: entirely farther than a kept component (the largest or one >= min_fraction), so a
    // wall ring larger than a small object in front of it still goes, and the object stays.
    for (int c = 1; c < n_comp; ++c) drop[c] = size[c] < keep;
    for (int c = 0; c < n_comp && T_cam_world; ++c)
      for (int o = 0; o < n_comp && !drop[c]; ++o)
        if (o != c && !drop[o] && size[o] >= keep && z_min[c] > z_max[o] + link) drop[c] = 1;
    for (size_t k = 0; k < idx.size(); ++k) {
      if (!drop[comp[k]]) continue;
      release_surfel(map, idx[k], clear_always_active);
      ++released;
    }
  }
  return released;
}

namespace {

/// 1.4826 x the median absolute signed distance of the inliers: the plane's noise (sigma).
float robust_spread(const std::vector<Eigen::Vector3f>& points, const std::vector<std::int32_t>& in,
                    const Plane& pl) {
  std::vector<float> r;
  r.reserve(in.size());
  for (const auto i : in) r.push_back(std::abs(pl.signed_distance(points[i])));
  if (r.empty()) return 0;
  std::nth_element(r.begin(), r.begin() + r.size() / 2, r.end());
  return 1.4826f * r[r.size() / 2];
}

}  // namespace

std::vector<SupportPlane> find_support_planes(const slam::SurfelMap& map, int max_planes,
                                              double min_fraction, double min_extent_m,
                                              double max_distance_m, size_t max_points) {
  std::vector<std::int32_t> background;
  for (size_t i = 0; i < map.size(); ++i)
    if (map.instance_id[i] <= 0) background.push_back(static_cast<std::int32_t>(i));
  if (max_points > 0 && background.size() > max_points) {
    const size_t step = (background.size() + max_points - 1) / max_points;
    size_t kept = 0;
    for (size_t k = 0; k < background.size(); k += step) background[kept++] = background[k];
    background.resize(kept);
  }
  PlaneSearchParams search;
  search.min_inliers = static_cast<size_t>(min_fraction * static_cast<double>(background.size()));
  search.min_extent_m = min_extent_m;
  std::mt19937 rng(20261201u);
  std::vector<SupportPlane> planes;
  for (int k = 0; k < max_planes; ++k) {
    SupportPlane sp;
    if (!find_large_plane(map.position_world, background, search, rng, &sp.plane)) break;
    std::vector<std::int32_t> in, rest;
    const float tol = static_cast<float>(search.distance_m);
    for (const auto i : background)
      (std::abs(sp.plane.signed_distance(map.position_world[i])) < tol ? in : rest).push_back(i);
    sp.inliers = in.size();
    sp.tolerance_m = std::clamp(3.0f * robust_spread(map.position_world, in, sp.plane), 0.003f,
                                static_cast<float>(max_distance_m));
    planes.push_back(sp);
    background.swap(rest);
  }
  return planes;
}

int release_support_plane_surfels(slam::SurfelMap& map, const std::vector<SupportPlane>& planes,
                                  double max_angle_deg, bool clear_always_active) {
  if (planes.empty()) return 0;
  const float min_cos = static_cast<float>(std::cos(max_angle_deg * M_PI / 180.0));
  std::map<std::int32_t, std::vector<std::int32_t>> on_plane;
  std::map<std::int32_t, size_t> members;
  for (size_t i = 0; i < map.size(); ++i) {
    const auto id = map.instance_id[i];
    if (id <= 0) continue;
    ++members[id];
    for (const auto& sp : planes)
      if (std::abs(sp.plane.signed_distance(map.position_world[i])) < sp.tolerance_m &&
          std::abs(sp.plane.normal.dot(map.normal_world[i])) >= min_cos) {
        on_plane[id].push_back(static_cast<std::int32_t>(i));
        break;
      }
  }
  int released = 0;
  for (const auto& [id, idx] : on_plane) {
    if (2 * idx.size() >= members.at(id)) continue;  // the instance itself lies flat on the plane
    for (const auto i : idx) {
      release_surfel(map, i, clear_always_active);
      ++released;
    }
  }
  return released;
}

namespace {

/// Whether a point lies within `link` of one of `pts` (voxel hash of cell `link`, 27 cells).
class NearQuery {
 public:
  NearQuery(const std::vector<Eigen::Vector3f>& pts, float link) : pts_(pts), link_(link) {
    for (size_t k = 0; k < pts.size(); ++k) cells_[key(cell(pts[k]))].push_back(k);
  }
  bool near(const Eigen::Vector3f& p) const {
    const Eigen::Vector3i c = cell(p);
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          const auto it = cells_.find(key(c + Eigen::Vector3i(dx, dy, dz)));
          if (it == cells_.end()) continue;
          for (const size_t k : it->second)
            if ((pts_[k] - p).squaredNorm() <= link_ * link_) return true;
        }
    return false;
  }

 private:
  Eigen::Vector3i cell(const Eigen::Vector3f& p) const {
    return (p / link_).array().floor().cast<int>();
  }
  static std::int64_t key(const Eigen::Vector3i& c) {
    return (static_cast<std::int64_t>(c.x()) * 73856093) ^
           (static_cast<std::int64_t>(c.y()) * 19349663) ^
           (static_cast<std::int64_t>(c.z()) * 83492791);
  }
  const std::vector<Eigen::Vector3f>& pts_;
  float link_;
  std::unordered_map<std::int64_t, std::vector<size_t>> cells_;
};

}  // namespace

int release_unconfirmed_surfels(slam::SurfelMap& map, float link_m, bool clear_always_active) {
  std::map<std::int32_t, std::vector<std::int32_t>> once, confirmed;
  for (size_t i = 0; i < map.size(); ++i) {
    const auto id = map.instance_id[i];
    if (id <= 0) continue;
    auto& bucket = map.last_seen_time[i] == map.init_time[i] ? once : confirmed;
    bucket[id].push_back(static_cast<std::int32_t>(i));
  }
  int released = 0;
  for (const auto& [id, idx] : once) {
    const auto c = confirmed.find(id);
    if (c == confirmed.end()) continue;
    const std::vector<Eigen::Vector3f> pts = positions(map, c->second);
    const NearQuery confirmed_surface(pts, segment_link_m(map, c->second, link_m));
    for (const auto i : idx) {
      if (!confirmed_surface.near(map.position_world[i])) continue;  // new surface: kept
      release_surfel(map, i, clear_always_active);
      ++released;
    }
  }
  return released;
}

std::map<std::int32_t, float> segment_height_above_support(
    const slam::SurfelMap& map, const std::vector<SupportPlane>& planes) {
  std::map<std::int32_t, std::vector<std::int32_t>> members;
  for (size_t i = 0; i < map.size(); ++i)
    if (map.instance_id[i] > 0) members[map.instance_id[i]].push_back(static_cast<std::int32_t>(i));
  std::map<std::int32_t, float> out;
  for (const auto& [id, idx] : members)
    for (const auto& sp : planes) {
      std::vector<float> above, below;
      for (const auto i : idx) {
        const float h = sp.plane.signed_distance(map.position_world[i]);
        (h >= 0 ? above : below).push_back(std::abs(h));
      }
      std::vector<float>& side = above.size() >= below.size() ? above : below;
      if (10 * side.size() < 9 * idx.size()) continue;  // the plane cuts through it
      const size_t k = std::min(side.size() - 1, side.size() * 98 / 100);
      std::nth_element(side.begin(), side.begin() + static_cast<std::ptrdiff_t>(k), side.end());
      const auto it = out.find(id);
      if (it == out.end() || side[k] < it->second) out[id] = side[k];
    }
  return out;
}

}  // namespace orpe
