// Instance-aware semantic fusion (the paper, sec. III-A): detections of a keyframe are associated
// to the map's object instances through masks rendered from the map, each instance keeps one
// class-probability vector (simple average over the frames that detected it), each surfel keeps an
// instance id and its averaged non-background probability p_o, and boundary surfels whose p_o sits
// just below 0.5 join the closest instance when a sequence of frames supports it.
//
// Choices where the paper is silent (docs/SEMANTIC.md has the full rationale):
//  - Which surfels a frame updates: the surfels this frame's pixels fused into. Given the SLAM's
//    pixel -> surfel image (SlamSystem::last_pixel_surfel()), exactly those, each at its listed
//    pixel nearest its projected centre (a surfel can cover several pixels); otherwise the surfels
//    whose centres the supersampled index map puts in a pixel (one pixel per surfel and frame) and
//    whose depth agrees with the frame's measured depth. Splatted rendering is used only for the
//    association masks M^ and the per-instance outputs.
//  - Ownership: an unlabelled surfel takes the instance of the detection covering its pixel
//    (probability >= 0.5, highest probability wins between overlapping detections); a labelled
//    surfel keeps its instance (first come) until its p_o falls to <= release_probability (0.4:
//    clearly background) or its instance is removed.
//  - U = |M n M^| / max(|M^|, association_min_projected_area_px): the floor keeps a large detection
//    from being captured by a few stray pixels of another instance. Ties: larger U, then larger
//    intersection, then lower instance id.
//  - "6-neighbourhood" on an image: the (2r+1) x (2r+1) window of Chebyshev radius r = 6 px around
//  the
//    surfel's pixel ("object pixel" = a pixel of this frame's associated detection masks).
//  - "n frames" of the boundary rule: the keyframes in which the candidate surfel was observed.
//    The window length and the count are packed into SurfelMap::boundary_counter (high / low
//    nibble), so n and sigma are at most 15.
//  - Detector misses: when an instance renders >= min_visible_area_px pixels but no detection
//  joined it,
//    the surfels seen in its projection (dilated by boundary_neighbourhood_px) are not updated in
//    this keyframe (skip_missed_instances): the paper would average a 0 into their p_o, which
//    unlabels new surfels and pushes boundary surfels out of the refinement band.
//  - Only confirmed instances (>= min_confirmed_detections detections) protect their surfels from a
//    miss: a tentative one (likely spurious) must not blank real surfels around it. The projected
//    outputs (SemanticMapper::render_instance_labels / render_instance_views) show confirmed ones.
//  - Spurious instances die: an instance detected in fewer than min_instance_detections keyframes
//  is
//    removed once it was visible but undetected in prune_missed_keyframes keyframes in a row, and
//    at finalize(); an instance left without surfels (all released) is removed at once; one with
//    fewer than min_instance_surfels surfels is removed at finalize(). Removing an instance
//    unlabels its surfels. Also at finalize(): an instance rising less than min_height_fraction x
//    its class model's minimal width above a support plane (set_class_min_widths), and, when
//    min_detection_ratio > 0, one detected in too few of its chances.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "orpe/core/frame.h"
#include "orpe/core/se3.h"
#include "orpe/semantic/detection.h"
#include "orpe/semantic/instance_render.h"
#include "orpe/slam/map_renderer.h"
#include "orpe/slam/surfel_map.h"

