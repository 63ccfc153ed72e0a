// Guards that keep an object instance's segment to the object (issue #14; docs/SEMANTIC.md,
// "Stray surfels"):
//  - drop_pixels_behind_mask_edges: a detection mask pixel near the mask's outline whose measured
//    depth lies well behind the mask's own nearer pixels around it sees the background past the
//    object's silhouette (depth bleeding: the mask and the depth edges of a real sensor do not line
//    up, and degraded masks are dilated). Such a pixel is background, not an object pixel.
//  - segment_components / release_detached_surfels: an instance's surfels form one object,
//  connected
//    in 3D; pieces detached from the instance's main body by more than the link distance (surfels
//    that carry its label behind or beside it) are released to the background.
//  - find_support_planes / release_support_plane_surfels: the large planes of the map (table,
//    floor, shelf boards, walls) are support, not object: an instance's surfels lying on one,
//    within the plane's own noise and oriented like it, are released (the table just past a
//    small object's silhouette is continuous in depth with it, so neither guard above sees it).
//  - segment_height_above_support: how far an instance rises above the support planes (a resting
//    object's top lies at least its model's minimal width above its support).
//  - release_unconfirmed_surfels: a surfel fused in one frame only, next to the instance's
//    confirmed surface, is a measurement that disagreed with that surface (else it would have been
//    fused into it); at the end of a run it does not count as part of the object's segment.
#pragma once

#include <cstdint>
#include <map>
#include <vector>

#include "orpe/core/image.h"
#include "orpe/core/plane_fit.h"
#include "orpe/core/se3.h"
#include "orpe/slam/surfel_map.h"

namespace orpe {

/// Surfel i leaves its instance (background again): label and boundary count cleared, and
/// always_active too when `clear_always_active`. Every guard and instance removal releases so.
inline void release_surfel(slam::SurfelMap& map, size_t i, bool clear_always_active) {
  map.instance_id[i] = 0;
  map.boundary_counter[i] = 0;
  if (clear_always_active) map.always_active[i] = 0;
}

/// For every label L > 0 of `labels`: a pixel of L within `band_px` (Chebyshev) of a pixel that is
/// not L, with valid depth z, is dropped (label 0, probability 0) when some pixel of L within
/// `band_px` has valid depth z_near < z - tolerance, tolerance = max(tolerance_m, slope x band_px x
/// z_near / focal_px): a surface may recede by `slope` times its lateral extent within the band (3:
/// up to ~72 degrees to the view ray) before a depth step counts as an edge, so the curved
/// silhouettes of a coarse image keep their pixels. Returns the number of pixels dropped.
int drop_pixels_behind_mask_edges(const DepthImage& depth, LabelImage* labels,
                                  ProbabilityImage* probability, int band_px, double tolerance_m,
                                  double focal_px, double slope = 3.0);

/// Connected components of the points: occupied cells of a voxel grid of size `link_m`,
/// 26-connected (points closer than link_m always link, points more than 2 sqrt(3) link_m apart
/// never). Returns a component index per point; components are numbered by decreasing size (0 =
/// largest).
std::vector<int> segment_components(const std::vector<Eigen::Vector3f>& points, float link_m);

/// Per instance of `map`, over its 3D components (segment_components with link = max(link_m, twice
/// the instance's median surfel radius: surfels touch when closer than their radii)): a component
/// other than the largest loses the instance when it holds fewer than `min_fraction` of the
/// instance's surfels; and, seen from the camera (`T_cam_world`, if given), any component that lies
/// entirely more than the link behind another kept component holding >= min_fraction (background
/// seen past the silhouette; the pieces of an object split by an occluder overlap in depth).
/// Returns the number of surfels released; `always_active` is cleared for them when
/// `clear_always_active`.
int release_detached_surfels(slam::SurfelMap& map, float link_m, double min_fraction,
                             const SE3* T_cam_world, bool clear_always_active);

/// A support plane of the map and the distance (m) within which a surfel lies on it.
struct SupportPlane {
  Plane plane;            ///< world frame
  float tolerance_m = 0;  ///< 3 x the robust (MAD) spread of its inliers, clamped
  size_t inliers = 0;
};

/// Up to `max_planes` large planes among the map's surfels without an instance, largest first:
/// each holds >= min_fraction of them (within 1.2 cm) spread over >= min_extent_m (plane_extent).
/// Tolerance of each: 3 x 1.4826 x the median absolute residual of its inliers, clamped to
/// [3 mm, max_distance_m]. Deterministic (fixed seed). A map with more than `max_points` such
/// surfels is searched on an evenly strided subset of at most that many (0 = all): the planes are
/// large, so a subset fits them as well (the fits' noise falls with the square root of the count).
std::vector<SupportPlane> find_support_planes(const slam::SurfelMap& map, int max_planes,
                                              double min_fraction, double min_extent_m,
                                              double max_distance_m, size_t max_points = 0);

/// Per instance: its surfels within a plane's tolerance whose normal is within max_angle_deg of
/// the plane's normal (either sign) lose the instance, unless they are at least half of its
/// surfels (then the instance is itself flat on the plane, e.g. a sheet, and is left to the
/// class average). Returns the number of surfels released; `always_active` is cleared for them when
/// `clear_always_active`.
int release_support_plane_surfels(slam::SurfelMap& map, const std::vector<SupportPlane>& planes,
                                  double max_angle_deg, bool clear_always_active);

/// Instance surfels fused in one frame only (last_seen_time == init_time) that lie within the link
/// (max(link_m, twice the median radius of the instance's confirmed surfels)) of a confirmed surfel
/// of the same instance lose the instance: had the measurement agreed with that surface it would
/// have been fused into it (projective association), so it is an outlier of a surface already
/// known. Once-seen surfels away from every confirmed one are new surface and keep the label. The
/// surfels stay in the map. Returns the number released; `always_active` is cleared for them when
/// `clear_always_active`.
int release_unconfirmed_surfels(slam::SurfelMap& map, float link_m, bool clear_always_active);

/// Per instance of `map`: how far it rises above the support planes it stands on one side of. For
/// each plane with at least 90 % of the instance's surfels on one side of it, the 98th percentile
/// of their distances on that side; the smallest over such planes (m). Instances on no plane's one
/// side are not listed.
std::map<std::int32_t, float> segment_height_above_support(const slam::SurfelMap& map,
                                                           const std::vector<SupportPlane>& planes);

}  // namespace orpe
