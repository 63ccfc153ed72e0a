#include "orpe/synth/sensor.h"

#include <algorithm>
#include <cmath>

namespace orpe::synth {
namespace {
constexpr double kMaxThetaRad = 80.0 * M_PI / 180.0;

/// Counter-based random numbers: a hash of (stream key, pixel, draw), so a pixel's draws do not
/// depend on how many numbers other pixels used (cheaper than a sequential engine, and order-free).
struct PixelRandom {
  std::uint64_t key;
  static std::uint64_t mix(std::uint64_t x) {  // splitmix64 finaliser
    x += 0x9E3779B97F4A7C15ull;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
    return x ^ (x >> 31);
  }
  std::uint64_t bits(std::uint64_t pixel, std::uint64_t draw) const {
    return mix(key ^ mix(pixel * 16 + draw));
  }
  double uniform(std::uint64_t pixel, std::uint64_t draw) const {
    return (bits(pixel, draw) >> 11) * (1.0 / 9007199254740992.0);
  }
  /// Standard normal (Box-Muller).
  double normal(std::uint64_t pixel, std::uint64_t draw) const {
    const double u1 = std::max(uniform(pixel, draw), 1e-300), u2 = uniform(pixel, draw + 1);
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
  }
  /// Approximately normal (sum of four 16-bit uniforms, Irwin-Hall), for colour noise.
  float normal_approx(std::uint64_t pixel, std::uint64_t draw) const {
    const std::uint64_t b = bits(pixel, draw);
    const float s =
        static_cast<float>((b & 0xffff) + ((b >> 16) & 0xffff) + ((b >> 32) & 0xffff) + (b >> 48));
    return (s / 65535.0f - 2.0f) * 1.7320508f;  // mean 0, variance 1
  }
};
}  // namespace

bool DepthSensorParams::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (!(min_depth_m >= 0) || !(max_depth_m > min_depth_m))
    return fail("need 0 <= min_depth_m < max_depth_m");
  if (!(baseline_m > 0)) return fail("baseline_m must be > 0");
  if (!(disparity_subpixel > 0)) return fail("disparity_subpixel must be > 0");
  if (noise_scale < 0 || lateral_sigma_px < 0)
    return fail("noise_scale and lateral_sigma_px must be >= 0");
  if (!(grazing_start_deg <= grazing_max_deg) || grazing_max_deg > 90)
    return fail("need grazing_start_deg <= grazing_max_deg <= 90");
  if (edge_dropout < 0 || edge_dropout > 1 || dropout < 0 || dropout > 1)
    return fail("dropout probabilities must be in [0, 1]");
  return true;
}

double axial_noise_sigma_m(double z, double theta) {
  const double th = std::clamp(theta, 0.0, kMaxThetaRad);
  const double h = M_PI / 2 - th;
  return 0.0012 + 0.0019 * (z - 0.4) * (z - 0.4) +
         0.0001 / std::sqrt(std::max(z, 1e-3)) * th * th / (h * h);
}

double quantisation_step_m(double z, double f, const DepthSensorParams& p) {
  return z * z / (f * p.baseline_m * p.disparity_subpixel);
}

double depth_error_bound_m(double z, double theta, double f, const DepthSensorParams& p) {
  return 5.0 * p.noise_scale * axial_noise_sigma_m(z, theta) + quantisation_step_m(z, f, p);
}

