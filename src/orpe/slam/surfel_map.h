// The surfel map: a structure-of-arrays store of oriented discs (ElasticFusion-style), plus the
// per-surfel attributes of the instance-aware semantic stage.
//
// Frames and units: positions and normals are in the `world` frame, metres; radius in metres.
// Times are frame counters of the SLAM system (`SlamSystem::frame_count()` at the time of the
// update), not seconds.
//
// Indices: surfel i is element i of every array. Indices are stable *within* one call of
// `SlamSystem::process()` after fusion returned (the semantic stage hooks in there), but removal
// (`remove()`, called by fusion's cleaning step) moves the last surfels into the freed slots, so an
// index must not be kept across frames. Keep per-object state keyed by `instance_id` instead.
//
// All arrays always have `size()` elements. Writers that append or remove go through the member
// functions so the arrays stay in step; reading and writing existing elements by index is free.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "orpe/core/image.h"

namespace orpe::slam {

using Vec3f = Eigen::Vector3f;

/// One surfel's values, used to append and to read back a whole record (tests, I/O). The map itself
/// stores the fields in separate arrays (see SurfelMap).
struct Surfel {
  Vec3f position_world = Vec3f::Zero();  ///< m
  Vec3f normal_world = Vec3f::UnitZ();   ///< unit length, pointing towards the cameras that saw it
  Rgb8 color;
  float radius_m = 0.0f;
  float confidence = 0.0f;  ///< accumulated observation weight; stable at >= FusionParams threshold
  std::int32_t init_time = 0;       ///< frame counter when created
  std::int32_t last_seen_time = 0;  ///< frame counter of the last fused observation
  // Semantic attributes (see SurfelMap for their meaning).
  std::int32_t instance_id = 0;
  float p_object = 0.0f;
  std::uint8_t boundary_counter = 0;
  std::uint16_t object_obs_count = 0;
  std::uint8_t always_active = 0;
};

class SurfelMap {
 public:
  // ---- geometry and appearance (written by fusion) ----
  std::vector<Vec3f> position_world;  ///< m, world frame
  std::vector<Vec3f> normal_world;    ///< unit vectors, world frame
  std::vector<Rgb8> color;            ///< RGB8, confidence-weighted average of observations
  std::vector<float> radius_m;        ///< disc radius, m
  std::vector<float> confidence;      ///< sum of observation weights (ElasticFusion's c)
  std::vector<std::int32_t> init_time;       ///< frame counter at creation
  std::vector<std::int32_t> last_seen_time;  ///< frame counter of the last fused observation

  // ---- semantic attributes (owned by the semantic stage; fusion only initialises them) ----
  /// Object instance this surfel belongs to; 0 = none (background / not yet assigned). Instance ids
  /// are allocated by the semantic stage and are stable for the whole run.
  std::vector<std::int32_t> instance_id;
  /// Running average of the per-pixel non-background probability over the frames in which this
  /// surfel was observed by a segmentation (paper sec. III-A, p_o). In [0, 1]; 0 when never observed.
  std::vector<float> p_object;
  /// Boundary-refinement counter (paper: +1 per frame while 0.4 < p_o < 0.5 and an object pixel is
  /// in the 6-neighbourhood; compared with sigma = 10 after n = 10 frames).
  std::vector<std::uint8_t> boundary_counter;
  /// Number of segmented frames that contributed to p_object (the t of the running average).
  std::vector<std::uint16_t> object_obs_count;
  /// 1 = never becomes inactive (the paper keeps object surfels always active); 0 = normal surfel,
  /// inactive after FusionParams::active_window_frames frames without an observation.
  std::vector<std::uint8_t> always_active;

  size_t size() const { return position_world.size(); }
  bool empty() const { return position_world.empty(); }
  void clear();
  void reserve(size_t n);
  /// Resizes every array; new surfels are all zero (including the normal: set it).
  void resize(size_t n);

  /// Appends one surfel; returns its index.
  size_t push_back(const Surfel& s);
  /// Reads surfel i into a record.
  Surfel get(size_t i) const;
  /// Overwrites surfel i with a record.
  void set(size_t i, const Surfel& s);

  /// Removes the surfels whose indices are listed (any order, duplicates allowed). Removal fills the
  /// freed slots with the last surfels, so other indices can change: when `moved_from` is non-null it
  /// receives, for each new index i < new size(), the old index the surfel came from (identity for
  /// surfels that did not move). O(removed) apart from the optional remap table.
  void remove(std::vector<std::uint32_t> indices, std::vector<std::uint32_t>* moved_from = nullptr);

  /// Bytes held by the arrays (size() elements, not capacity).
  size_t bytes() const;
  /// Bytes per surfel across all arrays.
  static constexpr size_t kBytesPerSurfel = sizeof(Vec3f) * 2 + sizeof(Rgb8) + sizeof(float) * 3 +
                                            sizeof(std::int32_t) * 3 + sizeof(std::uint8_t) * 2 +
                                            sizeof(std::uint16_t);

  /// Is surfel i active at frame `now`: always_active, or seen within `active_window_frames`
  /// (<= 0 means every surfel is active).
  bool is_active(size_t i, std::int32_t now, int active_window_frames) const {
    return active_window_frames <= 0 || always_active[i] != 0 ||
           now - last_seen_time[i] <= active_window_frames;
  }
};

}  // namespace orpe::slam
