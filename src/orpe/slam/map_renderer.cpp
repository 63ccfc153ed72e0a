#include "orpe/slam/map_renderer.h"

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "orpe/slam/rigid_f.h"

namespace orpe::slam {
namespace {

constexpr std::uint64_t kEmpty = std::numeric_limits<std::uint64_t>::max();

// Positive floats order like their bit patterns, so (depth bits, index) packs into one key whose
// minimum is the nearest surface, ties going to the lower index: deterministic under any schedule.
inline std::uint64_t pack(float depth, std::uint32_t index) {
  return (static_cast<std::uint64_t>(std::bit_cast<std::uint32_t>(depth)) << 32) | index;
}
inline float unpack_depth(std::uint64_t key) {
  return std::bit_cast<float>(static_cast<std::uint32_t>(key >> 32));
}
inline std::int32_t unpack_index(std::uint64_t key) {
  return static_cast<std::int32_t>(key & 0xffffffffu);
}

inline void atomic_min(std::uint64_t& slot, std::uint64_t key) {
  std::atomic_ref<std::uint64_t> ref(slot);
  std::uint64_t cur = ref.load(std::memory_order_relaxed);
  while (key < cur && !ref.compare_exchange_weak(cur, key, std::memory_order_relaxed)) {
  }
}

struct CameraF {
  RigidF T_cam_world;
  float fx, fy, cx, cy;
  int width, height;
  CameraF(const SE3& T_world_cam, const PinholeIntrinsics& K, int scale) {
    T_cam_world = RigidF(T_world_cam.inverse());
    fx = static_cast<float>(K.fx);
    fy = static_cast<float>(K.fy);
    cx = static_cast<float>(K.cx);
    cy = static_cast<float>(K.cy);
    width = K.width * scale;
    height = K.height * scale;
  }
};

// The surfel filter shared by both render modes.
struct SurfelFilter {
  const SurfelMap& map;
  const RenderOptions& o;
  bool operator()(size_t i) const {
    if (o.only_instance > 0 && map.instance_id[i] != o.only_instance) return false;
    if (o.only_labelled && map.instance_id[i] <= 0) return false;
    if (!map.is_active(i, o.now, o.active_window_frames)) return false;
    if (map.last_seen_time[i] > o.seen_until) return false;
    if (map.confidence[i] >= o.min_confidence) return true;
    return o.also_seen_since >= 0 && map.last_seen_time[i] >= o.also_seen_since;
  }
};

// The pixels of the window [ox, ox + W) x [oy, oy + H) (the whole image's rays).
struct Window {
  int ox, oy, W, H;
};

// Calls visit(x, y, t, d2) for every window pixel (x, y) that surfel i's disc covers, with the
// depth t of the pixel ray's intersection with the disc and d2 the squared distance (px^2) from
// the pixel to the projected centre; a splat smaller than a pixel (or missed by every pixel ray)
// still covers its centre's pixel, at the centre's depth. Returns false when the surfel is not
// drawn (behind, back-facing, outside the window).
template <class Visit>
bool splat_surfel(const SurfelMap& map, size_t i, const CameraF& cam, const RenderOptions& options,
                  const Window& win, Visit&& visit) {
  const Vec3f p = cam.T_cam_world(map.position_world[i]);
  const float z = p.z();
  if (z < options.near_m || z > options.far_m) return false;
  const Vec3f nrm = cam.T_cam_world.rotate(map.normal_world[i]);
  const float facing = nrm.dot(p);
  if (facing >= 0.0f) return false;  // back-facing
  const float u = cam.fx * p.x() / z + cam.cx;
  const float v = cam.fy * p.y() / z + cam.cy;
  const float r_m = map.radius_m[i] * options.radius_scale;
  const float r_px = std::min(r_m * std::max(cam.fx, cam.fy) / z, options.max_splat_radius_px);
  const int x_end = win.ox + win.W - 1, y_end = win.oy + win.H - 1;  // the window's last pixel
  if (u + r_px < win.ox - 0.5f || v + r_px < win.oy - 0.5f || u - r_px > x_end + 0.5f ||
      v - r_px > y_end + 0.5f)
    return false;  // nothing of it in the window
  const int uc = static_cast<int>(std::floor(u + 0.5f)),
            vc = static_cast<int>(std::floor(v + 0.5f));
  const int u0 = std::max(win.ox, static_cast<int>(std::ceil(u - r_px)));
  const int u1 = std::min(x_end, static_cast<int>(std::floor(u + r_px)));
  const int v0 = std::max(win.oy, static_cast<int>(std::ceil(v - r_px)));
  const int v1 = std::min(y_end, static_cast<int>(std::floor(v + r_px)));
  const float r2 = r_m * r_m;
  const float inv_fx = 1.0f / cam.fx, inv_fy = 1.0f / cam.fy;
  // The plane n . X = n . p; along the pixel ray X = d * t with d = ((x - cx)/fx, (y - cy)/fy, 1)
  // the intersection's depth is t = (n . p) / (n . d).
  bool centre_drawn = false;
  for (int y = v0; y <= v1; ++y) {
    const float dy = (static_cast<float>(y) - cam.cy) * inv_fy;
    const float py = static_cast<float>(y) - v;
    for (int x = u0; x <= u1; ++x) {
      const float dx = (static_cast<float>(x) - cam.cx) * inv_fx;
      const float nd = nrm.x() * dx + nrm.y() * dy + nrm.z();
      if (nd > -1e-4f) continue;  // grazing ray
      const float t = facing / nd;
      const float ex = dx * t - p.x(), ey = dy * t - p.y(), ez = t - z;
      if (ex * ex + ey * ey + ez * ez > r2 || t < options.near_m) continue;
      const float px = static_cast<float>(x) - u;
      visit(x, y, t, px * px + py * py);
      if (x == uc && y == vc) centre_drawn = true;
    }
  }
  if (!centre_drawn && uc >= win.ox && vc >= win.oy && uc <= x_end && vc <= y_end) {
    const float px = static_cast<float>(uc) - u, py = static_cast<float>(vc) - v;
    visit(uc, vc, z, px * px + py * py);
  }
  return true;
}

}  // namespace

namespace {

// The window of `options` (the whole image when it has none).
Window window_of(const RenderOptions& options, const CameraF& cam) {
  const bool windowed = options.window_width > 0 && options.window_height > 0;
  return {windowed ? options.window_u0 : 0, windowed ? options.window_v0 : 0,
          windowed ? options.window_width : cam.width,
          windowed ? options.window_height : cam.height};
}

// A z-buffer of the window's size, emptied.
std::uint64_t* empty_zbuffer(std::vector<std::uint64_t>& buffer, const Window& win) {
  const size_t npix = static_cast<size_t>(win.W) * win.H;
  if (buffer.size() < npix) buffer.resize(npix);
  std::fill(buffer.data(), buffer.data() + npix, kEmpty);
  return buffer.data();
}

// The key of a splatted pixel: depth with the centre preference, then the surfel index.
inline std::uint64_t splat_key(float t, float d2, float kappa, std::uint32_t index) {
  return pack(t * (1.0f + kappa * d2), index);
}

// The images of `out` (the outputs `options` asks for) from the window's z-buffer `zbuf`. Reads
// only the want_* flags and radius_scale of `options`.
void resolve(const SurfelMap& map, const CameraF& cam, const RenderOptions& options,
             const Window& win, const std::uint64_t* zbuf, size_t drawn, RenderedView* out) {
  const int ox = win.ox, oy = win.oy, W = win.W, H = win.H;
  const float inv_fx = 1.0f / cam.fx, inv_fy = 1.0f / cam.fy;
  ensure_size(out->depth, W, H);
  ensure_size(out->surfel_index, W, H);
  if (options.want_vertex) ensure_size(out->vertex, W, H);
  if (options.want_normal) ensure_size(out->normal, W, H);
  if (options.want_color) ensure_size(out->color, W, H);
  if (options.want_instance) ensure_size(out->instance_id, W, H);
  if (options.want_surfel_centre) ensure_size(out->surfel_centre, W, H);
  out->drawn_surfels = drawn;

#pragma omp parallel for schedule(static)
  for (int yw = 0; yw < H; ++yw) {
    const float dy = (static_cast<float>(yw + oy) - cam.cy) * inv_fy;
    for (int xw = 0; xw < W; ++xw) {
      const size_t k = static_cast<size_t>(yw) * W + xw;
      const std::uint64_t key = zbuf[k];
      if (key == kEmpty) {
        out->depth[k] = 0.0f;
        out->surfel_index[k] = -1;
        if (options.want_vertex) out->vertex[k].setZero();
        if (options.want_normal) out->normal[k].setZero();
        if (options.want_color) out->color[k] = Rgb8{};
        if (options.want_instance) out->instance_id[k] = 0;
        if (options.want_surfel_centre) out->surfel_centre[k].setZero();
        continue;
      }
      const std::int32_t s = unpack_index(key);
      // The key's depth carries the centre preference: recompute the ray-plane intersection.
      const float dx = (static_cast<float>(xw + ox) - cam.cx) * inv_fx;
      const Vec3f p = cam.T_cam_world(map.position_world[s]);
      const Vec3f nrm = cam.T_cam_world.rotate(map.normal_world[s]);
      const float nd = nrm.x() * dx + nrm.y() * dy + nrm.z();
      float t = nd < -1e-4f ? nrm.dot(p) / nd : p.z();
      if (!(t > 0.0f) || std::fabs(t - p.z()) > map.radius_m[s] * options.radius_scale) t = p.z();
      out->depth[k] = t;
      out->surfel_index[k] = s;
      if (options.want_vertex) out->vertex[k] = Vec3f(dx * t, dy * t, t);
      if (options.want_normal) out->normal[k] = nrm;
      if (options.want_color) out->color[k] = map.color[s];
      if (options.want_instance) out->instance_id[k] = map.instance_id[s];
      if (options.want_surfel_centre) out->surfel_centre[k] = p;
    }
  }
}

}  // namespace

void MapRenderer::render(const SurfelMap& map, const SE3& T_world_cam, const PinholeIntrinsics& K,
                         const RenderOptions& options, RenderedView* out) {
  const CameraF cam(T_world_cam, K, 1);
  // The window (ox, oy, W, H) in the image's pixels; every ray below is the whole image's.
  const Window win = window_of(options, cam);
  const int ox = win.ox, oy = win.oy, W = win.W;
  std::uint64_t* zbuf = empty_zbuffer(zbuffer_, win);
  auto slot = [&](std::uint64_t* buf, int x, int y) -> std::uint64_t& {
    return buf[static_cast<size_t>(y - oy) * W + (x - ox)];
  };

  const SurfelFilter keep{map, options};
  const long n = static_cast<long>(map.size());
  const float kappa = options.centre_preference;
  size_t drawn = 0;
  // The surface band's second pass visits only the surfels the first one drew (1 byte each).
  const bool band = options.surface_band_m > 0.0f;
  if (band) drawn_.assign(static_cast<size_t>(n), 0);
  std::uint8_t* drawn_flag = band ? drawn_.data() : nullptr;
#pragma omp parallel for schedule(static, 4096) reduction(+ : drawn)
  for (long i = 0; i < n; ++i) {
    if (!keep(static_cast<size_t>(i))) continue;
    const auto idx = static_cast<std::uint32_t>(i);
    const bool d = splat_surfel(map, static_cast<size_t>(i), cam, options, win,
                                [&](int x, int y, float t, float d2) {
                                  atomic_min(slot(zbuf, x, y), splat_key(t, d2, kappa, idx));
                                });
    drawn += d;
    if (drawn_flag) drawn_flag[i] = d;
  }
  // Second pass: among the discs within surface_band_m behind the nearest, the one whose centre
  // is nearest the pixel (the first pass's key holds the nearest depth, times at most
  // 1 + kappa d2).
  if (band) {
    std::uint64_t* zbuf2 = empty_zbuffer(zbuffer2_, win);
#pragma omp parallel for schedule(static, 4096)
    for (long i = 0; i < n; ++i) {
      if (!drawn_flag[i]) continue;
      const auto idx = static_cast<std::uint32_t>(i);
      splat_surfel(map, static_cast<size_t>(i), cam, options, win,
                   [&](int x, int y, float t, float d2) {
                     if (t <= unpack_depth(slot(zbuf, x, y)) + options.surface_band_m)
                       atomic_min(slot(zbuf2, x, y), pack(d2, idx));
                   });
    }
    zbuf = zbuf2;
  }
  resolve(map, cam, options, win, zbuf, drawn, out);
}

void MapRenderer::render_with_labelled(const SurfelMap& map, const SE3& T_world_cam,
                                       const PinholeIntrinsics& K, const RenderOptions& options,
                                       const RenderOptions& labelled_wants, RenderedView* out,
                                       RenderedView* labelled) {
  if (options.surface_band_m > 0.0f)
    throw std::invalid_argument("MapRenderer::render_with_labelled: no surface band");
  const CameraF cam(T_world_cam, K, 1);
  const Window win = window_of(options, cam);
  const int ox = win.ox, oy = win.oy, W = win.W;
  std::uint64_t* zbuf = empty_zbuffer(zbuffer_, win);
  std::uint64_t* zlab = empty_zbuffer(zbuffer_labelled_, win);
  const SurfelFilter keep{map, options};
  const long n = static_cast<long>(map.size());
  const float kappa = options.centre_preference;
  size_t drawn = 0, drawn_labelled = 0;
#pragma omp parallel for schedule(static, 4096) reduction(+ : drawn, drawn_labelled)
  for (long i = 0; i < n; ++i) {
    if (!keep(static_cast<size_t>(i))) continue;
    const auto idx = static_cast<std::uint32_t>(i);
    const bool has_instance = map.instance_id[static_cast<size_t>(i)] > 0;
    const bool d = splat_surfel(map, static_cast<size_t>(i), cam, options, win,
                                [&](int x, int y, float t, float d2) {
                                  const size_t k = static_cast<size_t>(y - oy) * W + (x - ox);
                                  const std::uint64_t key = splat_key(t, d2, kappa, idx);
                                  atomic_min(zbuf[k], key);
                                  if (has_instance) atomic_min(zlab[k], key);
                                });
    drawn += d;
    drawn_labelled += d && has_instance;
  }
  resolve(map, cam, options, win, zbuf, drawn, out);
  RenderOptions lo = labelled_wants;  // its outputs, the splats' geometry of `options`
  lo.radius_scale = options.radius_scale;
  resolve(map, cam, lo, win, zlab, drawn_labelled, labelled);
}

void MapRenderer::render_index_map(const SurfelMap& map, const SE3& T_world_cam,
                                   const PinholeIntrinsics& K, int supersample,
                                   const RenderOptions& options, IndexMap* out,
                                   bool want_attributes) {
  const int s = std::max(1, supersample);
  const CameraF cam(T_world_cam, K, s);
  const int W = cam.width, H = cam.height;
  const size_t ncell = static_cast<size_t>(W) * H;
  if (zbuffer_.size() < ncell) zbuffer_.resize(ncell);
  std::uint64_t* zbuf = zbuffer_.data();
  std::fill(zbuf, zbuf + ncell, kEmpty);

  const SurfelFilter keep{map, options};
  const long n = static_cast<long>(map.size());
  const float sf = static_cast<float>(s);
  size_t drawn = 0;

#pragma omp parallel for schedule(static, 4096) reduction(+ : drawn)
  for (long i = 0; i < n; ++i) {
    if (!keep(static_cast<size_t>(i))) continue;
    const Vec3f p = cam.T_cam_world(map.position_world[i]);
    const float z = p.z();
    if (z < options.near_m || z > options.far_m) continue;
    // Cell of the projected centre at s x resolution: pixel u covers [u - 0.5, u + 0.5).
    const float cu = (cam.fx * p.x() / z + cam.cx + 0.5f) * sf;
    const float cv = (cam.fy * p.y() / z + cam.cy + 0.5f) * sf;
    if (!(cu >= 0.0f && cv >= 0.0f && cu < static_cast<float>(W) && cv < static_cast<float>(H)))
      continue;
    ++drawn;
    const size_t cell = static_cast<size_t>(cv) * W + static_cast<size_t>(cu);
    atomic_min(zbuf[cell], pack(z, static_cast<std::uint32_t>(i)));
  }

  out->supersample = s;
  ensure_size(out->surfel_index, W, H);
  ensure_size(out->depth, W, H);
  ensure_size(out->position_cam, W, H);
  if (want_attributes) {
    ensure_size(out->normal_world, W, H);
    ensure_size(out->radius_m, W, H);
    ensure_size(out->confidence, W, H);
  }
  out->drawn_surfels = drawn;
#pragma omp parallel for schedule(static)
  for (long k = 0; k < static_cast<long>(ncell); ++k) {
    const std::uint64_t key = zbuf[k];
    if (key == kEmpty) {
      out->surfel_index[k] = -1;
      out->depth[k] = 0.0f;
      out->position_cam[k].setZero();
      continue;
    }
    const std::int32_t i = unpack_index(key);
    out->surfel_index[k] = i;
    out->depth[k] = unpack_depth(key);
    out->position_cam[k] = cam.T_cam_world(map.position_world[i]);
    if (want_attributes) {
      out->normal_world[k] = map.normal_world[i];
      out->radius_m[k] = map.radius_m[i];
      out->confidence[k] = map.confidence[i];
    }
  }
}

}  // namespace orpe::slam
