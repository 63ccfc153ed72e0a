#include "orpe/slam/fusion.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>

#include "orpe/core/error.h"
#include "orpe/slam/rigid_f.h"

namespace orpe::slam {
namespace {

constexpr std::int32_t kNoAssoc = -1;
constexpr std::int32_t kNewSurfel = -2;

inline Rgb8 blend(const Rgb8& a, float wa, const Rgb8& b, float wb) {
  const float s = 1.0f / (wa + wb);
  auto mix = [&](std::uint8_t x, std::uint8_t y) {
    return static_cast<std::uint8_t>(std::clamp((wa * x + wb * y) * s + 0.5f, 0.0f, 255.0f));
  };
  return Rgb8{mix(a.r, b.r), mix(a.g, b.g), mix(a.b, b.b)};
}

}  // namespace

bool FusionParams::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (!(max_depth_m > 0)) return fail("max_depth_m must be positive");
  if (!(assoc_max_depth_diff_m > 0)) return fail("assoc_max_depth_diff_m must be positive");
  if (!(assoc_max_normal_angle_rad > 0 && assoc_max_normal_angle_rad <= M_PI))
    return fail("assoc_max_normal_angle_rad must be in (0, pi]");
  if (!(stable_confidence > 0)) return fail("stable_confidence must be positive");
  if (!(confidence_sigma > 0)) return fail("confidence_sigma must be positive");
  if (confidence_radius_px < 0) return fail("confidence_radius_px must be >= 0");
  if (!(max_radius_growth >= 1)) return fail("max_radius_growth must be >= 1");
  if (unstable_max_age_frames < 0) return fail("unstable_max_age_frames must be >= 0");
  if (index_supersample < 1 || index_supersample > 4)
    return fail("index_supersample must be in 1..4");
  if (!(free_space_margin_m > 0)) return fail("free_space_margin_m must be positive");
  if (!(merge_max_distance_factor > 0 && merge_max_distance_factor <= 2))
    return fail("merge_max_distance_factor must be in (0, 2]");
  if (!(merge_max_normal_angle_rad > 0)) return fail("merge_max_normal_angle_rad must be positive");
  if (fusion_level < 0 || fusion_level > 2) return fail("fusion_level must be 0, 1 or 2");
  return true;
}

SurfelFusion::SurfelFusion(const FusionParams& params) : params_(params) {
  std::string why;
  if (!params_.IsValid(&why)) throw ConfigError("slam_fusion: " + why);
}

void downsample_color(const ColorImage& in, int level, ColorImage* out) {
  const int f = 1 << level;
  const int w = in.width() / f, h = in.height() / f;
  ensure_size(*out, w, h);
  const int inv_n = f * f;
  const int shift = 2 * level;  // dividing the non-negative sums by f * f: a shift, not an idiv
#pragma omp parallel for schedule(static)
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      int r = 0, g = 0, b = 0;
      for (int y = v * f; y < v * f + f; ++y)
        for (int x = u * f; x < u * f + f; ++x) {
          const Rgb8 c = in.at(x, y);
          r += c.r;
          g += c.g;
          b += c.b;
        }
      out->at(u, v) = Rgb8{static_cast<std::uint8_t>((r + inv_n / 2) >> shift),
                           static_cast<std::uint8_t>((g + inv_n / 2) >> shift),
                           static_cast<std::uint8_t>((b + inv_n / 2) >> shift)};
    }
}

/// A frame at the fusion level, as the fusion steps read it: depth, normals and colour, the camera,
/// and the observation of a pixel.
struct SurfelFusion::Frame {
  const DepthImage& depth;  ///< raw depth at level 0, else the level's filtered depth
  const NormalImage& normal;
  const ColorImage& color;
  const float color_gain;  ///< the map's brightness over the frame's (multiplies the colours)
  const RigidF T_wc;
  const int W, H, level;
  const float fx, fy, cx, cy, f_mean, max_z, g_norm, inv_2sig2;

