#include "orpe/semantic/semantic_fusion.h"

#include <fmt/format.h>
#include <algorithm>
#include <chrono>
#include <limits>
#include <numeric>
#include <optional>
#include <set>

#include "orpe/core/error.h"
#include "orpe/semantic/segment_guard.h"

namespace orpe {
namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

constexpr int kMaxBoundaryNibble = 15;

}  // namespace

bool SemanticParams::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (!(object_probability_threshold > 0 && object_probability_threshold < 1))
    return fail("object_probability_threshold must be in (0, 1)");
  if (!(association_min_overlap >= 0 && association_min_overlap < 1))
    return fail("association_min_overlap must be in [0, 1)");
  if (association_min_projected_area_px < 1)
    return fail("association_min_projected_area_px must be >= 1");
  if (!(release_probability >= 0 && release_probability < object_probability_threshold))
    return fail("release_probability must be in [0, object_probability_threshold)");
  if (!(boundary_low_probability >= 0 && boundary_low_probability < boundary_high_probability &&
        boundary_high_probability <= 1))
    return fail("need 0 <= boundary_low_probability < boundary_high_probability <= 1");
  if (!(boundary_pixel_min_probability >= 0 && boundary_pixel_min_probability < 1))
    return fail("boundary_pixel_min_probability must be in [0, 1)");
  if (boundary_neighbourhood_px < 1 || boundary_neighbourhood_px > 50)
    return fail("boundary_neighbourhood_px must be in [1, 50]");
  if (boundary_window_frames < 1 || boundary_window_frames > kMaxBoundaryNibble)
    return fail("boundary_window_frames must be in [1, 15] (stored in 4 bits per surfel)");
  if (boundary_min_count < 1 || boundary_min_count > boundary_window_frames)
    return fail("boundary_min_count must be in [1, boundary_window_frames]");
  if (index_supersample < 1 || index_supersample > 8)
    return fail("index_supersample must be in [1, 8]");
  if (!(mask_splat_radius_px >= 0.5 && mask_splat_radius_px <= 50))
    return fail("mask_splat_radius_px must be in [0.5, 50]");
  if (!(mask_depth_tolerance_m >= 0)) return fail("mask_depth_tolerance_m must be >= 0");
  if (!(mask_splat_radius_scale > 0 && mask_splat_radius_scale <= 4))
    return fail("mask_splat_radius_scale must be in (0, 4]");
  if (!(surfel_depth_tolerance_m > 0) || !(surfel_depth_tolerance_rel >= 0))
    return fail("surfel_depth_tolerance_m must be > 0 and surfel_depth_tolerance_rel >= 0");
  if (min_visible_area_px < 1) return fail("min_visible_area_px must be >= 1");
  if (min_instance_detections < 1) return fail("min_instance_detections must be >= 1");
  if (min_confirmed_detections < 1) return fail("min_confirmed_detections must be >= 1");
  if (prune_missed_keyframes < 1) return fail("prune_missed_keyframes must be >= 1");
  if (min_instance_surfels < 0) return fail("min_instance_surfels must be >= 0");
  if (!(min_detection_ratio >= 0 && min_detection_ratio <= 1))
    return fail("min_detection_ratio must be in [0, 1]");
  if (!(min_height_fraction >= 0 && min_height_fraction <= 1))
    return fail("min_height_fraction must be in [0, 1]");
  if (edge_band_px < 1 || edge_band_px > 50) return fail("edge_band_px must be in [1, 50]");
  if (!(edge_depth_tolerance_m > 0)) return fail("edge_depth_tolerance_m must be > 0");
  if (!(segment_link_m > 0 && segment_link_m <= 1)) return fail("segment_link_m must be in (0, 1]");
  if (!(segment_min_component_fraction >= 0 && segment_min_component_fraction <= 1))
    return fail("segment_min_component_fraction must be in [0, 1]");
  if (support_plane_max_planes < 0 || support_plane_max_planes > 10)
    return fail("support_plane_max_planes must be in [0, 10]");
  if (!(support_plane_min_fraction > 0 && support_plane_min_fraction <= 1))
    return fail("support_plane_min_fraction must be in (0, 1]");
  if (!(support_plane_min_extent_m >= 0)) return fail("support_plane_min_extent_m must be >= 0");
  if (support_plane_max_points != 0 && support_plane_max_points < 1000)
    return fail("support_plane_max_points must be 0 (all) or >= 1000");
  if (!(support_plane_max_distance_m >= 0.003))
    return fail("support_plane_max_distance_m must be >= 0.003 (the tolerance's floor)");
  if (!(support_plane_max_normal_angle_deg >= 0 && support_plane_max_normal_angle_deg <= 90))
    return fail("support_plane_max_normal_angle_deg must be in [0, 90]");
  return true;
}

