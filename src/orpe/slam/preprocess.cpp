#include "orpe/slam/preprocess.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "orpe/core/error.h"

namespace orpe::slam {
namespace {

constexpr int kRangeLutMm = 1000;  // range weights tabulated per millimetre up to this difference

using Float4 = float __attribute__((vector_size(16)));
using Int4 = std::int32_t __attribute__((vector_size(16)));

// The bilateral filter's tabulated weights and half-window.
struct BilateralKernel {
  const float* range_lut;  // per millimetre of depth difference
  const float* space_lut;  // per window offset, (2r+1)^2
  int r;
};

// Filtered depth of pixel (u, v) with depth zc > 0: neighbours without depth or farther than the
// range table do not contribute.
float bilateral_pixel(const DepthImage& src, const BilateralKernel& k, int u, int v, float zc) {
  const int w = src.width(), h = src.height(), r = k.r, side = 2 * r + 1;
  float sw = 0.0f, sz = 0.0f;
  const int y0 = std::max(0, v - r), y1 = std::min(h - 1, v + r);
  const int x0 = std::max(0, u - r), x1 = std::min(w - 1, u + r);
  for (int y = y0; y <= y1; ++y) {
    const float* row = src.row(y);
    const float* srow = k.space_lut + (y - v + r) * side + r - u;
    for (int x = x0; x <= x1; ++x) {
      const float z = row[x];
      const int mm = static_cast<int>(std::fabs(z - zc) * 1000.0f + 0.5f);
      if (z <= 0.0f || mm > kRangeLutMm) continue;
      const float wgt = srow[x] * k.range_lut[mm];
      sw += wgt;
      sz += wgt * z;
    }
  }
  return sz / sw;  // sw >= 1 (the centre pixel)
}

// bilateral_pixel for pixels u..u+3 of row v, whose windows lie inside the image. Each lane sums
// the same terms in the same order (a skipped neighbour adds +0), so the results are identical.
Float4 bilateral_4(const DepthImage& src, const BilateralKernel& k, int u, int v, Float4 zc) {
  const int r = k.r, side = 2 * r + 1;
  Float4 sw = {}, sz = {};
  for (int y = v - r; y <= v + r; ++y) {
    const float* row = src.row(y) + u;
    const float* srow = k.space_lut + (y - v + r) * side + r;
    for (int dx = -r; dx <= r; ++dx) {
      Float4 z;
      std::memcpy(&z, row + dx, sizeof z);
      const Float4 d = z - zc;
      const Float4 ad = (Float4)((Int4)d & 0x7fffffff);  // |d|
      const Int4 mm = __builtin_convertvector(ad * 1000.0f + 0.5f, Int4);
      const Int4 ok = (z > 0.0f) & (mm >= 0) & (mm <= kRangeLutMm);
      const Int4 i = mm & ok;
      const Float4 range = {k.range_lut[i[0]], k.range_lut[i[1]], k.range_lut[i[2]], k.range_lut[i[3]]};
      const Float4 wgt = (Float4)((Int4)(srow[dx] * range) & ok);
      sw += wgt;
      sz += wgt * z;
    }
  }
  return sz / sw;
}

}  // namespace

bool PreprocessParams::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (pyramid_levels < 1 || pyramid_levels > 5) return fail("pyramid_levels must be in 1..5");
  if (!(min_depth_m >= 0 && max_depth_m > min_depth_m)) return fail("need 0 <= min_depth_m < max_depth_m");
  if (bilateral_radius_px < 0 || bilateral_radius_px > 8) return fail("bilateral_radius_px must be in 0..8");
  if (!(bilateral_sigma_space_px > 0 && bilateral_sigma_depth_m > 0))
    return fail("bilateral sigmas must be positive");
  if (!(pyramid_max_depth_jump_m > 0)) return fail("pyramid_max_depth_jump_m must be positive");
  if (!(normal_max_depth_jump_m > 0)) return fail("normal_max_depth_jump_m must be positive");
  return true;
}

FramePreprocessor::FramePreprocessor(const PreprocessParams& params, int level0_normal_step)
    : params_(params), level0_normal_step_(std::max(1, level0_normal_step)) {
  std::string why;
  if (!params_.IsValid(&why)) throw ConfigError("slam_preprocess: " + why);
  const double sd = params_.bilateral_sigma_depth_m;
  range_lut_.resize(kRangeLutMm + 1);
  for (int mm = 0; mm <= kRangeLutMm; ++mm) {
    const double d = mm * 1e-3;
    const float w = static_cast<float>(std::exp(-d * d / (2 * sd * sd)));
    range_lut_[mm] = w < 1e-4f ? 0.0f : w;
  }
  const int r = params_.bilateral_radius_px;
  const double ss = params_.bilateral_sigma_space_px;
  space_lut_.resize(static_cast<size_t>((2 * r + 1) * (2 * r + 1)));
  for (int dy = -r; dy <= r; ++dy)
    for (int dx = -r; dx <= r; ++dx)
      space_lut_[static_cast<size_t>((dy + r) * (2 * r + 1) + dx + r)] =
          static_cast<float>(std::exp(-(dx * dx + dy * dy) / (2 * ss * ss)));
}

