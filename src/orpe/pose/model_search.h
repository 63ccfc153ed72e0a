// Nearest-neighbour search over a fixed 3D point set (a kd-tree, nanoflann behind the header).
// Queries are const and safe to run from several threads at once.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
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
  /// Up to k nearest points, closest first; returns how many were found.
  int knn(const Eigen::Vector3f& query, int k, std::uint32_t* indices, float* distances_sq) const;

  size_t size() const { return points_.size(); }
  const std::vector<Eigen::Vector3f>& points() const { return points_; }

 private:
  struct Tree;
  std::vector<Eigen::Vector3f> points_;
  std::unique_ptr<Tree> tree_;
};

}  // namespace orpe