std::vector<std::pair<int, double>> InstanceInfo::class_distribution() const {
  std::vector<std::pair<int, double>> out;
  if (detections == 0) return out;
  for (const auto& [c, sum] : class_probability_sum) out.emplace_back(c, sum / detections);
  std::stable_sort(out.begin(), out.end(),
                   [](const auto& a, const auto& b) { return a.second > b.second; });
  return out;
}

double InstanceInfo::detection_ratio() const {
  const int chances = detections + missed_keyframes;
  return chances > 0 ? static_cast<double>(detections) / chances : 0.0;
}

int InstanceInfo::argmax_class() const {
  const auto d = class_distribution();
  return d.empty() ? 0 : d.front().first;
}

double InstanceInfo::argmax_probability() const {
  const auto d = class_distribution();
  return d.empty() ? 0.0 : d.front().second;
}

std::map<int, InstanceGeometry> instance_geometry(const slam::SurfelMap& map) {
  std::map<int, InstanceGeometry> out;
  for (size_t i = 0; i < map.size(); ++i) {
    const int id = map.instance_id[i];
    if (id <= 0) continue;
    auto& g = out[id];
    ++g.surfels;
    g.min_world = g.min_world.cwiseMin(map.position_world[i]);
    g.max_world = g.max_world.cwiseMax(map.position_world[i]);
  }
  return out;
}

std::string SemanticFrameReport::report() const {
  return fmt::format(
      "semantic frame {}: {} detections ({} associated, {} new, {} merged, {} pruned, {} missed "
      "instances); surfels: {} observed, {} skipped, {} labelled, {} released, {} boundary "
      "candidates, "
      "{} joined, {} detached; {} mask pixels behind edges; {:.1f} ms (render {:.1f}, associate "
      "{:.1f}, update {:.1f}, guards {:.1f})",
      frame_index, detections, associated, new_instances, merged_instances, pruned_instances,
      missed_instances, surfels_observed, surfels_skipped, surfels_labelled, surfels_released,
      boundary_candidates, boundary_joined, surfels_detached, pixels_behind_edges, total_ms,
      render_ms, associate_ms, update_ms, guards_ms);
}

std::vector<Association> associate_detections(const std::vector<MaskImage>& masks,
                                              const LabelImage& rendered_instances,
                                              double min_overlap, int min_projected_area_px) {
  std::map<int, int> area;
  for (const auto id : rendered_instances)
    if (id > 0) ++area[id];
  std::vector<Association> out(masks.size());
  for (size_t d = 0; d < masks.size(); ++d) {
    const MaskImage& mask = masks[d];
    if (mask.width() != rendered_instances.width() || mask.height() != rendered_instances.height())
      throw ConfigError(fmt::format("associate_detections: mask {} is {}x{}, rendered image {}x{}",
                                    d, mask.width(), mask.height(), rendered_instances.width(),
                                    rendered_instances.height()));
    std::map<int, int> intersection;
    for (size_t k = 0; k < mask.size(); ++k)
      if (mask[k] && rendered_instances[k] > 0) ++intersection[rendered_instances[k]];
    struct Candidate {
      int id, inter;
      double u;
    };
    std::vector<Candidate> candidates;
    for (const auto& [id, inter] : intersection)
      candidates.push_back(
          {id, inter, static_cast<double>(inter) / std::max(area[id], min_projected_area_px)});
    std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
      if (a.u != b.u) return a.u > b.u;
      if (a.inter != b.inter) return a.inter > b.inter;
      return a.id < b.id;
    });
    if (candidates.empty()) continue;
    out[d].overlap = candidates.front().u;
    if (candidates.front().u <= min_overlap) continue;
    out[d].instance_id = candidates.front().id;
    for (size_t c = 1; c < candidates.size(); ++c)
      if (candidates[c].u > min_overlap) out[d].also_overlapping.push_back(candidates[c].id);
  }
  return out;
}