void color_to_intensity(const ColorImage& color, IntensityImage* out) {
  ensure_size(*out, color.width(), color.height());
  const long n = static_cast<long>(color.size());
#pragma omp parallel for schedule(static)
  for (long i = 0; i < n; ++i) {
    const Rgb8 c = color[i];
    (*out)[i] = 0.299f * c.r + 0.587f * c.g + 0.114f * c.b;
  }
}

void downsample_depth(const DepthImage& in, float max_jump_m, DepthImage* out) {
  const int w = in.width() / 2, h = in.height() / 2;
  ensure_size(*out, w, h);
#pragma omp parallel for schedule(static)
  for (int v = 0; v < h; ++v) {
    const float* r0 = in.row(2 * v);
    const float* r1 = in.row(2 * v + 1);
    float* o = out->row(v);
    for (int u = 0; u < w; ++u) {
      const float d[4] = {r0[2 * u], r0[2 * u + 1], r1[2 * u], r1[2 * u + 1]};
      float ref = 0.0f, sum = 0.0f;
      int n = 0;
      for (float x : d) {
        if (x <= 0.0f) continue;
        if (ref == 0.0f) ref = x;
        if (std::fabs(x - ref) > max_jump_m) continue;
        sum += x;
        ++n;
      }
      o[u] = n > 0 ? sum / static_cast<float>(n) : 0.0f;
    }
  }
}

void downsample_intensity(const IntensityImage& in, IntensityImage* out) {
  const int w = in.width() / 2, h = in.height() / 2;
  ensure_size(*out, w, h);
#pragma omp parallel for schedule(static)
  for (int v = 0; v < h; ++v) {
    const float* r0 = in.row(2 * v);
    const float* r1 = in.row(2 * v + 1);
    float* o = out->row(v);
    for (int u = 0; u < w; ++u)
      o[u] = 0.25f * (r0[2 * u] + r0[2 * u + 1] + r1[2 * u] + r1[2 * u + 1]);
  }
}

void compute_gradients(const IntensityImage& in, Image<float>* gu, Image<float>* gv) {
  const int w = in.width(), h = in.height();
  ensure_size(*gu, w, h);
  ensure_size(*gv, w, h);
#pragma omp parallel for schedule(static)
  for (int v = 0; v < h; ++v) {
    float* ou = gu->row(v);
    float* ov = gv->row(v);
    if (v == 0 || v == h - 1) {
      std::fill(ou, ou + w, 0.0f);
      std::fill(ov, ov + w, 0.0f);
      continue;
    }
    const float* a = in.row(v - 1);
    const float* b = in.row(v);
    const float* c = in.row(v + 1);
    ou[0] = ov[0] = ou[w - 1] = ov[w - 1] = 0.0f;
    for (int u = 1; u < w - 1; ++u) {
      ou[u] = ((a[u + 1] - a[u - 1]) + 2.0f * (b[u + 1] - b[u - 1]) + (c[u + 1] - c[u - 1])) * 0.125f;
      ov[u] = ((c[u - 1] - a[u - 1]) + 2.0f * (c[u] - a[u]) + (c[u + 1] - a[u + 1])) * 0.125f;
    }
  }
}

void compute_vertex_map(const DepthImage& depth, const PinholeIntrinsics& K, VertexImage* vertex) {
  const int w = depth.width(), h = depth.height();
  ensure_size(*vertex, w, h);
  const float fx_inv = static_cast<float>(1.0 / K.fx), fy_inv = static_cast<float>(1.0 / K.fy);
  const float cx = static_cast<float>(K.cx), cy = static_cast<float>(K.cy);
#pragma omp parallel for schedule(static)
  for (int v = 0; v < h; ++v) {
    const float* d = depth.row(v);
    Vec3f* o = vertex->row(v);
    const float y = (static_cast<float>(v) - cy) * fy_inv;
    for (int u = 0; u < w; ++u) {
      const float z = d[u];
      o[u] = z > 0.0f ? Vec3f((static_cast<float>(u) - cx) * fx_inv * z, y * z, z) : Vec3f::Zero();
    }
  }
}