namespace orpe {

struct SemanticParams {
  double object_probability_threshold =
      0.5;                               ///< a pixel is an object pixel at >= this (Mask R-CNN)
  double association_min_overlap = 0.3;  ///< U must exceed this to join an instance (paper)
  int association_min_projected_area_px = 50;  ///< floor of U's denominator |M^|
  bool merge_same_class_instances =
      true;  ///< merge instances of one argmax class that one detection overlaps
  double release_probability = 0.4;  ///< a labelled surfel with p_o <= this becomes background
  bool boundary_refinement = true;   ///< the paper's boundary refinement (off: ablation)
  double boundary_low_probability =
      0.4;  ///< boundary candidates: low < p_o < high (paper 0.4, 0.5)
  double boundary_high_probability = 0.5;
  double boundary_pixel_min_probability = 0.4;  ///< criterion (i): pixel probability > this
  int boundary_neighbourhood_px = 6;  ///< criterion (ii): object pixel within this Chebyshev radius
  int boundary_window_frames = 10;    ///< n: observations per decision window (<= 15)
  int boundary_min_count = 10;        ///< sigma: supporting observations needed (<= n)
  int index_supersample = 4;          ///< index map resolution factor (ElasticFusion: 4)
  /// Cap of a surfel's splat radius on screen when rendering instance masks (M^ and the projected
  /// masks): bounds the overhang of grazing-angle discs past silhouettes and the cost.
  double mask_splat_radius_px = 2.0;
  /// Splat radius = surfel radius x this when rendering instance masks
  /// (RenderOptions::radius_scale).
  double mask_splat_radius_scale = 1.0;
  /// Instance masks are rendered label-aware (instance_render.h): the nearest labelled surface wins
  /// a pixel when it lies within this of the map's visible surface (young noisy surfels in front).
  double mask_depth_tolerance_m = 0.02;
  /// Instance masks: every surfel and the labelled ones rendered in one pass over the map (false:
  /// two renders; the same images, InstanceRenderOptions::one_pass).
  bool mask_render_one_pass = true;
  double surfel_depth_tolerance_m =
      0.02;  ///< a surfel is observed when |z_surfel - z_frame| <= max(
  double surfel_depth_tolerance_rel = 0.02;  ///<   tolerance_m, tolerance_rel * z_frame)
  int min_visible_area_px = 50;      ///< an instance rendering this many pixels counts as visible
  int min_confirmed_detections = 2;  ///< an instance is confirmed after this many detections
  int min_instance_detections = 3;   ///< instances detected in fewer keyframes are pruned
  int prune_missed_keyframes = 5;  ///< ... once visible but undetected this many keyframes in a row
  int min_instance_surfels = 50;   ///< instances with fewer surfels are removed at finalize()
  /// At finalize(): an instance detected in fewer than this fraction of its chances (keyframes
  /// that detected it or in which it was visible, >= min_visible_area_px, without a detection)
  /// has not earned its existence and is removed (0 = off).
  double min_detection_ratio = 0;
  /// At finalize(): an instance of a class with a known minimal width w (set_class_min_widths)
  /// whose surfels rise less than this x w above a support plane they stand on one side of is
  /// removed: a resting object's top lies at least w above its support (a sheet or the table
  /// explained by a model does not). 0 = off.
  double min_height_fraction = 0.7;
  bool always_active_objects = true;  ///< flag object surfels always active (paper)
  /// A keyframe in which a visible instance got no detection does not update the surfels in and
  /// around (boundary_neighbourhood_px) its projection: a detector miss is not evidence of
  /// background.
  bool skip_missed_instances = true;
  /// Depth-edge guard (segment_guard.h): a mask pixel within edge_band_px of the mask's outline
  /// whose depth lies more than edge_depth_tolerance_m behind the mask's nearer pixels within the
  /// band sees the background past the silhouette: it is not an object pixel (probability 0).
  bool edge_depth_guard = true;
  int edge_band_px = 6;
  double edge_depth_tolerance_m = 0.02;
  /// Connectivity guard (segment_guard.h): after each keyframe and at finalize(), the surfels of an
  /// instance outside its largest 3D component (voxels of segment_link_m, 26-connected) lose the
  /// instance when their component holds < segment_min_component_fraction of its surfels.
  bool segment_connectivity_guard = true;
  double segment_link_m = 0.01;
  double segment_min_component_fraction = 0.1;
  /// Support-plane guard (segment_guard.h): after each keyframe and at finalize(), the large planes
  /// of the map's background (table, floor, walls: >= support_plane_min_fraction of the background
  /// surfels, spread >= support_plane_min_extent_m) are found, and an instance's surfels lying on
  /// one (within 3 sigma of its noise, at most support_plane_max_distance_m, normal within
  /// support_plane_max_normal_angle_deg) lose the instance.
  bool support_plane_guard = true;
  int support_plane_max_planes = 3;
  double support_plane_min_fraction = 0.15;
  double support_plane_min_extent_m = 0.35;
  double support_plane_max_distance_m = 0.01;
  int support_plane_max_points = 20000;  ///< planes searched on at most this many surfels (0 = all)
  double support_plane_max_normal_angle_deg = 30;
  /// At finalize(), before the guards above: an instance's surfels fused in one frame only (never
  /// re-observed) lose the instance (segment_guard.h, release_unconfirmed_surfels).
  bool segment_confirmed_surfels_only = true;

