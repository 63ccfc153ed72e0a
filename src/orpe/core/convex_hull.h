// The convex hull of 2-D points (Andrew's monotone chain), for any Eigen 2-vector type.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <vector>

namespace orpe {

/// The convex hull of `points`, counter-clockwise, without repeated or collinear points; fewer
/// than three distinct points are returned as they are (sorted, duplicates removed).
template <typename Vec2>
std::vector<Vec2> convex_hull(std::vector<Vec2> points) {
  std::sort(points.begin(), points.end(), [](const Vec2& a, const Vec2& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  points.erase(std::unique(points.begin(), points.end()), points.end());
  if (points.size() < 3) return points;
  auto cross = [](const Vec2& o, const Vec2& a, const Vec2& b) {
    return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
  };
  std::vector<Vec2> h(2 * points.size());
  size_t k = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    while (k >= 2 && cross(h[k - 2], h[k - 1], points[i]) <= 0) --k;
    h[k++] = points[i];
  }
  for (size_t i = points.size() - 1, t = k + 1; i-- > 0;) {
    while (k >= t && cross(h[k - 2], h[k - 1], points[i]) <= 0) --k;
    h[k++] = points[i];
  }
  h.resize(k - 1);
  return h;
}

}  // namespace orpe