  /// Level `lvl` of `frame` (L = frame.levels[lvl]), with its colour.
  Frame(const FramePyramid& frame, int lvl, const FrameLevel& L, const ColorImage& color_at_level,
        float gain, const SE3& T_world_cam, const FusionParams& p)
      : depth(lvl == 0 ? frame.raw_depth : L.depth),
        normal(L.normal),
        color(color_at_level),
        color_gain(gain),
        T_wc(T_world_cam),
        W(L.K.width),
        H(L.K.height),
        level(lvl),
        fx(static_cast<float>(L.K.fx)),
        fy(static_cast<float>(L.K.fy)),
        cx(static_cast<float>(L.K.cx)),
        cy(static_cast<float>(L.K.cy)),
        f_mean(0.5f * (fx + fy)),
        max_z(static_cast<float>(p.max_depth_m)),
        g_norm(p.confidence_radius_px > 0
                   ? static_cast<float>(p.confidence_radius_px)
                   : 0.5f * std::sqrt(static_cast<float>(W) * W + static_cast<float>(H) * H)),
        inv_2sig2(static_cast<float>(1.0 / (2.0 * p.confidence_sigma * p.confidence_sigma))) {}

  /// Colour of pixel (u, v) at the map's brightness (x color_gain).
  Rgb8 colour(int u, int v) const {
    const Rgb8 c = color.at(u, v);
    if (color_gain == 1.0f) return c;
    auto scale = [&](std::uint8_t x) {
      return static_cast<std::uint8_t>(std::clamp(x * color_gain + 0.5f, 0.0f, 255.0f));
    };
    return Rgb8{scale(c.r), scale(c.g), scale(c.b)};
  }

  /// Observation of pixel (u, v): world point, world normal, weight, radius. False if unusable.
  bool observe(int u, int v, Vec3f* p_w, Vec3f* n_w, float* a, float* r) const {
    const float z = depth.at(u, v);
    if (z <= 0.0f || z > max_z) return false;
    const Vec3f& n_c = normal.at(u, v);
    if (n_c.z() == 0.0f && n_c.x() == 0.0f && n_c.y() == 0.0f) return false;
    const Vec3f p_c((static_cast<float>(u) - cx) * z / fx, (static_cast<float>(v) - cy) * z / fy,
                    z);
    *p_w = T_wc(p_c);
    *n_w = T_wc.rotate(n_c);
    const float du = static_cast<float>(u) - cx, dv = static_cast<float>(v) - cy;
    const float g2 = (du * du + dv * dv) / (g_norm * g_norm);
    *a = std::exp(-g2 * inv_2sig2);
    *r = std::sqrt(2.0f) * z / f_mean * std::min(1.0f / std::max(std::fabs(n_c.z()), 1e-6f), 2.0f);
    return true;
  }
};

FusionStats SurfelFusion::fuse(const FramePyramid& frame, const SE3& T_world_cam, std::int32_t now,
                               SurfelMap* map, IndexImage* pixel_surfel, float color_gain) {
  const auto t0 = std::chrono::steady_clock::now();
  auto lap = [t = t0]() mutable {
    const auto now_t = std::chrono::steady_clock::now();
    const double ms = std::chrono::duration<double, std::milli>(now_t - t).count();
    t = now_t;
    return ms;
  };
  FusionStats stats;
  // Source images: full resolution raw depth (ElasticFusion), or the half-resolution filtered
  // level.
  const int level = std::min(params_.fusion_level, static_cast<int>(frame.levels.size()) - 1);
  if (level > 0) downsample_color(frame.color, level, &color_lowres_);
  const FrameLevel& L = frame.levels.at(static_cast<size_t>(level));
  const Frame f(frame, level, L, level == 0 ? frame.color : color_lowres_, color_gain, T_world_cam,
                params_);
  const PinholeIntrinsics& K = L.K;
  RenderOptions opt;
  opt.active_window_frames = params_.active_window_frames;
  opt.now = now;
  opt.far_m = static_cast<float>(params_.max_depth_m + params_.assoc_max_depth_diff_m);
  renderer_.render_index_map(*map, T_world_cam, K, params_.index_supersample, opt, &index_map_,
                             true);
  stats.index_ms = lap();

  associate(f, now, map);
  stats.associate_ms = lap();

  stats.updated = update_surfels(f, now, map);
  if (params_.add_new_surfels) stats.created = add_new_surfels(f, now, map);
  stats.update_ms = lap();

  std::vector<std::uint8_t> removed(map->size(), 0);
  stats.removed_unstable = mark_stale_unstable(now, *map, removed);
  if (params_.remove_free_space_violations)
    stats.removed_free_space = mark_free_space_violations(f, *map, removed);
  merges_.clear();
  if (params_.merge_duplicates) stats.merged = merge_duplicates(map, removed);
  stats.clean_ms = lap();

  remove_marked(frame, f, map, removed, pixel_surfel);
  stats.remove_ms = lap();
  stats.surfels = map->size();
  stats.time_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return stats;
}

