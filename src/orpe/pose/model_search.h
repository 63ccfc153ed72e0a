// Nearest-neighbour search over a fixed 3D point set (a kd-tree, nanoflann behind the header).
// Queries are const and safe to run from several threads at once.
#pragma once

#include <Eigen/Core>
#include <atomic>
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
  /// What nearest_within(query, max_distance_sq) returns, found from `hint` (a point near the
  /// query, e.g. the one found for it in the previous iteration of a registration; kNone = none)
  /// by scanning the hint's precomputed neighbours: exact whenever the query is close enough to
  /// the hint that the nearest point must be among them (checked per query; else the tree,
  /// bounded by the best distance seen). The lists (kListSize neighbours per point) are built on
  /// the first call that has a hint.
  std::uint32_t nearest_near(const Eigen::Vector3f& query, std::uint32_t hint,
                             float max_distance_sq, float* distance_sq) const;
  static constexpr int kListSize = 32;
  /// Up to k nearest points, closest first; returns how many were found.
  int knn(const Eigen::Vector3f& query, int k, std::uint32_t* indices, float* distances_sq) const;

  /// Approximate nearest point, for the coarse stages of a search: the nearest point of the centre
  /// of the query's cell in a grid of cubic cells of `cell_m` over the points' bounding box grown
  /// by `margin_m` (laid out on the first call, each cell's point found on its first query; later
  /// calls keep the first call's grid).
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
    float cell = 0, inv_cell = 0;
    int nx = 0, ny = 0, nz = 0;
    /// Per cell (x fastest): the nearest point of its centre, kNone until first queried.
    std::unique_ptr<std::atomic<std::uint32_t>[]> nearest;
  };
  struct NeighbourLists {
    int k = 0;
    std::vector<std::uint32_t> index;  ///< k per point: its k nearest points (itself included)
    std::vector<float> radius_sq;      ///< per point: squared distance of its k-th neighbour
  };
  void build_neighbour_lists() const;
  mutable std::once_flag lists_once_;
  mutable NeighbourLists lists_;
  mutable std::once_flag grid_once_;
  mutable Grid grid_;
};

}  // namespace orpe