  template <class V>
  void visit(V&& v) {
    v("object_probability_threshold", object_probability_threshold,
      "A pixel belongs to a detection's mask at probability >= this (Mask R-CNN: 0.5)");
    v("association_min_overlap", association_min_overlap,
      "Association: U = |M n M^| / |M^| must exceed this to join an instance (paper: 0.3)");
    v("association_min_projected_area_px", association_min_projected_area_px,
      "Association: floor of |M^| in U, so a few stray pixels of an instance cannot capture a "
      "detection");
    v("merge_same_class_instances", merge_same_class_instances,
      "Merge instances with the same argmax class when one detection overlaps both (U > "
      "threshold)");
    v("release_probability", release_probability,
      "A labelled surfel whose averaged p_o falls to <= this becomes background");
    v("boundary_refinement", boundary_refinement,
      "Boundary refinement: surfels with p_o just below 0.5 join the closest instance (paper; off "
      "= ablation)");
    v("boundary_low_probability", boundary_low_probability,
      "Boundary refinement candidates have low < p_o < high (paper: 0.4)");
    v("boundary_high_probability", boundary_high_probability,
      "Boundary refinement candidates have low < p_o < high (paper: 0.5)");
    v("boundary_pixel_min_probability", boundary_pixel_min_probability,
      "Boundary criterion (i): the pixel's non-background probability must exceed this (paper: "
      "0.4)");
    v("boundary_neighbourhood_px", boundary_neighbourhood_px,
      "Boundary criterion (ii): an object pixel within this Chebyshev radius (px; paper: "
      "6-neighbourhood)");
    v("boundary_window_frames", boundary_window_frames,
      "Boundary refinement window n: observations per decision (paper: 10; <= 15)");
    v("boundary_min_count", boundary_min_count,
      "Boundary refinement sigma: supporting observations in a window to join an instance (paper: "
      "10)");
    v("index_supersample", index_supersample, "Index map supersampling for surfel updates (1-8)");
    v("mask_splat_radius_px", mask_splat_radius_px,
      "Splat radius cap (px) when rendering instance masks; full splats overhang silhouettes");
    v("mask_splat_radius_scale", mask_splat_radius_scale,
      "Instance masks: splat radius = surfel radius x this (< 1 trims the overhang past "
      "silhouettes)");
    v("mask_depth_tolerance_m", mask_depth_tolerance_m,
      "Instance masks: an instance surface within this (m) of the visible surface labels the "
      "pixel");
    v("mask_render_one_pass", mask_render_one_pass,
      "Instance masks: render every surfel and the labelled ones in one pass over the map (false: "
      "a render each, the same images; session 24: the semantic stage's render -14 % on the YCB "
      "clips)");
    v("surfel_depth_tolerance_m", surfel_depth_tolerance_m,
      "A surfel is observed by a pixel when |z_surfel - z_pixel| <= max(this (m), rel * z)");
    v("surfel_depth_tolerance_rel", surfel_depth_tolerance_rel,
      "Relative part of the surfel/pixel depth agreement test");
    v("min_visible_area_px", min_visible_area_px,
      "An instance rendering at least this many pixels counts as visible in a keyframe");
    v("min_confirmed_detections", min_confirmed_detections,
      "An instance detected in this many keyframes is confirmed: only confirmed instances appear "
      "in the "
      "projected masks / instance views and protect their surfels from a missed detection");
    v("min_instance_detections", min_instance_detections,
      "Instances detected in fewer keyframes are pruned (spurious detections)");
    v("prune_missed_keyframes", prune_missed_keyframes,
      "Prune such an instance once it was visible but undetected this many keyframes in a row");
    v("min_instance_surfels", min_instance_surfels,
      "Instances with fewer surfels are removed at the end");
    v("min_height_fraction", min_height_fraction,
      "At the end, an instance whose surfels rise less than this x its class model's minimal "
      "width above a support plane they lie on one side of is removed (0 = off; needs the "
      "models' widths, which the pipeline provides)");
    v("min_detection_ratio", min_detection_ratio,
      "At the end, instances detected in fewer than this fraction of the keyframes that detected "
      "them or in which they were visible (projected mask >= min_visible_area_px) are removed (0 = "
      "off)");
    v("always_active_objects", always_active_objects,
      "Flag object surfels always active (never leave the active window; paper)");
    v("skip_missed_instances", skip_missed_instances,
      "Do not update surfels in/around a visible instance that this keyframe failed to detect");
    v("edge_depth_guard", edge_depth_guard,
      "Depth-edge guard: mask pixels near the outline whose depth lies behind the mask's nearer "
      "pixels there are background (depth bleeding past the silhouette)");
    v("edge_band_px", edge_band_px,
      "Depth-edge guard: band (px, Chebyshev) along the mask outline and search radius of the "
      "nearer pixels");
    v("edge_depth_tolerance_m", edge_depth_tolerance_m,
      "Depth-edge guard: a band pixel this much (m) behind the mask's nearest pixel around it is "
      "background");
    v("segment_connectivity_guard", segment_connectivity_guard,
      "Connectivity guard: release surfels of an instance detached from its largest 3D component");
    v("segment_link_m", segment_link_m,
      "Connectivity guard: voxel size (m) of the 26-connected components of a segment");
    v("segment_min_component_fraction", segment_min_component_fraction,
      "Connectivity guard: a detached component with at least this share of the instance's surfels "
      "is kept (an object split by an occluder)");
    v("support_plane_guard", support_plane_guard,
      "Support-plane guard: release an instance's surfels lying on a large plane of the map "
      "(table, floor, wall) and oriented like it");
    v("segment_confirmed_surfels_only", segment_confirmed_surfels_only,
      "At finalize, surfels fused in one frame only (never re-observed) leave their instance");
    v("support_plane_max_planes", support_plane_max_planes,
      "Support-plane guard: planes searched (largest first)");
    v("support_plane_min_fraction", support_plane_min_fraction,
      "Support-plane guard: a support plane holds at least this share of the background surfels");
    v("support_plane_min_extent_m", support_plane_min_extent_m,
      "Support-plane guard: a support plane spreads at least this far (m, 4 sigma, both in-plane "
      "axes; an object's face does not)");
    v("support_plane_max_distance_m", support_plane_max_distance_m,
      "Support-plane guard: largest distance (m) from the plane at which a surfel lies on it (the "
      "tolerance is 3 sigma of the plane's own noise, at least 3 mm)");
    v("support_plane_max_points", support_plane_max_points,
      "Support-plane guard: the planes are searched on an evenly strided subset of at most this "
      "many background surfels (0 = all; session 23: the guards 14.6 -> 9.2 ms per keyframe on the "
      "YCB clips' ~200k surfels)");
    v("support_plane_max_normal_angle_deg", support_plane_max_normal_angle_deg,
      "Support-plane guard: a surfel on the plane is support when its normal is within this angle "
      "(deg) of the plane's");
  }
  bool IsValid(std::string* why) const;
};

/// One object instance of the map.
struct InstanceInfo {
  int id = 0;
  std::map<int, double> class_probability_sum;  ///< class id -> sum over detecting keyframes
  int detections = 0;    ///< keyframes that detected it (the t of the class average)
  int first_frame = -1;  ///< frame index of its first / last detection
  int last_frame = -1;
  int visible_keyframes = 0;   ///< keyframes in which it rendered >= min_visible_area_px pixels
  int consecutive_misses = 0;  ///< visible-but-undetected keyframes since its last detection
  int missed_keyframes = 0;    ///< visible-but-undetected keyframes in all
  /// Set by finalize(): its height above the support (segment_height_above_support, m; -1 = none).
  double height_above_support_m = -1;