ObjectNeighbourhood::ObjectNeighbourhood(const LabelImage& object_labels, int radius_px)
    : labels_(object_labels), radius_(radius_px) {
  const int W = labels_.width(), H = labels_.height();
  integral_.assign(static_cast<size_t>(W + 1) * (H + 1), 0);
  for (int v = 0; v < H; ++v) {
    std::int32_t row_sum = 0;
    for (int u = 0; u < W; ++u) {
      row_sum += labels_.at(u, v) > 0 ? 1 : 0;
      integral_[static_cast<size_t>(v + 1) * (W + 1) + u + 1] =
          integral_[static_cast<size_t>(v) * (W + 1) + u + 1] + row_sum;
    }
  }
}

bool ObjectNeighbourhood::has_object_pixel(int u, int v) const {
  const int W = labels_.width(), H = labels_.height();
  const int u0 = std::max(0, u - radius_), u1 = std::min(W - 1, u + radius_);
  const int v0 = std::max(0, v - radius_), v1 = std::min(H - 1, v + radius_);
  if (u0 > u1 || v0 > v1) return false;
  auto I = [&](int x, int y) { return integral_[static_cast<size_t>(y) * (W + 1) + x]; };
  return I(u1 + 1, v1 + 1) - I(u0, v1 + 1) - I(u1 + 1, v0) + I(u0, v0) > 0;
}

int ObjectNeighbourhood::nearest_label(int u, int v) const {
  int best = 0, best_d2 = std::numeric_limits<int>::max();
  for (int dv = -radius_; dv <= radius_; ++dv)
    for (int du = -radius_; du <= radius_; ++du) {
      if (!labels_.in_bounds(u + du, v + dv)) continue;
      const int label = labels_.at(u + du, v + dv);
      const int d2 = du * du + dv * dv;
      if (label > 0 && d2 < best_d2) {
        best_d2 = d2;
        best = label;
      }
    }
  return best;
}

SemanticFusion::SemanticFusion(const SemanticParams& params) : params_(params) {
  std::string why;
  if (!params_.IsValid(&why)) throw ConfigError("semantic: " + why);
}

void SemanticFusion::render_instances(const slam::SurfelMap& map, const SE3& T_world_cam,
                                      const PinholeIntrinsics& K, bool want_color,
                                      InstanceImages* out) {
  instance_renderer_.render(map, T_world_cam, K, static_cast<float>(params_.mask_splat_radius_px),
                            static_cast<float>(params_.mask_splat_radius_scale),
                            params_.mask_depth_tolerance_m, want_color, out);
}

std::map<int, InstanceInfo> SemanticFusion::confirmed_instances() const {
  std::map<int, InstanceInfo> out;
  for (const auto& [id, info] : instances_)
    if (info.detections >= params_.min_confirmed_detections) out.emplace(id, info);
  return out;
}

void SemanticFusion::remove_instance(int id, slam::SurfelMap& map) {
  for (size_t i = 0; i < map.size(); ++i)
    if (map.instance_id[i] == id) release_surfel(map, i, params_.always_active_objects);
  instances_.erase(id);
}

void SemanticFusion::merge_into(int keep, int absorb, slam::SurfelMap& map) {
  for (size_t i = 0; i < map.size(); ++i)
    if (map.instance_id[i] == absorb) map.instance_id[i] = keep;
  InstanceInfo& k = instances_.at(keep);
  const InstanceInfo& a = instances_.at(absorb);
  for (const auto& [c, sum] : a.class_probability_sum) k.class_probability_sum[c] += sum;
  k.detections += a.detections;
  if (a.first_frame >= 0 && (k.first_frame < 0 || a.first_frame < k.first_frame))
    k.first_frame = a.first_frame;
  k.last_frame = std::max(k.last_frame, a.last_frame);
  k.visible_keyframes = std::max(k.visible_keyframes, a.visible_keyframes);
  // Keyframes in which both were visible and one was detected count once, as a detection.
  k.missed_keyframes = std::min(k.missed_keyframes, a.missed_keyframes);
  instances_.erase(absorb);
  merged_into_[absorb] = keep;
}

