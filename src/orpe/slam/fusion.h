// Surfel fusion (ElasticFusion): projective data association of the live frame against an index map
// of the active surfels rendered at the current pose, confidence-weighted updates, new unstable
// surfels, then cleaning (stale unstable surfels, free-space violations, near-duplicate merging).
//
// Per live pixel (u, v) with depth z <= max_depth_m and a normal n (camera frame):
//   weight a = exp(-g^2 / (2 sigma^2)), g = |(u, v) - (cx, cy)| / confidence_radius_px
//   radius r = sqrt(2) z / f / max(|n_z|, 0.5)   (capped at 2x the fronto-parallel radius)
// Candidates: surfels whose centres fall in the pixel's cells of the supersampled index map, with
// |z_surfel - z| < assoc_max_depth_diff_m and normal angle < assoc_max_normal_angle_rad; the one
// closest to the pixel's ray wins (ties: higher confidence). Each surfel lies in exactly one cell,
// so it is updated by at most one pixel per frame. Update: if r < max_radius_growth * r_old,
// position, normal, colour and radius become confidence- weighted averages (weights c_old and a);
// in any case c <- c + a and last_seen <- now. No candidate: a new surfel with confidence a
// (unstable until stable_confidence).
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "orpe/core/se3.h"
#include "orpe/slam/map_renderer.h"
#include "orpe/slam/preprocess.h"
#include "orpe/slam/surfel_map.h"

namespace orpe::slam {

struct FusionParams {
  double max_depth_m = 3.0;                 ///< depth cut-off for fusion (EF: 3 m)
  double assoc_max_depth_diff_m = 0.05;     ///< association window along the ray (EF: 0.05)
  double assoc_max_normal_angle_rad = 0.5;  ///< association normal angle (EF: 0.5)
  double stable_confidence = 10.0;          ///< a surfel is stable at confidence >= this (EF: 10)
  double confidence_sigma = 0.6;            ///< a = exp(-g^2 / (2 sigma^2)) (EF: 0.6)
  double confidence_radius_px =
      0.0;  ///< g's normaliser (px); 0 = half image diagonal (400 at 640x480)
  double max_radius_growth = 1.5;    ///< update geometry only if r_new < this * r_old (EF: 1.5)
  int unstable_max_age_frames = 20;  ///< unstable surfels older than this are removed (EF: 20)
  int active_window_frames = 200;    ///< unseen for longer -> inactive (EF: 200); <= 0: never
  int index_supersample = 1;         ///< index map resolution factor (EF: 4)
  bool remove_free_space_violations =
      true;                           ///< remove unstable surfels in front of the measured surface
  double free_space_margin_m = 0.05;  ///< surfel this much in front of the measurement violates
  bool merge_duplicates = true;       ///< merge near-duplicate surfels seen in this frame
  double merge_max_distance_factor = 0.5;   ///< merge if centre distance < this * smaller radius
  double merge_max_normal_angle_rad = 0.5;  ///< and normal angle below this
  bool add_new_surfels = true;  ///< off: only update existing surfels (e.g. while degraded)
  /// Pyramid level fused: 0 = full-resolution raw depth, one surfel per pixel (ElasticFusion);
  /// 1 = the half-resolution filtered level (4x fewer, 2x larger surfels: faster everywhere).
  int fusion_level = 0;

