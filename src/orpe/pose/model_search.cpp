#include "orpe/pose/model_search.h"

#include <algorithm>
#include <cmath>
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
    Grid g;
    g.origin = lo - Eigen::Vector3f::Constant(margin_m);
    g.inv_cell = 1.0f / c;
    g.nx = std::max(1, static_cast<int>(std::ceil(size.x() / c)));
    g.ny = std::max(1, static_cast<int>(std::ceil(size.y() / c)));
    g.nz = std::max(1, static_cast<int>(std::ceil(size.z() / c)));
    g.nearest.resize(static_cast<size_t>(g.nx) * g.ny * g.nz);
    // Along a row, the previous cell's nearest point bounds the search (one cell away at most
    // one cell farther): the exact nearest point, found without most of the tree's traversal.
#pragma omp parallel for schedule(static)
    for (int z = 0; z < g.nz; ++z)
      for (int y = 0; y < g.ny; ++y) {
        std::uint32_t prev = kNone;
        for (int x = 0; x < g.nx; ++x) {
          const Eigen::Vector3f centre =
              g.origin + c * Eigen::Vector3f(x + 0.5f, y + 0.5f, z + 0.5f);
          float d2 = 0;
          std::uint32_t j = kNone;
          if (prev != kNone)
            j = nearest_within(
                centre, (points_[prev] - centre).squaredNorm() * (1.0f + 1e-5f) + 1e-12f, &d2);
          if (j == kNone) j = nearest(centre, &d2);
          g.nearest[(static_cast<size_t>(z) * g.ny + y) * g.nx + x] = prev = j;
        }
      }
    grid_ = std::move(g);
  });
  const Eigen::Vector3f r = (query - grid_.origin) * grid_.inv_cell;
  const int x = static_cast<int>(std::floor(r.x())), y = static_cast<int>(std::floor(r.y())),
            z = static_cast<int>(std::floor(r.z()));
  if (x < 0 || y < 0 || z < 0 || x >= grid_.nx || y >= grid_.ny || z >= grid_.nz)
    return nearest(query, distance_sq);
  const std::uint32_t j = grid_.nearest[(static_cast<size_t>(z) * grid_.ny + y) * grid_.nx + x];
  if (distance_sq) *distance_sq = (points_[j] - query).squaredNorm();
  return j;
}

int ModelSearchIndex::knn(const Eigen::Vector3f& query, int k, std::uint32_t* indices,
                          float* distances_sq) const {
  nanoflann::KNNResultSet<float, std::uint32_t> result(static_cast<size_t>(k));
  result.init(indices, distances_sq);
  tree_->tree.findNeighbors(result, query.data(), nanoflann::SearchParams(32, 0.0f, true));
  return static_cast<int>(result.size());
}

}  // namespace orpe