int SemanticFusion::resolve_instance(int id) const {
  // Ids only ever merge into live instances, so the chain ends; the bound guards against a cycle.
  for (size_t hops = 0; hops <= merged_into_.size(); ++hops) {
    const auto it = merged_into_.find(id);
    if (it == merged_into_.end()) break;
    id = it->second;
  }
  return id;
}

void SemanticFusion::UpdateCounts::add(const UpdateCounts& o) {
  observed += o.observed;
  skipped += o.skipped;
  labelled += o.labelled;
  released += o.released;
  candidates += o.candidates;
  joined += o.joined;
}

void SemanticFusion::update_surfel(std::int32_t i, int u, int v,
                                   const ObjectNeighbourhood& neighbourhood,
                                   const ObjectNeighbourhood* missed, slam::SurfelMap& map,
                                   UpdateCounts& counts) const {
  if (missed && missed->has_object_pixel(u, v)) {
    ++counts.skipped;
    return;
  }
  ++counts.observed;
  const float p = pixel_probability_.at(u, v);
  const int label = detection_labels_.at(u, v);
  // p_o: running average over the segmented frames that observed the surfel.
  const std::uint16_t n = map.object_obs_count[i];
  const float p_o = (map.p_object[i] * n + p) / (n + 1.0f);
  map.p_object[i] = p_o;
  if (n < std::numeric_limits<std::uint16_t>::max()) map.object_obs_count[i] = n + 1;
  std::int32_t& instance = map.instance_id[i];
  if (p_o <= static_cast<float>(params_.release_probability)) {
    if (instance > 0) ++counts.released;
    instance = 0;
  } else if (label > 0 && instance == 0) {
    instance = label;
    ++counts.labelled;
  }
  // Boundary refinement; window length and count packed in one byte (high / low nibble).
  std::uint8_t& packed = map.boundary_counter[i];
  if (params_.boundary_refinement && instance == 0 &&
      p_o > static_cast<float>(params_.boundary_low_probability) &&
      p_o < static_cast<float>(params_.boundary_high_probability)) {
    ++counts.candidates;
    int window = (packed >> 4) + 1, count = packed & 0x0f;
    if (p > static_cast<float>(params_.boundary_pixel_min_probability) &&
        neighbourhood.has_object_pixel(u, v))
      ++count;
    if (window >= params_.boundary_window_frames) {
      if (count >= params_.boundary_min_count) {
        const int nearest = neighbourhood.nearest_label(u, v);
        if (nearest > 0) {
          instance = nearest;
          ++counts.joined;
        }
      }
      window = count = 0;
    }
    packed = static_cast<std::uint8_t>((window << 4) | count);
  } else {
    packed = 0;
  }
  if (params_.always_active_objects) map.always_active[i] = instance > 0 ? 1 : 0;
}

