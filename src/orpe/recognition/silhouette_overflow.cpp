#include "orpe/recognition/silhouette_overflow.h"

#include <algorithm>
#include <cmath>

namespace orpe {

namespace {

/// The grid cell (column, row; maybe outside the grid) a camera-frame point projects to.
Eigen::Vector2i grid_cell_of(const SceneGrid& g, const PinholeIntrinsics& K,
                             const Eigen::Vector3f& q) {
  const float stride = static_cast<float>(g.stride);
  const float gu = static_cast<float>(K.fx * q.x() / q.z() + K.cx) / stride;
  const float gv = static_cast<float>(K.fy * q.y() / q.z() + K.cy) / stride;
  return {static_cast<int>(std::lround(gu)), static_cast<int>(std::lround(gv))};
}

}  // namespace

std::vector<std::uint8_t> model_silhouette(const SceneGrid& g, const PinholeIntrinsics& K,
                                           const ObjectModel& model, const SE3& T_cam_obj,
                                           int margin_cells) {
  std::vector<std::uint8_t> in(static_cast<size_t>(g.width) * g.height, 0);
  const Eigen::Matrix3f R = T_cam_obj.rotation().cast<float>();
  const Eigen::Vector3f t = T_cam_obj.translation().cast<float>();
  const float spacing = static_cast<float>(model.mean_spacing_m);
  const float stride = static_cast<float>(g.stride);
  for (const Eigen::Vector3f& p : model.points) {
    const Eigen::Vector3f q = R * p + t;
    if (q.z() <= 0.05f) continue;
    const int r = static_cast<int>(std::ceil(static_cast<float>(K.fx) * spacing / q.z() / stride)) +
                  margin_cells;
    const Eigen::Vector2i cell = grid_cell_of(g, K, q);
    const int cu = cell.x(), cv = cell.y();
    for (int v = std::max(0, cv - r); v <= std::min(g.height - 1, cv + r); ++v)
      for (int u = std::max(0, cu - r); u <= std::min(g.width - 1, cu + r); ++u)
        if ((u - cu) * (u - cu) + (v - cv) * (v - cv) <= r * r) in[g.cell(u, v)] = 1;
  }
  return in;
}

int silhouette_overflow(const SceneGrid& g, const std::vector<int>& explained_by, int i,
                        const std::vector<std::uint8_t>& silhouette, float continuation_m,
                        int limit, const std::function<bool(int)>& stop) {
  std::vector<std::uint8_t> seen(explained_by.size(), 0);
  std::vector<int> stack;
  const float reach2 = continuation_m * continuation_m;
  auto try_step = [&](int from, int to) {
    if (seen[to] || !g.kept[to] || explained_by[to] >= 0 || g.region[to] < 0 ||
        g.region[to] != g.region[from] || (g.points[to] - g.points[from]).squaredNorm() >= reach2)
      return;
    if (stop && stop(to)) {
      seen[to] = 1;
      return;
    }
    seen[to] = 1;
    stack.push_back(to);
  };
  auto neighbours = [&](int c, auto&& fn) {
    const int gu = c % g.width, gv = c / g.width;
    if (gu > 0) fn(c - 1);
    if (gu + 1 < g.width) fn(c + 1);
    if (gv > 0) fn(c - g.width);
    if (gv + 1 < g.height) fn(c + g.width);
  };
  for (size_t c = 0; c < explained_by.size(); ++c)
    if (explained_by[c] == i)
      neighbours(static_cast<int>(c), [&](int n) { try_step(static_cast<int>(c), n); });
  int overflow = 0;
  while (!stack.empty() && overflow < limit) {
    const int c = stack.back();
    stack.pop_back();
    if (!silhouette[c]) ++overflow;
    neighbours(c, [&](int n) { try_step(c, n); });
  }
  return overflow;
}

bool is_support_cell(const SceneGrid& g, GridNormals& normals, const Plane& support, int c,
                     float base_m, float height_tolerance_m, float max_tilt_deg) {
  if (std::abs(support.signed_distance(g.points[c]) - base_m) > height_tolerance_m) return false;
  const Eigen::Vector3f& n = normals.at(c);
  if (n.squaredNorm() < 0.5f) return false;  // no normal
  return std::abs(n.dot(support.normal)) >=
         std::cos(max_tilt_deg * static_cast<float>(M_PI) / 180.0f);
}

bool stands_on_observed_surface(const SceneGrid& g, GridNormals& normals,
                                const PinholeIntrinsics& K, const ObjectModel& model,
                                const SE3& T_cam_obj, float base_m, float height_tolerance_m,
                                float max_tilt_deg, int radius_cells, int min_points) {
  if (g.planes.empty()) return true;
  const Plane& support = g.planes.front();
  const Eigen::Matrix3f R = T_cam_obj.rotation().cast<float>();
  const Eigen::Vector3f t = T_cam_obj.translation().cast<float>();
  const size_t step = std::max<size_t>(1, model.points.size() / 400);
  int projected = 0, supported = 0;
  for (size_t k = 0; k < model.points.size() && supported < min_points; k += step) {
    const Eigen::Vector3f q = R * model.points[k] + t;
    if (support.signed_distance(q) > base_m + 0.01f || q.z() <= 0.05f) continue;
    bool on_plane = false;
    for (size_t j = 1; j < g.planes.size() && !on_plane; ++j)
      on_plane = std::abs(g.planes[j].signed_distance(q)) < height_tolerance_m;
    if (on_plane) {
      ++supported;
      continue;
    }
    const Eigen::Vector2i cell = grid_cell_of(g, K, q);
    const int cu = cell.x(), cv = cell.y();
    if (cu < 0 || cv < 0 || cu >= g.width || cv >= g.height) continue;
    ++projected;
    bool found = false;
    for (int v = std::max(0, cv - radius_cells);
         v <= std::min(g.height - 1, cv + radius_cells) && !found; ++v)
      for (int u = std::max(0, cu - radius_cells);
           u <= std::min(g.width - 1, cu + radius_cells) && !found; ++u) {
        const int c = g.cell(u, v);
        found = g.kept[c] &&
                is_support_cell(g, normals, support, c, base_m, height_tolerance_m, max_tilt_deg);
      }
    supported += found;
  }
  return supported >= min_points || projected == 0;
}

}  // namespace orpe
