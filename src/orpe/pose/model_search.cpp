#include "orpe/pose/model_search.h"

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

int ModelSearchIndex::knn(const Eigen::Vector3f& query, int k, std::uint32_t* indices,
                          float* distances_sq) const {
  nanoflann::KNNResultSet<float, std::uint32_t> result(static_cast<size_t>(k));
  result.init(indices, distances_sq);
  tree_->tree.findNeighbors(result, query.data(), nanoflann::SearchParams(32, 0.0f, true));
  return static_cast<int>(result.size());
}

}  // namespace orpe