SemanticFrameReport SemanticFusion::integrate(const RgbdFrame& frame,
                                              const std::vector<Detection>& detections,
                                              const SE3& T_world_cam, slam::SurfelMap& map,
                                              const slam::IndexImage* pixel_surfel) {
  const auto t_start = Clock::now();
  SemanticFrameReport rep;
  rep.frame_index = frame.index;
  rep.detections = static_cast<int>(detections.size());
  if (frame.depth.empty())
    throw IoError(frame.name, "semantic fusion needs the frame's depth image");
  const int W = frame.depth.width(), H = frame.depth.height();
  PinholeIntrinsics K = frame.intrinsics;
  K.width = W;
  K.height = H;
  for (const auto& d : detections)
    if (d.probability.width() != W || d.probability.height() != H)
      throw IoError(frame.name, fmt::format("detection mask is {}x{}, the frame {}x{}",
                                            d.probability.width(), d.probability.height(), W, H));
  if (pixel_surfel && (pixel_surfel->width() != W || pixel_surfel->height() != H))
    throw ConfigError(fmt::format("semantic fusion: pixel->surfel image is {}x{}, the frame {}x{}",
                                  pixel_surfel->width(), pixel_surfel->height(), W, H));

  // 1. Instance masks M^ rendered from the map (geometry of this frame, semantics of t - 1).
  auto t0 = Clock::now();
  {
    InstanceRenderOptions o;
    o.max_splat_radius_px = static_cast<float>(params_.mask_splat_radius_px);
    o.splat_radius_scale = static_cast<float>(params_.mask_splat_radius_scale);
    o.depth_tolerance_m = params_.mask_depth_tolerance_m;
    o.one_pass = params_.mask_render_one_pass;
    o.keep_scene = keep_scene_margin_px_ >= 0 ? &scene_ : nullptr;
    o.keep_margin_px = keep_scene_margin_px_;
    scene_.clear();
    instance_renderer_.render(map, T_world_cam, K, o, &view_);
  }
  rep.render_ms = ms_since(t0);

  // 2. Association, in order of decreasing score (ties: input order), class observations, the
  // instances seen but not detected, and the fused per-pixel labels.
  t0 = Clock::now();
  std::vector<size_t> order(detections.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return detections[a].score > detections[b].score; });
  const std::vector<int> instance_of = associate(detections, order, map, rep);
  const std::set<int> detected = observe_classes(detections, order, instance_of, frame.index);
  const std::vector<int> missed = missed_instances(detected);
  rep.missed_instances = static_cast<int>(missed.size());
  const bool skip_missed = params_.skip_missed_instances && !missed.empty();
  if (skip_missed) label_missed_pixels(missed, W, H);
  fuse_pixel_labels(frame.depth, detections, order, instance_of, K, rep);
  rep.associate_ms = ms_since(t0);

  // 3. Surfel updates: the surfels this frame observed, each once; then the segment guards.
  t0 = Clock::now();
  update_surfels(frame, T_world_cam, K, map, pixel_surfel, skip_missed, rep);
  rep.update_ms = ms_since(t0);
  t0 = Clock::now();
  if (params_.segment_connectivity_guard) {
    const SE3 T_cam_world = T_world_cam.inverse();
    rep.surfels_detached = release_detached_surfels(map, static_cast<float>(params_.segment_link_m),
                                                    params_.segment_min_component_fraction,
                                                    &T_cam_world, params_.always_active_objects);
  }
  rep.surfels_on_support = release_support_surfels(map);
  rep.guards_ms = ms_since(t0);

  // 4. Spurious instances.
  rep.pruned_instances = prune_instances(map);
  rep.total_ms = ms_since(t_start);
  return rep;
}

std::vector<int> SemanticFusion::associate(const std::vector<Detection>& detections,
                                           const std::vector<size_t>& order, slam::SurfelMap& map,
                                           SemanticFrameReport& rep) {
  const float threshold = static_cast<float>(params_.object_probability_threshold);
  std::vector<MaskImage> masks;
  masks.reserve(order.size());
  for (size_t k : order) masks.push_back(binary_mask(detections[k].probability, threshold));
  const auto assoc = associate_detections(masks, view_.instance_id, params_.association_min_overlap,
                                          params_.association_min_projected_area_px);
  std::vector<int> instance_of(order.size(), 0);
  for (size_t j = 0; j < order.size(); ++j) {
    // An instance merged away earlier in this loop lives on as its survivor (merge_into records
    // it).
    int id = resolve_instance(assoc[j].instance_id);
    if (id > 0) {
      ++rep.associated;
      if (params_.merge_same_class_instances) {
        for (int other : assoc[j].also_overlapping) {
          other = resolve_instance(other);
          if (other == id || !instances_.count(other) || !instances_.count(id)) continue;
          if (instances_[other].argmax_class() != instances_[id].argmax_class()) continue;
          merge_into(id, other, map);
          ++rep.merged_instances;
        }
      }
    } else {
      id = next_instance_id_++;
      InstanceInfo info;
      info.id = id;
      instances_[id] = info;
      ++rep.new_instances;
    }
    instance_of[j] = id;
  }
  return instance_of;
}

