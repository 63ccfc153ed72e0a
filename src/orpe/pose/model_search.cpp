#include "orpe/pose/model_search.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <nanoflann.hpp>

namespace orpe {

namespace {
struct PointsAdaptor {
  const std::vector<Eigen::Vector3f>* points;
  size_t kdtree_get_point_count() const { return points->size(); }
  float kdtree_get_pt(size_t i, size_t dim) const { return (*points)[i][static_cast<int>(dim)]; }
  template <class Bbox>
  bool kdtree_get_bbox(Bbox&) const {
    return false;
  }
};
using KdTree =
    nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, PointsAdaptor>,
                                        PointsAdaptor, 3, std::uint32_t>;
}  // namespace

struct ModelSearchIndex::Tree {
  PointsAdaptor adaptor;
  KdTree tree;
  explicit Tree(const std::vector<Eigen::Vector3f>* pts)
      : adaptor{pts}, tree(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(10)) {}
};

ModelSearchIndex::ModelSearchIndex(std::vector<Eigen::Vector3f> points)
    : points_(std::move(points)), tree_(std::make_unique<Tree>(&points_)) {}

ModelSearchIndex::~ModelSearchIndex() = default;

std::uint32_t ModelSearchIndex::nearest(const Eigen::Vector3f& query, float* distance_sq) const {
  std::uint32_t index = 0;
  float d2 = 0;
  nanoflann::KNNResultSet<float, std::uint32_t> result(1);
  result.init(&index, &d2);
  tree_->tree.findNeighbors(result, query.data(), nanoflann::SearchParams(32, 0.0f, false));
  if (distance_sq) *distance_sq = d2;
  return index;
}

std::uint32_t ModelSearchIndex::nearest_within(const Eigen::Vector3f& query, float max_distance_sq,
                                               float* distance_sq) const {
  std::uint32_t index = kNone;
  float d2 = 0;
  nanoflann::KNNResultSet<float, std::uint32_t> result(1);
  result.init(&index, &d2);
  d2 = max_distance_sq;  // the result set's worst distance: only nearer points are accepted
  tree_->tree.findNeighbors(result, query.data(), nanoflann::SearchParams(32, 0.0f, false));
  if (result.size() == 0) return kNone;
  if (distance_sq) *distance_sq = d2;
  return index;
}

std::uint32_t ModelSearchIndex::nearest_approx(const Eigen::Vector3f& query, float* distance_sq,
                                               float cell_m, float margin_m) const {
  std::call_once(grid_once_, [&] {
    Eigen::Vector3f lo = points_.front(), hi = points_.front();
    for (const auto& p : points_) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    const float cell = std::max(cell_m, 1e-4f);
    const Eigen::Vector3f size = hi - lo + Eigen::Vector3f::Constant(2 * margin_m);
    // At most ~2M cells (8 MB): a coarser cell for a huge margin.
    float c = cell;
    while ((size / c).array().ceil().prod() > 2e6f) c *= 1.25f;
    grid_.origin = lo - Eigen::Vector3f::Constant(margin_m);
    grid_.cell = c;
    grid_.inv_cell = 1.0f / c;
    grid_.nx = std::max(1, static_cast<int>(std::ceil(size.x() / c)));
    grid_.ny = std::max(1, static_cast<int>(std::ceil(size.y() / c)));
    grid_.nz = std::max(1, static_cast<int>(std::ceil(size.z() / c)));
    const size_t cells = static_cast<size_t>(grid_.nx) * grid_.ny * grid_.nz;
    grid_.nearest = std::make_unique<std::atomic<std::uint32_t>[]>(cells);
    for (size_t i = 0; i < cells; ++i) grid_.nearest[i].store(kNone, std::memory_order_relaxed);
  });
  const Eigen::Vector3f r = (query - grid_.origin) * grid_.inv_cell;
  const int x = static_cast<int>(std::floor(r.x())), y = static_cast<int>(std::floor(r.y())),
            z = static_cast<int>(std::floor(r.z()));
  if (x < 0 || y < 0 || z < 0 || x >= grid_.nx || y >= grid_.ny || z >= grid_.nz)
    return nearest(query, distance_sq);
  // A cell's point is found on its first query (a search covers a small part of the grid) and kept.
  // It is the exact nearest point of the cell's centre whichever thread stores it first, so the
  // result does not depend on the order of the queries.
  std::atomic<std::uint32_t>& slot =
      grid_.nearest[(static_cast<size_t>(z) * grid_.ny + y) * grid_.nx + x];
  std::uint32_t j = slot.load(std::memory_order_relaxed);
  if (j == kNone) {
    const Eigen::Vector3f centre =
        grid_.origin + grid_.cell * Eigen::Vector3f(x + 0.5f, y + 0.5f, z + 0.5f);
    float d2 = 0;
    j = nearest(centre, &d2);
    slot.store(j, std::memory_order_relaxed);
  }
  if (distance_sq) *distance_sq = (points_[j] - query).squaredNorm();
  return j;
}

std::uint32_t ModelSearchIndex::nearest_near(const Eigen::Vector3f& query, std::uint32_t hint,
                                             float max_distance_sq, float* distance_sq) const {
  constexpr float kMargin = 1.0f + 1e-5f;  // float rounding of the distances compared below
  float bound = max_distance_sq * kMargin + 1e-12f;
  if (hint != kNone && hint < points_.size()) {
    std::call_once(lists_once_, [&] { build_neighbour_lists(); });
    float dh2 = (points_[hint] - query).squaredNorm();
    for (int hop = 0; hop < 4; ++hop) {
      const std::uint32_t* list = &lists_.index[static_cast<size_t>(hint) * lists_.k];
      std::uint32_t best = hint;
      float best_d2 = dh2;
      for (int i = 0; i < lists_.k; ++i) {
        const float d2 = (points_[list[i]] - query).squaredNorm();
        if (d2 < best_d2) best_d2 = d2, best = list[i];
      }
      // The nearest point lies within sqrt(best_d2) of the query, so within sqrt(best_d2) +
      // sqrt(dh2) of the hint: inside the hint's list when that is below the list's radius.
      // Beyond max_distance_sq nothing is wanted: only that range needs to be covered.
      const float reach =
          (std::sqrt(std::min(best_d2, max_distance_sq)) + std::sqrt(dh2)) * kMargin + 1e-6f;
      if (reach * reach < lists_.radius_sq[hint]) {
        if (best_d2 > max_distance_sq) return kNone;
        if (distance_sq) *distance_sq = best_d2;
        return best;
      }
      bound = std::min(bound, best_d2 * kMargin + 1e-12f);
      if (best == hint) break;
      hint = best, dh2 = best_d2;
    }
  }
  // Not certified by a list: the tree, bounded by the best distance seen.
  std::uint32_t j = nearest_within(query, bound, distance_sq);
  if (j == kNone && bound < max_distance_sq * kMargin) {  // rounding betrayed the hint's bound
    float d2 = 0;
    j = nearest(query, &d2);
    if (d2 > max_distance_sq) return kNone;
    if (distance_sq) *distance_sq = d2;
  }
  return j;
}

void ModelSearchIndex::build_neighbour_lists() const {
  const size_t n = points_.size();
  const int k = static_cast<int>(std::min<size_t>(kListSize, n));
  lists_.k = k;
  lists_.index.resize(n * static_cast<size_t>(k));
  lists_.radius_sq.resize(n);
#pragma omp parallel for schedule(static)
  for (size_t j = 0; j < n; ++j) {
    std::vector<float> d2(static_cast<size_t>(k));
    knn(points_[j], k, &lists_.index[j * static_cast<size_t>(k)], d2.data());
    // Every point nearer than the k-th neighbour is in the list; with all points listed, any
    // distance is covered.
    lists_.radius_sq[j] =
        static_cast<size_t>(k) == n ? std::numeric_limits<float>::infinity() : d2.back();
  }
}

int ModelSearchIndex::knn(const Eigen::Vector3f& query, int k, std::uint32_t* indices,
                          float* distances_sq) const {
  nanoflann::KNNResultSet<float, std::uint32_t> result(static_cast<size_t>(k));
  result.init(indices, distances_sq);
  tree_->tree.findNeighbors(result, query.data(), nanoflann::SearchParams(32, 0.0f, true));
  return static_cast<int>(result.size());
}

}  // namespace orpe