void SurfelFusion::associate(const Frame& f, std::int32_t now, SurfelMap* map) {
  const int W = f.W, H = f.H, s = params_.index_supersample;
  const float max_dz = static_cast<float>(params_.assoc_max_depth_diff_m);
  const float min_cos = static_cast<float>(std::cos(params_.assoc_max_normal_angle_rad));
  if (assoc_.width() != W || assoc_.height() != H) {
    assoc_ = IndexImage(W, H, kNoAssoc);
    home_ = Image<std::uint8_t>(W, H, 0);
  }
#pragma omp parallel for schedule(static)
  for (int v = 0; v < H; ++v) {
    for (int u = 0; u < W; ++u) {
      std::int32_t& out = assoc_.at(u, v);
      out = kNoAssoc;
      const float z = f.depth.at(u, v);
      if (z <= 0.0f || z > f.max_z) continue;
      const Vec3f& n_c = f.normal.at(u, v);
      if (n_c.z() == 0.0f && n_c.x() == 0.0f && n_c.y() == 0.0f) continue;
      const Vec3f n_w = f.T_wc.rotate(n_c);
      const Vec3f ray =
          Vec3f((static_cast<float>(u) - f.cx) / f.fx, (static_cast<float>(v) - f.cy) / f.fy, 1.0f)
              .normalized();
      std::int32_t best = kNewSurfel;
      float best_d2 = 0.0f, best_conf = 0.0f;
      auto consider = [&](int x, int y) {
        const std::int32_t idx = index_map_.surfel_index.at(x, y);
        if (idx < 0) return;
        const Vec3f& q = index_map_.position_cam.at(x, y);
        if (std::fabs(q.z() - z) >= max_dz) return;
        const float along = q.dot(ray);
        const float d2 = q.squaredNorm() - along * along;  // squared distance from the ray
        const float r = index_map_.radius_m.at(x, y);
        if (d2 >= r * r) return;  // the ray misses the disc
        if (index_map_.normal_world.at(x, y).dot(n_w) < min_cos) return;
        const float c = index_map_.confidence.at(x, y);
        if (best < 0 || d2 < best_d2 || (d2 == best_d2 && c > best_conf)) {
          best = idx;
          best_d2 = d2;
          best_conf = c;
        }
      };
      // The pixel's own cells first: a surfel centred inside the pixel is (almost always) the one
      // closest to its ray. Only without one, look at the neighbouring pixels' cells.
      for (int y = v * s; y < v * s + s; ++y)
        for (int x = u * s; x < u * s + s; ++x) consider(x, y);
      const bool best_home = best >= 0;
      if (!best_home) {
        const int y0 = std::max(0, (v - 1) * s), y1 = std::min(H * s, (v + 2) * s);
        const int x0 = std::max(0, (u - 1) * s), x1 = std::min(W * s, (u + 2) * s);
        for (int y = y0; y < y1; ++y)
          for (int x = x0; x < x1; ++x)
            if (x / s != u || y / s != v) consider(x, y);
      }
      home_.at(u, v) = best_home ? 1 : 0;
      // A surfel covering this pixel from a neighbouring cell counts as seen; only the pixel whose
      // cell holds its centre updates it (one writer per surfel).
      if (best >= 0 && !best_home)
        std::atomic_ref<std::int32_t>(map->last_seen_time[best])
            .store(now, std::memory_order_relaxed);
      out = best;
    }
  }
}