std::set<int> SemanticFusion::observe_classes(const std::vector<Detection>& detections,
                                              const std::vector<size_t>& order,
                                              const std::vector<int>& instance_of,
                                              int frame_index) {
  // Class probabilities: one observation per keyframe and instance (detections of one instance in
  // one frame are averaged first).
  std::map<int, std::pair<std::map<int, double>, int>> frame_classes;
  for (size_t j = 0; j < order.size(); ++j) {
    auto& [sum, n] = frame_classes[resolve_instance(instance_of[j])];
    for (const auto& [c, p] : class_distribution(detections[order[j]])) sum[c] += p;
    ++n;
  }
  for (auto& [id, entry] : frame_classes) {
    InstanceInfo& info = instances_.at(id);
    for (const auto& [c, sum] : entry.first) info.class_probability_sum[c] += sum / entry.second;
    ++info.detections;
    if (info.first_frame < 0) info.first_frame = frame_index;
    info.last_frame = frame_index;
    info.consecutive_misses = 0;
  }
  std::set<int> detected;
  for (const auto& entry : frame_classes) detected.insert(entry.first);
  return detected;
}

std::vector<int> SemanticFusion::missed_instances(const std::set<int>& detected) {
  // Rendered instances visible enough this keyframe: those not detected count a miss.
  std::map<int, int> rendered_area;
  for (const auto id : view_.instance_id)
    if (id > 0) ++rendered_area[resolve_instance(id)];
  std::vector<int> missed;
  for (const auto& [id, area] : rendered_area) {
    auto it = instances_.find(id);
    if (it == instances_.end() || area < params_.min_visible_area_px) continue;
    ++it->second.visible_keyframes;
    if (!detected.count(id)) {
      ++it->second.consecutive_misses;
      ++it->second.missed_keyframes;
      if (it->second.detections >= params_.min_confirmed_detections) missed.push_back(id);
    }
  }
  return missed;
}

void SemanticFusion::label_missed_pixels(const std::vector<int>& missed, int W, int H) {
  missed_labels_ = LabelImage(W, H, 0);
  for (size_t k = 0; k < missed_labels_.size(); ++k) {
    const int id = view_.instance_id[k] > 0 ? resolve_instance(view_.instance_id[k]) : 0;
    if (id > 0 && std::binary_search(missed.begin(), missed.end(), id)) missed_labels_[k] = id;
  }
}

void SemanticFusion::fuse_pixel_labels(const DepthImage& depth,
                                       const std::vector<Detection>& detections,
                                       const std::vector<size_t>& order,
                                       const std::vector<int>& instance_of,
                                       const PinholeIntrinsics& K, SemanticFrameReport& rep) {
  const int W = K.width, H = K.height;
  const float threshold = static_cast<float>(params_.object_probability_threshold);
  // Per-pixel fused segmentation: the highest-probability detection above threshold labels a pixel
  // (earlier = higher score wins ties); the pixel's non-background probability is the maximum soft
  // probability over the detections (0 where no detection reaches).
  if (detection_labels_.width() != W || detection_labels_.height() != H) {
    detection_labels_ = LabelImage(W, H, 0);
    pixel_probability_ = ProbabilityImage(W, H, 0.0f);
  } else {
    detection_labels_.fill(0);
    pixel_probability_.fill(0.0f);
  }
  ProbabilityImage label_probability(W, H, 0.0f);
  for (size_t j = 0; j < order.size(); ++j) {
    const ProbabilityImage& prob = detections[order[j]].probability;
    const int id = resolve_instance(instance_of[j]);
    for (size_t k = 0; k < prob.size(); ++k) {
      const float p = prob[k];
      pixel_probability_[k] = std::max(pixel_probability_[k], p);
      if (p >= threshold && p > label_probability[k]) {
        label_probability[k] = p;
        detection_labels_[k] = id;
      }
    }
  }
  if (params_.edge_depth_guard)
    rep.pixels_behind_edges =
        drop_pixels_behind_mask_edges(depth, &detection_labels_, &pixel_probability_,
                                      params_.edge_band_px, params_.edge_depth_tolerance_m, K.fx);
}