  template <class V>
  void visit(V&& v) {
    v("max_depth_m", max_depth_m, "Depth cut-off for fusion (m) (EF: 3)");
    v("assoc_max_depth_diff_m", assoc_max_depth_diff_m,
      "Association window along the ray (m) (EF: 0.05)");
    v("assoc_max_normal_angle_rad", assoc_max_normal_angle_rad,
      "Association max normal angle (rad) (EF: 0.5)");
    v("stable_confidence", stable_confidence,
      "Confidence at which a surfel becomes stable (EF: 10)");
    v("confidence_sigma", confidence_sigma,
      "Observation weight a = exp(-g^2/(2 sigma^2)) (EF: 0.6)");
    v("confidence_radius_px", confidence_radius_px,
      "g = distance from the principal point / this (px); 0 = half the image diagonal (400 at "
      "640x480)");
    v("max_radius_growth", max_radius_growth,
      "Update geometry only if new radius < this x old (EF: 1.5)");
    v("unstable_max_age_frames", unstable_max_age_frames,
      "Remove unstable surfels older than this (frames) (EF: 20)");
    v("active_window_frames", active_window_frames,
      "Surfels unseen for more frames are inactive (not tracked/fused) (EF: 200); <= 0: always "
      "active");
    v("index_supersample", index_supersample,
      "Index map resolution factor for association (EF: 4)");
    v("remove_free_space_violations", remove_free_space_violations,
      "Remove unstable surfels lying in front of the measured surface");
    v("free_space_margin_m", free_space_margin_m,
      "A surfel this far in front of the measurement is in free space (m)");
    v("merge_duplicates", merge_duplicates,
      "Merge near-duplicate surfels among those seen in this frame");
    v("merge_max_distance_factor", merge_max_distance_factor,
      "Merge two surfels closer than this times the smaller radius");
    v("merge_max_normal_angle_rad", merge_max_normal_angle_rad,
      "Merge only if normals differ by less (rad)");
    v("add_new_surfels", add_new_surfels,
      "Create surfels for unexplained pixels (off: update only)");
    v("fusion_level", fusion_level,
      "Pyramid level fused: 0 = full-resolution raw depth (EF), 1 = half-resolution filtered depth "
      "(faster)");
  }
  bool IsValid(std::string* why) const;
};

struct FusionStats {
  size_t updated = 0;             ///< surfels updated by an observation
  size_t created = 0;             ///< new surfels
  size_t removed_unstable = 0;    ///< stale unstable surfels removed
  size_t removed_free_space = 0;  ///< free-space violations removed
  size_t merged = 0;              ///< surfels merged into a neighbour
  size_t surfels = 0;             ///< map size afterwards
  double time_ms = 0;
  // Phases (ms): index map, association, updates + new surfels, cleaning + merging, removal.
  double index_ms = 0, associate_ms = 0, update_ms = 0, clean_ms = 0, remove_ms = 0;
};

/// Block average of a colour image by 2^level.
void downsample_color(const ColorImage& in, int level, ColorImage* out);

class SurfelFusion {
 public:
  explicit SurfelFusion(const FusionParams& params = {});
  const FusionParams& params() const { return params_; }

  /// Fuses the preprocessed frame seen from `T_world_cam` into `map` at frame counter `now`.
  /// When `pixel_surfel` is non-null it receives, per full-resolution pixel, the index of the
  /// surfel the pixel (its block at a coarser fusion level) updated, created or is covered by
  /// (valid after this frame's removals), or -1. The frame's colours are fused multiplied by
  /// `color_gain` (the tracker's estimate of the map's brightness over the frame's,
  /// AlignmentResult::rgb_gain), so that the map keeps one brightness through exposure changes.
  FusionStats fuse(const FramePyramid& frame, const SE3& T_world_cam, std::int32_t now,
                   SurfelMap* map, IndexImage* pixel_surfel = nullptr, float color_gain = 1.0f);

  /// The index map of the last fuse() (before cleaning; indices refer to the map before removals).
  const IndexMap& last_index_map() const { return index_map_; }

 private:
  struct Frame;  // the frame at the fusion level and its observation of a pixel (fusion.cpp)
  // The steps of fuse(), in order.
  /// assoc_ and home_: per pixel, the surfel whose disc its ray meets (nearest the ray, then most
  /// confident; the pixel's own index cells first), kNewSurfel, or kNoAssoc.
  void associate(const Frame& f, std::int32_t now, SurfelMap* map);
  /// The associated surfels averaged with their pixel's observation; returns how many.
  size_t update_surfels(const Frame& f, std::int32_t now, SurfelMap* map);
  /// A new surfel per pixel without one; returns how many.
  size_t add_new_surfels(const Frame& f, std::int32_t now, SurfelMap* map);
  /// Marks the unstable surfels older than unstable_max_age_frames; returns how many.
  size_t mark_stale_unstable(std::int32_t now, const SurfelMap& map,
                             std::vector<std::uint8_t>& removed) const;
  /// Marks the unstable surfels seen in front of the frame's depth; returns how many.
  size_t mark_free_space_violations(const Frame& f, const SurfelMap& map,
                                    std::vector<std::uint8_t>& removed) const;
  /// Merges unstable surfels into a dominating close neighbour (merges_); returns how many.
  size_t merge_duplicates(SurfelMap* map, std::vector<std::uint8_t>& removed);
  /// Removes the marked surfels and fills `pixel_surfel` (after the removals' renumbering).
  void remove_marked(const FramePyramid& frame, const Frame& f, SurfelMap* map,
                     const std::vector<std::uint8_t>& removed, IndexImage* pixel_surfel);

  FusionParams params_;
  MapRenderer renderer_;
  IndexMap index_map_;
  IndexImage assoc_;          // per pixel: associated surfel, -1 none, -2 new surfel
  Image<std::uint8_t> home_;  // 1: the associated surfel's centre is in this pixel (update it)
  ColorImage color_lowres_;   // colour at the fusion level when it is not 0
  std::vector<std::uint32_t> row_counts_;
  std::vector<std::int32_t> merge_target_;
  std::vector<std::pair<std::int32_t, std::int32_t>> merges_;  // (merged surfel, target)
};

}  // namespace orpe::slam