namespace {

/// 1. Projector shadows, row by row: projector column of a point = u - f b / z. Scanning from the
/// projector's side (right to left), a point is lit only if no point to its right maps to a
/// projector column at or left of its own. Marks them 1 in `invalid`.
void mark_projector_shadows(const DepthImage& clean, double f, const DepthSensorParams& p,
                            MaskImage& invalid, DepthSensorStats& st) {
  const int W = clean.width(), H = clean.height();
  const double fb = f * p.baseline_m;
  for (int v = 0; v < H; ++v) {
    double min_col = 1e30;
    for (int u = W - 1; u >= 0; --u) {
      const float z = clean.at(u, v);
      if (z <= 0) continue;
      const double col = u - fb / z;
      if (col > min_col + 0.5) {
        invalid.at(u, v) = 1;
        ++st.shadowed;
      }
      min_col = std::min(min_col, col);
    }
  }
}

/// 2. Grazing angles: invalid (2) beyond grazing_max_deg, with a growing probability from
/// grazing_start_deg. Returns each pixel's incidence angle (rad).
Image<float> mark_grazing(const DepthImage& clean, const Image<Eigen::Vector3f>& normals,
                          const PinholeIntrinsics& K, const DepthSensorParams& p,
                          const PixelRandom& R, MaskImage& invalid, DepthSensorStats& st) {
  const int W = clean.width(), H = clean.height();
  const double cos_max = std::cos(p.grazing_max_deg * M_PI / 180.0);
  const double cos_start = std::cos(p.grazing_start_deg * M_PI / 180.0);
  Image<float> theta_img(W, H, 0.0f);
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      const float z = clean.at(u, v);
      if (z <= 0) continue;
      if (invalid.at(u, v)) continue;
      const Eigen::Vector3d ray =
          Eigen::Vector3d((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0).normalized();
      const Eigen::Vector3f n = normals.empty() ? Eigen::Vector3f(0, 0, -1) : normals.at(u, v);
      const double c = std::abs(ray.dot(n.cast<double>()));
      theta_img.at(u, v) = static_cast<float>(std::acos(std::min(1.0, c)));
      const double r = c < cos_start ? R.uniform(static_cast<std::uint64_t>(v) * W + u, 0) : 1.0;
      if (c < cos_max || (c < cos_start && r < (cos_start - c) / (cos_start - cos_max))) {
        invalid.at(u, v) = 2;
        ++st.grazing;
      }
    }
  return theta_img;
}

/// 3. Depth edges of the clean image: dropped (3) with edge_dropout, else the depth of a pixel
/// jittered by lateral_sigma_px.
void jitter_edges(const DepthImage& clean, const DepthSensorParams& p, const PixelRandom& R,
                  MaskImage& invalid, DepthImage& out, DepthSensorStats& st) {
  const int W = clean.width(), H = clean.height();
  auto is_edge = [&](int u, int v) {
    const float z = clean.at(u, v);
    const double thr = p.edge_jump_m + 0.02 * z;
    for (int dv = -1; dv <= 1; ++dv)
      for (int du = -1; du <= 1; ++du) {
        if (!clean.in_bounds(u + du, v + dv)) continue;
        const float zn = clean.at(u + du, v + dv);
        if (zn <= 0 || std::abs(zn - z) > thr) return true;
      }
    return false;
  };
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      if (clean.at(u, v) <= 0 || invalid.at(u, v) || !is_edge(u, v)) continue;
      const std::uint64_t pix = static_cast<std::uint64_t>(v) * W + u;
      const double r = R.uniform(pix, 1);
      const double du = p.lateral_sigma_px * R.normal(pix, 2),
                   dv = p.lateral_sigma_px * R.normal(pix, 4);
      if (r < p.edge_dropout) {
        invalid.at(u, v) = 3;
        ++st.edges;
        continue;
      }
      // Lateral jitter at edges: take the depth of a nearby pixel.
      const int su = std::clamp(u + static_cast<int>(std::lround(du)), 0, W - 1);
      const int sv = std::clamp(v + static_cast<int>(std::lround(dv)), 0, H - 1);
      out.at(u, v) = clean.at(su, sv);
      if (out.at(u, v) <= 0) invalid.at(u, v) = 3;
    }
}

/// 4-6. Axial noise, disparity quantisation, range, dropouts.
void add_axial_noise(const DepthImage& clean, const Image<float>& theta_img, double f,
                     const DepthSensorParams& p, const PixelRandom& R, const MaskImage& invalid,
                     DepthImage& out, DepthSensorStats& st) {
  const int W = clean.width(), H = clean.height();
  const double fb = f * p.baseline_m;
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      const float z0 = out.at(u, v);
      if (clean.at(u, v) <= 0) continue;
      if (invalid.at(u, v) || z0 <= 0) {
        out.at(u, v) = 0;
        continue;
      }
      const std::uint64_t pix = static_cast<std::uint64_t>(v) * W + u;
      const double n = R.normal(pix, 6), r = R.uniform(pix, 8);
      double z = z0 + p.noise_scale * axial_noise_sigma_m(z0, theta_img.at(u, v)) * n;
      if (z <= 0.05) {
        out.at(u, v) = 0;
        continue;
      }
      const double d = std::round(fb / z * p.disparity_subpixel) / p.disparity_subpixel;
      z = d > 0 ? fb / d : 0.0;
      if (z < p.min_depth_m || z > p.max_depth_m) {
        out.at(u, v) = 0;
        ++st.out_of_range;
        continue;
      }
      if (r < p.dropout) {
        out.at(u, v) = 0;
        ++st.dropped;
        continue;
      }
      out.at(u, v) = static_cast<float>(z);
    }
}

}  // namespace

DepthImage simulate_depth_sensor(const DepthImage& clean, const Image<Eigen::Vector3f>& normals,
                                 const PinholeIntrinsics& K, const DepthSensorParams& p,
                                 std::mt19937_64& rng, DepthSensorStats* stats) {
  DepthSensorStats st;
  const int W = clean.width(), H = clean.height();
  DepthImage out = clean;
  if (!p.enabled) {
    if (stats) *stats = st;
    return out;
  }
  const double f = K.fx;
  const PixelRandom R{rng()};
  MaskImage invalid(W, H, 0);
  if (p.projector_shadow) mark_projector_shadows(clean, f, p, invalid, st);
  const Image<float> theta_img = mark_grazing(clean, normals, K, p, R, invalid, st);
  jitter_edges(clean, p, R, invalid, out, st);
  add_axial_noise(clean, theta_img, f, p, R, invalid, out, st);
  if (stats) *stats = st;
  return out;
}

void apply_color_noise(ColorImage& image, double gain, double sigma, std::mt19937_64& rng) {
  const PixelRandom R{rng()};
  const float g = static_cast<float>(gain), sg = static_cast<float>(sigma);
  for (size_t i = 0; i < image.size(); ++i) {
    Rgb8& px = image[i];
    auto ch = [&](std::uint8_t c, int k) {
      const float x = c * g + (sg > 0 ? sg * R.normal_approx(i, k) : 0.0f);
      return static_cast<std::uint8_t>(std::clamp(x + 0.5f, 0.0f, 255.0f));
    };
    px.r = ch(px.r, 0);
    px.g = ch(px.g, 1);
    px.b = ch(px.b, 2);
  }
}

}  // namespace orpe::synth
