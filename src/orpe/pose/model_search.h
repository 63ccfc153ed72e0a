// Nearest-neighbour search over a fixed 3D point set (a kd-tree, nanoflann behind the header).
// Queries are const and safe to run from several threads at once.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <mutex>
#include <vector>

namespace orpe {

class ModelSearchIndex {
 public:
  /// Copies the points and builds the tree.
  explicit ModelSearchIndex(std::vector<Eigen::Vector3f> points);
  ~ModelSearchIndex();
  ModelSearchIndex(const ModelSearchIndex&) = delete;
  ModelSearchIndex& operator=(const ModelSearchIndex&) = delete;

  /// Index of the nearest point and its squared distance (m^2). Precondition: size() > 0.
  std::uint32_t nearest(const Eigen::Vector3f& query, float* distance_sq) const;
  /// The nearest point if its squared distance is below `max_distance_sq` (m^2), else kNone.
  /// Exactly the point nearest() returns (ties included: the same traversal, only subtrees farther
  /// than the bound are pruned), found faster the tighter the bound.
  static constexpr std::uint32_t kNone = 0xffffffffu;
  std::uint32_t nearest_within(const Eigen::Vector3f& query, float max_distance_sq,
                               float* distance_sq) const;
  /// Up to k nearest points, closest first; returns how many were found.
  int knn(const Eigen::Vector3f& query, int k, std::uint32_t* indices, float* distances_sq) const;

  /// Approximate nearest point, for the coarse stages of a search: the nearest point of the centre
  /// of the query's cell in a grid of cubic cells of `cell_m` over the points' bounding box grown
  /// by `margin_m` (built on the first call, in parallel; later calls keep the first call's grid).
  /// A query outside that box gets the exact nearest point. The squared distance is the query's own
  /// to the returned point (>= the true nearest distance, by at most the cell's diagonal).
  std::uint32_t nearest_approx(const Eigen::Vector3f& query, float* distance_sq, float cell_m,
                               float margin_m) const;

  size_t size() const { return points_.size(); }
  const std::vector<Eigen::Vector3f>& points() const { return points_; }

 private:
  struct Tree;
  std::vector<Eigen::Vector3f> points_;
  std::unique_ptr<Tree> tree_;
  struct Grid {
    Eigen::Vector3f origin = Eigen::Vector3f::Zero();
    float inv_cell = 0;
    int nx = 0, ny = 0, nz = 0;
    std::vector<std::uint32_t> nearest;  ///< per cell (x fastest)
  };
  mutable std::once_flag grid_once_;
  mutable Grid grid_;
};

}  // namespace orpe