void SemanticFusion::update_surfels(const RgbdFrame& frame, const SE3& T_world_cam,
                                    const PinholeIntrinsics& K, slam::SurfelMap& map,
                                    const slam::IndexImage* pixel_surfel, bool skip_missed,
                                    SemanticFrameReport& rep) {
  const int W = K.width, H = K.height;
  const ObjectNeighbourhood neighbourhood(detection_labels_, params_.boundary_neighbourhood_px);
  std::optional<ObjectNeighbourhood> missed_zone;
  if (skip_missed) missed_zone.emplace(missed_labels_, params_.boundary_neighbourhood_px);
  const ObjectNeighbourhood* missed_ptr = missed_zone ? &*missed_zone : nullptr;
  UpdateCounts counts;
  if (pixel_surfel) {
    choose_representative_pixels(T_world_cam, K, map, *pixel_surfel);
    const auto n = static_cast<std::int32_t>(map.size());  // each surfel once: no write conflicts
#pragma omp parallel
    {
      UpdateCounts local;
#pragma omp for schedule(static)
      for (int v = 0; v < H; ++v)
        for (int u = 0; u < W; ++u) {
          const std::int32_t i = pixel_surfel->at(u, v);
          if (i >= 0 && i < n && representative_[i].second == v * W + u)
            update_surfel(i, u, v, neighbourhood, missed_ptr, map, local);
        }
#pragma omp critical
      counts.add(local);
    }
  } else {
    slam::RenderOptions points;
    renderer_.render_index_map(map, T_world_cam, K, params_.index_supersample, points, &index_map_);
    const int s = index_map_.supersample;
    const int Ws = W * s;
    const long cells = static_cast<long>(index_map_.surfel_index.size());
#pragma omp parallel
    {
      UpdateCounts local;
#pragma omp for schedule(static)
      for (long c = 0; c < cells;
           ++c) {  // each surfel lies in at most one cell: no write conflicts
        const std::int32_t i = index_map_.surfel_index[c];
        if (i < 0) continue;
        const int u = static_cast<int>(c % Ws) / s, v = static_cast<int>(c / Ws) / s;
        const float z_frame = frame.depth.at(u, v);
        if (z_frame <= 0.0f) continue;
        const double tol = std::max(params_.surfel_depth_tolerance_m,
                                    params_.surfel_depth_tolerance_rel * z_frame);
        if (std::abs(index_map_.depth[c] - z_frame) > tol) continue;
        update_surfel(i, u, v, neighbourhood, missed_ptr, map, local);
      }
#pragma omp critical
      counts.add(local);
    }
  }
  rep.surfels_observed = counts.observed;
  rep.surfels_skipped = counts.skipped;
  rep.surfels_labelled = counts.labelled;
  rep.surfels_released = counts.released;
  rep.boundary_candidates = counts.candidates;
  rep.boundary_joined = counts.joined;
}

void SemanticFusion::choose_representative_pixels(const SE3& T_world_cam,
                                                  const PinholeIntrinsics& K,
                                                  const slam::SurfelMap& map,
                                                  const slam::IndexImage& pixel_surfel) {
  // A surfel may cover several pixels (the SLAM lists the surfel a pixel updated, created or is
  // covered by): each surfel is updated once, at its listed pixel nearest its projected centre.
  const int W = K.width, H = K.height;
  const auto n = static_cast<std::int32_t>(map.size());
  const SE3 T_cam_world = T_world_cam.inverse();
  const Eigen::Matrix3f R = T_cam_world.rotation().cast<float>();
  const Eigen::Vector3f t = T_cam_world.translation().cast<float>();
  // The pixels' distances in parallel, the choice per surfel in pixel order (the first of equal
  // distances wins).
  pixel_d2_.resize(static_cast<size_t>(W) * H);
#pragma omp parallel for schedule(static)
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      const std::int32_t i = pixel_surfel.at(u, v);
      if (i < 0 || i >= n) continue;
      const Eigen::Vector3f p = R * map.position_world[i] + t;
      float d2 = std::numeric_limits<float>::max() / 2;  // behind the camera: any pixel will do
      if (p.z() > 0) {
        const float du = static_cast<float>(K.fx) * p.x() / p.z() + static_cast<float>(K.cx) - u;
        const float dv = static_cast<float>(K.fy) * p.y() / p.z() + static_cast<float>(K.cy) - v;
        d2 = du * du + dv * dv;
      }
      pixel_d2_[static_cast<size_t>(v) * W + u] = d2;
    }
  representative_.assign(map.size(), {std::numeric_limits<float>::max(), -1});
  for (int k = 0; k < W * H; ++k) {
    const std::int32_t i = pixel_surfel[static_cast<size_t>(k)];
    if (i < 0 || i >= n) continue;
    auto& best = representative_[i];
    if (pixel_d2_[static_cast<size_t>(k)] < best.first)
      best = {pixel_d2_[static_cast<size_t>(k)], k};
  }
}