size_t SurfelFusion::update_surfels(const Frame& f, std::int32_t now, SurfelMap* map) {
  // Each surfel has at most one associated pixel: no races.
  const int W = f.W, H = f.H;
  const float growth = static_cast<float>(params_.max_radius_growth);
  size_t updated = 0;
#pragma omp parallel for schedule(static) reduction(+ : updated)
  for (int v = 0; v < H; ++v) {
    for (int u = 0; u < W; ++u) {
      const std::int32_t i = assoc_.at(u, v);
      if (i < 0 || !home_.at(u, v)) continue;
      Vec3f p_w = Vec3f::Zero(), n_w = Vec3f::Zero();
      float a = 0, r = 0;
      if (!f.observe(u, v, &p_w, &n_w, &a, &r)) continue;
      const float c = map->confidence[i];
      if (r < growth * map->radius_m[i]) {
        const float inv = 1.0f / (c + a);
        map->position_world[i] = (c * map->position_world[i] + a * p_w) * inv;
        Vec3f n = c * map->normal_world[i] + a * n_w;
        const float len = n.norm();
        if (len > 1e-6f) map->normal_world[i] = n / len;
        map->color[i] = blend(map->color[i], c, f.colour(u, v), a);
        map->radius_m[i] = (c * map->radius_m[i] + a * r) * inv;
      }
      map->confidence[i] = c + a;
      map->last_seen_time[i] = now;
      ++updated;
    }
  }
  return updated;
}

size_t SurfelFusion::add_new_surfels(const Frame& f, std::int32_t now, SurfelMap* map) {
  // Row counts, prefix sum, parallel fill (deterministic order).
  const int W = f.W, H = f.H;
  const size_t old_size = map->size();
  row_counts_.assign(static_cast<size_t>(H) + 1, 0);
#pragma omp parallel for schedule(static)
  for (int v = 0; v < H; ++v) {
    std::uint32_t n = 0;
    for (int u = 0; u < W; ++u) n += assoc_.at(u, v) == kNewSurfel;
    row_counts_[static_cast<size_t>(v) + 1] = n;
  }
  for (int v = 0; v < H; ++v)
    row_counts_[static_cast<size_t>(v) + 1] += row_counts_[static_cast<size_t>(v)];
  const size_t added = row_counts_[static_cast<size_t>(H)];
  map->resize(old_size + added);
#pragma omp parallel for schedule(static)
  for (int v = 0; v < H; ++v) {
    size_t k = old_size + row_counts_[static_cast<size_t>(v)];
    for (int u = 0; u < W; ++u) {
      if (assoc_.at(u, v) != kNewSurfel) continue;
      Vec3f p_w = Vec3f::Zero(), n_w = Vec3f::Zero();
      float a = 0, r = 0;
      f.observe(u, v, &p_w, &n_w, &a, &r);  // true: checked during association
      map->position_world[k] = p_w;
      map->normal_world[k] = n_w;
      map->color[k] = f.colour(u, v);
      map->radius_m[k] = r;
      map->confidence[k] = a;
      map->init_time[k] = now;
      map->last_seen_time[k] = now;
      assoc_.at(u, v) = static_cast<std::int32_t>(k);
      ++k;
    }
  }
  return added;
}

