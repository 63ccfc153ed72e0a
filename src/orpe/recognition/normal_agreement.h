// Normal agreement of the `model` back-end (docs/SEMANTIC.md, "model", step 4): an observed point
// is explained by a model only where the observed surface also runs along the model's. A distance
// band alone lets a curved model explain a flat face (a mustard bottle lying on its side, 1 cm
// from a wood block's front face over most of it): its surface crosses the face at an angle where
// it curves away, while a box explains the face, its top and its sharp edges with the normals too.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <vector>

#include "orpe/recognition/scene_geometry.h"

namespace orpe {

/// Unit normals of every kept grid cell (GridNormals over a (2 radius + 1)^2 window), zero where
/// the window has too few points or the cell is not kept. Computed at once, so the result can be
/// read from parallel registrations.
std::vector<Eigen::Vector3f> kept_cell_normals(const SceneGrid& g, int radius);

/// Whether an observed normal (object frame, any sign) agrees with the model's normal at the
/// point's nearest sample: |cos| of the angle at least `min_cos`. A zero observed normal (no
/// evidence) agrees.
inline bool normal_agrees(const Eigen::Vector3f& observed, const Eigen::Vector3f& model,
                          float min_cos) {
  if (observed.isZero()) return true;
  return std::abs(observed.dot(model)) >= min_cos;
}

}  // namespace orpe
