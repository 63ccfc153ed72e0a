// The model's silhouette against the observed surface it lies on: an object hypothesis whose
// observed surface continues smoothly well beyond the outline the model projects to is a part of
// something larger (a distractor box or cylinder longer than the target model fitted to one end of
// it), however short the leaking part of its outline is.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "orpe/core/se3.h"
#include "orpe/pose/object_model.h"
#include "orpe/recognition/scene_geometry.h"

namespace orpe {

/// Grid cells the model covers at T_cam_obj: each model sample projected into the grid, widened by
/// the sample spacing at its depth (+ `margin_cells`), so a sparsely sampled model has no gaps.
std::vector<std::uint8_t> model_silhouette(const SceneGrid& g, const PinholeIntrinsics& K,
                                           const ObjectModel& model, const SE3& T_cam_obj,
                                           int margin_cells);

/// Observed surface beyond an object's silhouette: the kept cells no kept object explains
/// (`explained_by` < 0) reached from object `i`'s explained cells through 4-neighbour steps shorter
/// than `continuation_m` inside one region (regions are split at depth steps and concave creases),
/// counted outside `silhouette`. Stops counting at `limit`. The walk does not enter the cells for
/// which `stop` (when given) is true (support_cells: what the object stands on).
int silhouette_overflow(const SceneGrid& g, const std::vector<int>& explained_by, int i,
                        const std::vector<std::uint8_t>& silhouette, float continuation_m,
                        int limit, const std::function<bool(int)>& stop = {});

/// What an object whose lowest model point lies `base_m` over the support plane `support` stands
/// on: a cell is its support when it lies within `height_tolerance_m` of that height and its
/// normal (`normals`) is within `max_tilt_deg` of the plane's (a horizontal surface at the
/// object's foot: the top of the crate a can is stacked on). The side of a distractor cylinder
/// below a can model fitted to its top end is vertical there and is no support.
bool is_support_cell(const SceneGrid& g, GridNormals& normals, const Plane& support, int c,
                     float base_m, float height_tolerance_m, float max_tilt_deg);

/// Whether an object whose lowest model point lies `base_m` over the support plane (g.planes
/// front) stands on observed surface: of its foot -- the model points (at T_cam_obj) within 1 cm
/// of that height, subsampled to about 400 -- at least `min_points` have a support cell
/// (is_support_cell at `base_m`) within `radius_cells` grid cells of their projection, or lie
/// within `height_tolerance_m` of another removed plane (a shelf board). True when no foot point
/// projects into the grid (no evidence) or the grid has no plane.
bool stands_on_observed_surface(const SceneGrid& g, GridNormals& normals,
                                const PinholeIntrinsics& K, const ObjectModel& model,
                                const SE3& T_cam_obj, float base_m, float height_tolerance_m,
                                float max_tilt_deg, int radius_cells, int min_points);

}  // namespace orpe