  /// detections / (detections + missed_keyframes): how often it was detected when it could be.
  double detection_ratio() const;

  /// P(l | I_1..t) = sum / detections, sorted by decreasing probability.
  std::vector<std::pair<int, double>> class_distribution() const;
  int argmax_class() const;  ///< 0 when never detected
  double argmax_probability() const;
};

/// Per-instance geometry read from the map.
struct InstanceGeometry {
  int surfels = 0;
  Eigen::Vector3f min_world = Eigen::Vector3f::Constant(1e30f);  ///< axis-aligned box, m
  Eigen::Vector3f max_world = Eigen::Vector3f::Constant(-1e30f);
};
std::map<int, InstanceGeometry> instance_geometry(const slam::SurfelMap& map);

/// What one keyframe did.
struct SemanticFrameReport {
  int frame_index = 0;
  int detections = 0;
  int associated = 0;  ///< detections joined to an existing instance
  int new_instances = 0;
  int merged_instances = 0;
  int pruned_instances = 0;
  int missed_instances = 0;  ///< visible confirmed instances without a detection
  int surfels_skipped = 0;   ///< observed surfels not updated because of a missed instance
  int surfels_observed = 0;  ///< surfels updated by this frame
  int surfels_labelled = 0;  ///< surfels that got an instance from a detection
  int surfels_released = 0;  ///< surfels that became background
  int boundary_candidates = 0;
  int boundary_joined = 0;      ///< surfels that joined an instance by boundary refinement
  int pixels_behind_edges = 0;  ///< mask pixels dropped by the depth-edge guard
  int surfels_detached = 0;     ///< surfels released by the connectivity guard
  int surfels_on_support = 0;   ///< surfels released by the support-plane guard
  /// Time (ms) of the steps: the map's instance masks rendered, detections associated and pixel
  /// labels fused, the observed surfels updated, the segment guards (connectivity, support
  /// planes); total includes the pruning.
  double render_ms = 0, associate_ms = 0, update_ms = 0, guards_ms = 0, total_ms = 0;
  std::string report() const;
};

/// Association of detection masks to rendered instance masks (the paper's rule).
struct Association {
  int instance_id = 0;                ///< matched instance, 0 = start a new one
  double overlap = 0;                 ///< U of the match (best U when unmatched)
  std::vector<int> also_overlapping;  ///< other instances with U > threshold (merge candidates)
};
std::vector<Association> associate_detections(const std::vector<MaskImage>& masks,
                                              const LabelImage& rendered_instances,
                                              double min_overlap, int min_projected_area_px);

/// Boundary criterion (ii) support: for each pixel, whether an object pixel (label > 0) lies within
/// Chebyshev radius r; and the label of the nearest (Euclidean) object pixel within r, or 0.
class ObjectNeighbourhood {
 public:
  ObjectNeighbourhood(const LabelImage& object_labels, int radius_px);
  bool has_object_pixel(int u, int v) const;
  int nearest_label(int u, int v) const;