size_t SurfelFusion::mark_stale_unstable(std::int32_t now, const SurfelMap& map,
                                         std::vector<std::uint8_t>& removed) const {
  const float stable = static_cast<float>(params_.stable_confidence);
  const int max_age = params_.unstable_max_age_frames;
  size_t removed_unstable = 0;
#pragma omp parallel for schedule(static) reduction(+ : removed_unstable)
  for (long i = 0; i < static_cast<long>(removed.size()); ++i) {
    if (map.confidence[i] < stable && now - map.init_time[i] > max_age) {
      removed[i] = 1;
      ++removed_unstable;
    }
  }
  return removed_unstable;
}

size_t SurfelFusion::mark_free_space_violations(const Frame& f, const SurfelMap& map,
                                                std::vector<std::uint8_t>& removed) const {
  const int s = params_.index_supersample;
  const int IW = f.W * s, IH = f.H * s;
  const float stable = static_cast<float>(params_.stable_confidence);
  const float margin = static_cast<float>(params_.free_space_margin_m);
  size_t fs = 0;
#pragma omp parallel for schedule(static) reduction(+ : fs)
  for (int y = 0; y < IH; ++y) {
    for (int x = 0; x < IW; ++x) {
      const std::int32_t i = index_map_.surfel_index.at(x, y);
      if (i < 0 || index_map_.confidence.at(x, y) >= stable || removed[i] || map.always_active[i])
        continue;
      const float z_live = f.depth.at(x / s, y / s);
      if (z_live <= 0.0f || z_live > f.max_z) continue;
      if (index_map_.depth.at(x, y) < z_live - margin) {
        removed[i] = 1;
        ++fs;
      }
    }
  }
  return fs;
}

size_t SurfelFusion::merge_duplicates(SurfelMap* map, std::vector<std::uint8_t>& removed) {
  const int IW = index_map_.surfel_index.width(), IH = index_map_.surfel_index.height();
  const float stable = static_cast<float>(params_.stable_confidence);
  if (merge_target_.size() < static_cast<size_t>(IW) * IH)
    merge_target_.resize(static_cast<size_t>(IW) * IH);
  const float factor = static_cast<float>(params_.merge_max_distance_factor);
  const float merge_cos = static_cast<float>(std::cos(params_.merge_max_normal_angle_rad));
#pragma omp parallel for schedule(static)
  for (int y = 0; y < IH; ++y) {
    for (int x = 0; x < IW; ++x) {
      std::int32_t& target = merge_target_[static_cast<size_t>(y) * IW + x];
      target = -1;
      const std::int32_t i = index_map_.surfel_index.at(x, y);
      if (i < 0) continue;
      // Decisions use the index map's copies (values before this frame's updates): contiguous
      // reads, and consistent for both sides of a pair.
      const float ci = index_map_.confidence.at(x, y);
      if (ci >= stable || removed[i]) continue;  // only unstable surfels are merged away
      const Vec3f& pi = index_map_.position_cam.at(x, y);
      const float ri = index_map_.radius_m.at(x, y);
      const Vec3f& ni = index_map_.normal_world.at(x, y);
      float best_d2 = 0.0f;
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          if ((dx == 0 && dy == 0) || x + dx < 0 || y + dy < 0 || x + dx >= IW || y + dy >= IH)
            continue;
          const std::int32_t j = index_map_.surfel_index.at(x + dx, y + dy);
          if (j < 0) continue;
          const float cj = index_map_.confidence.at(x + dx, y + dy);
          if (!(cj > ci || (cj == ci && j < i))) continue;
          const float lim = factor * std::min(ri, index_map_.radius_m.at(x + dx, y + dy));
          const float d2 = (index_map_.position_cam.at(x + dx, y + dy) - pi).squaredNorm();
          if (d2 >= lim * lim) continue;
          if (index_map_.normal_world.at(x + dx, y + dy).dot(ni) < merge_cos) continue;
          if (removed[j]) continue;
          if (target < 0 || d2 < best_d2) {
            target = j;
            best_d2 = d2;
          }
        }
      }
    }
  }
  // Phase 2 (sequential, in cell order): merge unless either side was removed meanwhile.
  size_t merged = 0;
  merges_.clear();
  for (size_t k = 0; k < static_cast<size_t>(IW) * IH; ++k) {
    const std::int32_t j = merge_target_[k];
    if (j < 0) continue;
    const std::int32_t i = index_map_.surfel_index[k];
    if (removed[i] || removed[j]) continue;
    const float ci = map->confidence[i], cj = map->confidence[j];
    const float inv = 1.0f / (ci + cj);
    map->position_world[j] = (cj * map->position_world[j] + ci * map->position_world[i]) * inv;
    const Vec3f n = cj * map->normal_world[j] + ci * map->normal_world[i];
    if (n.norm() > 1e-6f) map->normal_world[j] = n.normalized();
    map->color[j] = blend(map->color[j], cj, map->color[i], ci);
    map->radius_m[j] = (cj * map->radius_m[j] + ci * map->radius_m[i]) * inv;
    map->confidence[j] = ci + cj;
    map->init_time[j] = std::min(map->init_time[j], map->init_time[i]);
    map->last_seen_time[j] = std::max(map->last_seen_time[j], map->last_seen_time[i]);
    map->always_active[j] =
        static_cast<std::uint8_t>(map->always_active[j] | map->always_active[i]);
    removed[i] = 1;
    merges_.emplace_back(i, j);  // a pixel that updated i now points at j
    ++merged;
  }
  return merged;
}