void compute_normal_map(const VertexImage& vertex, double max_depth_jump_per_m, NormalImage* normal,
                        int step) {
  const int w = vertex.width(), h = vertex.height();
  ensure_size(*normal, w, h);
  const float jump = static_cast<float>(max_depth_jump_per_m);
  step = std::max(1, step);
#pragma omp parallel for schedule(static)
  for (int v = 0; v < h; ++v) {
    Vec3f* o = normal->row(v);
    if (step > 1) std::fill(o, o + w, Vec3f::Zero());
    if (v % step != 0) continue;
    for (int u = 0; u < w; u += step) {
      o[u].setZero();
      if (u == 0 || v == 0 || u == w - 1 || v == h - 1) continue;
      const Vec3f& c = vertex.at(u, v);
      if (c.z() <= 0.0f) continue;
      const Vec3f& l = vertex.at(u - 1, v);
      const Vec3f& r = vertex.at(u + 1, v);
      const Vec3f& t = vertex.at(u, v - 1);
      const Vec3f& b = vertex.at(u, v + 1);
      // Central differences; fall back to one-sided ones where a neighbour is missing or across an edge.
      const float lim = jump * c.z();
      auto ok = [&](const Vec3f& q) { return q.z() > 0.0f && std::fabs(q.z() - c.z()) < lim; };
      const bool lo = ok(l), ro = ok(r), to = ok(t), bo = ok(b);
      if (!(lo || ro) || !(to || bo)) continue;
      const Vec3f du = (ro ? r : c) - (lo ? l : c);
      const Vec3f dv = (bo ? b : c) - (to ? t : c);
      Vec3f n = du.cross(dv);
      const float len = n.norm();
      if (!(len > 0.0f)) continue;
      n /= len;
      if (n.dot(c) > 0.0f) n = -n;  // face the camera
      o[u] = n;
    }
  }
}

void FramePreprocessor::bilateral(const DepthImage& src, DepthImage* out) const {
  const int w = src.width(), h = src.height(), r = params_.bilateral_radius_px;
  const BilateralKernel k{range_lut_.data(), space_lut_.data(), r};
#pragma omp parallel for schedule(static)
  for (int v = 0; v < h; ++v) {
    const float* zrow = src.row(v);
    float* o = out->row(v);
    int u = 0;
    if (v >= r && v < h - r) {  // four pixels at a time between the left and right borders
      for (; u < r; ++u) o[u] = zrow[u] > 0.0f ? bilateral_pixel(src, k, u, v, zrow[u]) : 0.0f;
      for (; u + 4 <= w - r; u += 4) {
        Float4 zc;
        std::memcpy(&zc, zrow + u, sizeof zc);
        const Int4 valid = zc > 0.0f;
        Float4 z = {};
        if (valid[0] | valid[1] | valid[2] | valid[3])
          z = (Float4)((Int4)bilateral_4(src, k, u, v, zc) & valid);
        std::memcpy(o + u, &z, sizeof z);
      }
    }
    for (; u < w; ++u) o[u] = zrow[u] > 0.0f ? bilateral_pixel(src, k, u, v, zrow[u]) : 0.0f;
  }
}

void FramePreprocessor::process(const RgbdFrame& frame, FramePyramid* out) const {
  const PinholeIntrinsics& K = frame.intrinsics;
  const int w = K.width, h = K.height;
  if (frame.depth.width() != w || frame.depth.height() != h || frame.color.width() != w ||
      frame.color.height() != h)
    throw ConfigError("frame '" + frame.name + "': colour " + std::to_string(frame.color.width()) + "x" +
                      std::to_string(frame.color.height()) + " and depth " +
                      std::to_string(frame.depth.width()) + "x" + std::to_string(frame.depth.height()) +
                      " must match the intrinsics " + std::to_string(w) + "x" + std::to_string(h));
  const int levels = params_.pyramid_levels;
  out->levels.resize(static_cast<size_t>(levels));
  out->color = frame.color;

  // Depth cut.
  ensure_size(out->raw_depth, w, h);
  const float dmin = static_cast<float>(params_.min_depth_m), dmax = static_cast<float>(params_.max_depth_m);
  const long n = static_cast<long>(frame.depth.size());
#pragma omp parallel for schedule(static)
  for (long i = 0; i < n; ++i) {
    const float z = frame.depth[i];
    out->raw_depth[i] = (z >= dmin && z <= dmax) ? z : 0.0f;
  }

  // Bilateral filter of the level-0 depth (invalid pixels stay invalid and do not contribute).
  FrameLevel& L0 = out->levels[0];
  L0.K = K;
  ensure_size(L0.depth, w, h);
  const int r = params_.bilateral_radius_px;
  if (r == 0) {
    L0.depth = out->raw_depth;
  } else {
    bilateral(out->raw_depth, &L0.depth);
  }
  color_to_intensity(frame.color, &L0.intensity);

  for (int l = 1; l < levels; ++l) {
    FrameLevel& prev = out->levels[static_cast<size_t>(l - 1)];
    FrameLevel& cur = out->levels[static_cast<size_t>(l)];
    cur.K = K.scaled(l);
    downsample_depth(prev.depth, static_cast<float>(params_.pyramid_max_depth_jump_m), &cur.depth);
    downsample_intensity(prev.intensity, &cur.intensity);
  }
  for (size_t l = 0; l < out->levels.size(); ++l) {
    FrameLevel& L = out->levels[l];
    compute_vertex_map(L.depth, L.K, &L.vertex);
    compute_normal_map(L.vertex, params_.normal_max_depth_jump_m, &L.normal,
                       l == 0 ? level0_normal_step_ : 1);
    compute_gradients(L.intensity, &L.grad_u, &L.grad_v);
  }
}

}  // namespace orpe::slam