 private:
  const LabelImage& labels_;
  int radius_;
  std::vector<std::int32_t> integral_;  // (W + 1) x (H + 1) summed-area table of label > 0
};

class SemanticFusion {
 public:
  explicit SemanticFusion(const SemanticParams& params);

  /// Fuses one keyframe's detections into `map`, which already holds this frame's geometry (call
  /// after tracking and geometric fusion). `frame` provides intrinsics, depth (observation test)
  /// and index. `pixel_surfel` (optional, frame-sized): per pixel the surfel this frame fused the
  /// pixel into
  /// (-1 none), e.g. SlamSystem::last_pixel_surfel(); without it the surfels are found by
  /// rendering.
  SemanticFrameReport integrate(const RgbdFrame& frame, const std::vector<Detection>& detections,
                                const SE3& T_world_cam, slam::SurfelMap& map,
                                const slam::IndexImage* pixel_surfel = nullptr);
  /// End of the run: removes instances detected in too few keyframes or with too few surfels.
  /// Returns the number removed.
  int finalize(slam::SurfelMap& map);
  /// Minimal widths (m) of the class models, for min_height_fraction (classes not listed: no test).
  void set_class_min_widths(std::map<int, double> widths) {
    class_min_width_m_ = std::move(widths);
  }
  /// Removes one instance (its surfels become background).
  void remove_instance(int id, slam::SurfelMap& map);
  /// The support-plane guard (SemanticParams::support_plane_guard); returns the surfels released.
  int release_support_surfels(slam::SurfelMap& map) const;

  const std::map<int, InstanceInfo>& instances() const { return instances_; }
  /// The instance that `id` lives on as: `id` itself unless it was merged into another instance
  /// (then the survivor, following chains of merges). Removed instances resolve to themselves.
  int resolve_instance(int id) const;
  /// Every merge so far: absorbed instance id -> the instance it was merged into.
  const std::map<int, int>& merged_into() const { return merged_into_; }
  const SemanticParams& params() const { return params_; }
  /// The instances detected in >= min_confirmed_detections keyframes.
  std::map<int, InstanceInfo> confirmed_instances() const;
  /// Pixel labels of the last keyframe's associated detections (instance ids, 0 = none).
  const LabelImage& last_detection_labels() const { return detection_labels_; }
  /// Instance image rendered from the map before the last keyframe's update (the M^ masks).
  const LabelImage& last_rendered_instances() const { return view_.instance_id; }
  /// From the next keyframe on: the association's render keeps the render of every surfel over its
  /// window grown by `margin_px` (InstanceRenderOptions::keep_scene), for a later stage at the same
  /// camera and map geometry (the pose stage's projected images); -1 (default): nothing kept.
  void set_keep_scene(int margin_px) { keep_scene_margin_px_ = margin_px; }
  /// The render kept by the last keyframe's association (SceneRender::map null when none).
  const SceneRender& kept_scene() const { return scene_; }
  void drop_kept_scene() { scene_.clear(); }
  /// The label-aware instance images of the map at a pose, as the association renders them.
  void render_instances(const slam::SurfelMap& map, const SE3& T_world_cam,
                        const PinholeIntrinsics& K, bool want_color, InstanceImages* out);