void SurfelFusion::remove_marked(const FramePyramid& frame, const Frame& f, SurfelMap* map,
                                 const std::vector<std::uint8_t>& removed,
                                 IndexImage* pixel_surfel) {
  const int W = f.W, H = f.H, level = f.level;
  const size_t n_all = removed.size();
  std::vector<std::uint32_t> removal_list;
  for (size_t i = 0; i < n_all; ++i)
    if (removed[i]) removal_list.push_back(static_cast<std::uint32_t>(i));
  std::vector<std::uint32_t> moved_from;
  if (pixel_surfel && !removal_list.empty()) {
    // Where each removed surfel went: merged ones live on in their target.
    std::vector<std::int32_t> redirect(n_all);
    for (size_t i = 0; i < n_all; ++i) redirect[i] = removed[i] ? -1 : static_cast<std::int32_t>(i);
    for (const auto& [from, to] : merges_) redirect[from] = to;
    auto resolve = [&](std::int32_t i) {
      while (i >= 0 && redirect[i] != i) i = redirect[i];  // follow merge chains
      return i;
    };
    map->remove(removal_list, &moved_from);
    std::vector<std::int32_t> old_to_new(n_all, -1);
    for (size_t i = 0; i < moved_from.size(); ++i)
      old_to_new[moved_from[i]] = static_cast<std::int32_t>(i);
#pragma omp parallel for schedule(static)
    for (long k = 0; k < static_cast<long>(W) * H; ++k) {
      const std::int32_t i = assoc_[k];
      const std::int32_t r = i < 0 ? -1 : resolve(i);
      assoc_[k] = r < 0 ? -1 : old_to_new[r];
    }
  } else if (!removal_list.empty()) {
    map->remove(removal_list);
  }
  if (pixel_surfel) {
    // Per full-resolution pixel (each pixel of a coarser fusion level covers a block).
    const int FW = frame.raw_depth.width(), FH = frame.raw_depth.height();
    if (pixel_surfel->width() != FW || pixel_surfel->height() != FH)
      *pixel_surfel = IndexImage(FW, FH, -1);
#pragma omp parallel for schedule(static)
    for (int v = 0; v < FH; ++v)
      for (int u = 0; u < FW; ++u) {
        const int fu = std::min(u >> level, W - 1), fv = std::min(v >> level, H - 1);
        pixel_surfel->at(u, v) = std::max(assoc_.at(fu, fv), -1);
      }
  }
}

}  // namespace orpe::slam