int SemanticFusion::prune_instances(slam::SurfelMap& map) {
  // Spurious instances: detected rarely and now repeatedly visible without a detection; and
  // instances left without surfels (all released), which can never be rendered or matched again.
  std::map<int, int> surfel_count;
  for (const auto id : map.instance_id)
    if (id > 0) ++surfel_count[id];
  std::vector<int> doomed;
  for (const auto& [id, info] : instances_)
    if ((info.detections < params_.min_instance_detections &&
         info.consecutive_misses >= params_.prune_missed_keyframes) ||
        !surfel_count.count(id))
      doomed.push_back(id);
  for (int id : doomed) remove_instance(id, map);
  return static_cast<int>(doomed.size());
}

int SemanticFusion::release_support_surfels(slam::SurfelMap& map) const {
  if (!params_.support_plane_guard) return 0;
  const auto planes =
      find_support_planes(map, params_.support_plane_max_planes, params_.support_plane_min_fraction,
                          params_.support_plane_min_extent_m, params_.support_plane_max_distance_m,
                          static_cast<size_t>(params_.support_plane_max_points));
  return release_support_plane_surfels(map, planes, params_.support_plane_max_normal_angle_deg,
                                       params_.always_active_objects);
}

void SemanticFusion::measure_height(const slam::SurfelMap& map) {
  const auto planes =
      find_support_planes(map, params_.support_plane_max_planes, params_.support_plane_min_fraction,
                          params_.support_plane_min_extent_m, params_.support_plane_max_distance_m,
                          static_cast<size_t>(params_.support_plane_max_points));
  const auto height = segment_height_above_support(map, planes);
  for (auto& [id, info] : instances_) {
    const auto it = height.find(id);
    info.height_above_support_m = it == height.end() ? -1 : it->second;
  }
}

bool SemanticFusion::too_low(const InstanceInfo& info) const {
  const auto w = class_min_width_m_.find(info.argmax_class());
  return params_.min_height_fraction > 0 && w != class_min_width_m_.end() &&
         info.height_above_support_m >= 0 &&
         info.height_above_support_m < params_.min_height_fraction * w->second;
}

int SemanticFusion::finalize(slam::SurfelMap& map) {
  if (params_.segment_confirmed_surfels_only)
    release_unconfirmed_surfels(map, static_cast<float>(params_.segment_link_m),
                                params_.always_active_objects);
  if (params_.segment_connectivity_guard)
    release_detached_surfels(map, static_cast<float>(params_.segment_link_m),
                             params_.segment_min_component_fraction, nullptr,
                             params_.always_active_objects);
  release_support_surfels(map);
  measure_height(map);
  const auto geometry = instance_geometry(map);
  std::vector<int> doomed;
  for (const auto& [id, info] : instances_) {
    const auto it = geometry.find(id);
    const int surfels = it == geometry.end() ? 0 : it->second.surfels;
    if (info.detections < params_.min_instance_detections ||
        surfels < params_.min_instance_surfels ||
        info.detection_ratio() < params_.min_detection_ratio || too_low(info))
      doomed.push_back(id);
  }
  for (int id : doomed) remove_instance(id, map);
  return static_cast<int>(doomed.size());
}

}  // namespace orpe