 private:
  void merge_into(int keep, int absorb, slam::SurfelMap& map);
  /// Sets InstanceInfo::height_above_support_m; true when the instance is too low for its class.
  void measure_height(const slam::SurfelMap& map);
  bool too_low(const InstanceInfo& info) const;
  struct UpdateCounts {
    int observed = 0, skipped = 0, labelled = 0, released = 0, candidates = 0, joined = 0;
    void add(const UpdateCounts& o);
  };
  // The steps of integrate() (docs/SEMANTIC.md), in order.
  /// Each detection (in `order`) associated to a rendered instance or a new one; same-class
  /// instances it also overlaps merged. Returns the instance of each detection of `order`.
  std::vector<int> associate(const std::vector<Detection>& detections,
                             const std::vector<size_t>& order, slam::SurfelMap& map,
                             SemanticFrameReport& rep);
  /// One class observation per detected instance (its detections averaged); returns the
  /// instances detected in this keyframe.
  std::set<int> observe_classes(const std::vector<Detection>& detections,
                                const std::vector<size_t>& order,
                                const std::vector<int>& instance_of, int frame_index);
  /// Instances rendered visibly but not detected: their misses counted; the confirmed ones
  /// returned (ascending ids).
  std::vector<int> missed_instances(const std::set<int>& detected);
  /// missed_labels_: the rendered pixels of the `missed` instances.
  void label_missed_pixels(const std::vector<int>& missed, int W, int H);
  /// detection_labels_ and pixel_probability_: the per-pixel fused segmentation.
  void fuse_pixel_labels(const DepthImage& depth, const std::vector<Detection>& detections,
                         const std::vector<size_t>& order, const std::vector<int>& instance_of,
                         const PinholeIntrinsics& K, SemanticFrameReport& rep);
  /// representative_: per surfel of `pixel_surfel`, the listed pixel nearest its projected centre.
  void choose_representative_pixels(const SE3& T_world_cam, const PinholeIntrinsics& K,
                                    const slam::SurfelMap& map,
                                    const slam::IndexImage& pixel_surfel);
  /// update_surfel() for every surfel the frame observed, once each.
  void update_surfels(const RgbdFrame& frame, const SE3& T_world_cam, const PinholeIntrinsics& K,
                      slam::SurfelMap& map, const slam::IndexImage* pixel_surfel, bool skip_missed,
                      SemanticFrameReport& rep);
  /// Removes instances detected rarely and now repeatedly missed, and those left without
  /// surfels; returns how many.
  int prune_instances(slam::SurfelMap& map);
  /// The per-surfel rules for surfel i observed at pixel (u, v).
  void update_surfel(std::int32_t i, int u, int v, const ObjectNeighbourhood& neighbourhood,
                     const ObjectNeighbourhood* missed, slam::SurfelMap& map,
                     UpdateCounts& counts) const;

  SemanticParams params_;
  std::map<int, InstanceInfo> instances_;
  std::map<int, int> merged_into_;  // absorbed -> survivor, kept for later stages (pose tracks)
  std::map<int, double> class_min_width_m_;
  int next_instance_id_ = 1;
  slam::MapRenderer renderer_;
  InstanceRenderer instance_renderer_;
  InstanceImages view_;
  int keep_scene_margin_px_ = -1;
  SceneRender scene_;  // kept by the association's render when keep_scene_margin_px_ >= 0
  slam::IndexMap index_map_;
  LabelImage detection_labels_;
  ProbabilityImage pixel_probability_;
  LabelImage missed_labels_;  // rendered pixels of visible instances that got no detection
  std::vector<std::pair<float, int>> representative_;  // per surfel: (squared px distance, pixel)
  std::vector<float> pixel_d2_;  // per pixel: squared px distance to its surfel's projected centre
};

}  // namespace orpe
