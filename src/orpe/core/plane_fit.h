// Planes in point sets: least-squares fit, in-plane extent and a deterministic RANSAC search for a
// large plane (a support surface: table, floor, shelf board, wall). Shared by the stages that need
// the support surfaces of a scene (the semantic stage's support-plane guard; docs/SEMANTIC.md).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <random>
#include <vector>

namespace orpe {

/// A plane n . p + d = 0 in the points' frame; n is a unit vector, oriented so that d >= 0 (the
/// frame's origin, e.g. the camera of a camera-frame point set, is on the positive side).
struct Plane {
  Eigen::Vector3f normal = Eigen::Vector3f::UnitZ();
  float d = 0;
  float signed_distance(const Eigen::Vector3f& p) const { return normal.dot(p) + d; }
};

/// Least-squares plane through the points (smallest principal axis); `extent`, when given, gets
/// plane_extent(points) from the same decomposition. Precondition: >= 3 points not all on a line.
Plane fit_plane(const std::vector<Eigen::Vector3f>& points, float* extent = nullptr);

/// Spread (4 sigma) of the points along the smaller of the two in-plane principal axes, m: a
/// 16 x 20 cm box face gives ~0.18 m, a 1 x 2 m table ~1.15 m.
float plane_extent(const std::vector<Eigen::Vector3f>& points);

struct PlaneSearchParams {
  double distance_m = 0.012;   ///< inlier distance of the RANSAC hypotheses
  int iterations = 300;        ///< RANSAC samples
  size_t min_inliers = 3;      ///< a plane needs this many inliers (of the candidates)
  double min_extent_m = 0.35;  ///< and inliers spread at least this far (plane_extent)
  size_t max_scored = 4000;    ///< hypotheses are scored on a strided subset of this size
};

/// The plane with the most inliers among `candidates` (indices into `points`), refined twice by
/// least squares on its inliers; false when none has min_inliers inliers spread over
/// min_extent_m. Deterministic for a given `rng` state.
bool find_large_plane(const std::vector<Eigen::Vector3f>& points,
                      const std::vector<std::int32_t>& candidates, const PlaneSearchParams& params,
                      std::mt19937& rng, Plane* out);

}  // namespace orpe
