#include "orpe/render/rasterizer.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace orpe {
namespace {

constexpr int kSubpixelBits = 8;
constexpr std::int64_t kOne = 1 << kSubpixelBits;
constexpr double kGuardBandPx = 4096.0;  // keeps fixed-point products far from overflow
constexpr size_t kSetupChunk = 2048;     // triangles per setup work unit (fixed: deterministic)

std::int64_t floor_div(std::int64_t a, std::int64_t b) {  // b > 0
  return a >= 0 ? a / b : -((-a + b - 1) / b);
}
std::int64_t ceil_div(std::int64_t a, std::int64_t b) {  // b > 0
  return a >= 0 ? (a + b - 1) / b : -((-a) / b);
}

/// Clip plane a . P + d >= 0 (camera frame).
struct Plane {
  Eigen::Vector3d a;
  double d;
  double eval(const Eigen::Vector3d& p) const { return a.dot(p) + d; }
};

/// Sutherland-Hodgman: clips a convex polygon against one plane. `out` is cleared first.
void clip_polygon(const std::vector<Eigen::Vector3d>& in, const Plane& pl,
                  std::vector<Eigen::Vector3d>& out) {
  out.clear();
  const size_t n = in.size();
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d& p = in[i];
    const Eigen::Vector3d& q = in[(i + 1) % n];
    const double dp = pl.eval(p), dq = pl.eval(q);
    if (dp >= 0) out.push_back(p);
    if ((dp >= 0) != (dq >= 0)) {
      const double t = dp / (dp - dq);
      Eigen::Vector3d x = p + t * (q - p);
      out.push_back(x);
    }
  }
}

/// A triangle as the resolve pass needs it at each of its pixels: the constants of the ray
/// intersection and the attributes to interpolate. With ray d = (x, y, 1), vertices P0..P2,
/// e1 = P1 - P0, e2 = P2 - P0, s = -P0 (Moeller-Trumbore):
///   det = -d . n, b1 = d . m / det, b2 = d . q / det, z = c / det,
/// where n = e1 x e2, m = e2 x s, q = s x e1, c = e2 . q are constant per triangle.
struct TriangleSurface {
  Eigen::Vector3d n = Eigen::Vector3d::Zero(), m = n, q = n;
  double c = 0, zlo = 0, zhi = 0;
  Eigen::Vector3f n0 = Eigen::Vector3f::Zero(), n1 = n0, n2 = n0, face_n = n0;
  // Albedo terms: base colour x vertex colours, and uvs when textured.
  Eigen::Vector3f c0 = n0, c1 = n0, c2 = n0;
  Eigen::Vector2f t0 = Eigen::Vector2f::Zero(), t1 = t0, t2 = t0;
  bool textured = false;
  const TriangleMesh* mesh = nullptr;

  void load(const TriangleMesh& mesh_, int triangle, const std::vector<Eigen::Vector3f>& cv,
            const Eigen::Matrix3f& R, double near, bool want_color) {
    mesh = &mesh_;
    const Eigen::Vector3i& tri = mesh->triangles[triangle];
    const Eigen::Vector3d P0 = cv[tri[0]].cast<double>(), P1 = cv[tri[1]].cast<double>(),
                          P2 = cv[tri[2]].cast<double>();
    const Eigen::Vector3d e1 = P1 - P0, e2 = P2 - P0, s0 = -P0;
    n = e1.cross(e2);
    m = e2.cross(s0);
    q = s0.cross(e1);
    c = e2.dot(q);
    zlo = std::max(std::min({P0.z(), P1.z(), P2.z()}), near);
    zhi = std::max(std::max({P0.z(), P1.z(), P2.z()}), zlo);
    face_n = n.cast<float>();
    if (!mesh->normals.empty())
      n0 = R * mesh->normals[tri[0]], n1 = R * mesh->normals[tri[1]],
      n2 = R * mesh->normals[tri[2]];
    if (!want_color) return;
    const Eigen::Vector3f base =
        Eigen::Vector3f(mesh->base_color.r, mesh->base_color.g, mesh->base_color.b) / 255.0f;
    Eigen::Vector3f* cs[3] = {&c0, &c1, &c2};
    for (int k = 0; k < 3; ++k) {
      *cs[k] = base;
      if (!mesh->colors.empty()) {
        const Rgb8 vc = mesh->colors[tri[k]];
        *cs[k] = cs[k]->cwiseProduct(Eigen::Vector3f(vc.r, vc.g, vc.b) / 255.0f);
      }
    }
    textured = mesh->has_texture();
    if (textured) t0 = mesh->uvs[tri[0]], t1 = mesh->uvs[tri[1]], t2 = mesh->uvs[tri[2]];
  }

  /// Depth of the ray `d` on the triangle (`z_fallback` for a ray along its plane) and the
  /// barycentric coordinates, clamped into the triangle.
  double intersect(const Eigen::Vector3d& d, double z_fallback, Eigen::Vector3f* bary) const {
    const double det = -d.dot(n);
    double z, b1, b2;
    if (std::abs(det) > 1e-18) {
      const double inv = 1.0 / det;
      b1 = d.dot(m) * inv;
      b2 = d.dot(q) * inv;
      z = c * inv;
    } else {
      z = z_fallback;
      b1 = b2 = 1.0 / 3.0;
    }
    // Pixel centres on a snapped edge can sit a hair outside the exact triangle: clamp.
    z = std::clamp(z, zlo, zhi);
    b1 = std::clamp(b1, 0.0, 1.0), b2 = std::clamp(b2, 0.0, 1.0);
    if (b1 + b2 > 1.0) {
      const double sum = b1 + b2;
      b1 /= sum, b2 /= sum;
    }
    *bary = Eigen::Vector3f(static_cast<float>(1.0 - b1 - b2), static_cast<float>(b1),
                            static_cast<float>(b2));
    return z;
  }

  /// The interpolated (else the face's) unit normal, turned to face the camera (ray `d`).
  Eigen::Vector3f normal(const Eigen::Vector3f& bary, const Eigen::Vector3f& d) const {
    Eigen::Vector3f nrm = mesh->normals.empty()
                              ? face_n
                              : Eigen::Vector3f(bary[0] * n0 + bary[1] * n1 + bary[2] * n2);
    const float len = nrm.norm();
    nrm = len > 0 ? Eigen::Vector3f(nrm / len) : Eigen::Vector3f(0, 0, -1);
    if (nrm.dot(d) > 0) nrm = -nrm;  // face the camera
    return nrm;
  }

  /// Lambertian colour: albedo x (ambient + diffuse x max(0, n . l)).
  Rgb8 shade(const Eigen::Vector3f& bary, const Eigen::Vector3f& nrm, const Light& light,
             const Eigen::Vector3f& ldir) const {
    Eigen::Vector3f albedo = bary[0] * c0 + bary[1] * c1 + bary[2] * c2;
    if (textured) {
      const Eigen::Vector2f uv = bary[0] * t0 + bary[1] * t1 + bary[2] * t2;
      albedo = albedo.cwiseProduct(sample_texture_bilinear(*mesh->texture, uv.x(), uv.y()) *
                                   (1.0f / 255.0f));
    }
    const float shade = light.ambient + light.diffuse * std::max(0.0f, nrm.dot(ldir));
    const Eigen::Vector3f col = (albedo * (shade * 255.0f)).cwiseMin(255.0f).cwiseMax(0.0f);
    return {static_cast<std::uint8_t>(col.x() + 0.5f), static_cast<std::uint8_t>(col.y() + 0.5f),
            static_cast<std::uint8_t>(col.z() + 0.5f)};
  }
};

}  // namespace

bool RasterizerParams::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (!(near_m > 0)) return fail("near_m must be > 0");
  if (!(far_m > near_m)) return fail("far_m must be > near_m");
  if (ambient < 0 || diffuse < 0) return fail("ambient and diffuse must be >= 0");
  const double len =
      std::sqrt(light_dir_x * light_dir_x + light_dir_y * light_dir_y + light_dir_z * light_dir_z);
  if (!(len > 0) || !std::isfinite(len)) return fail("light direction must be a non-zero vector");
  if (background_gray < 0 || background_gray > 255)
    return fail("background_gray must be in 0..255");
  if (band_rows < 1 || band_rows > 1024) return fail("band_rows must be in 1..1024");
  if (threads < 0) return fail("threads must be >= 0");
  return true;
}

Rasterizer::Rasterizer(const RasterizerParams& params) : params_(params) {
  std::string why;
  if (!params_.IsValid(&why)) throw std::invalid_argument("RasterizerParams: " + why);
}

Light Rasterizer::default_light() const {
  Light l;
  l.direction_cam = Eigen::Vector3f(static_cast<float>(params_.light_dir_x),
                                    static_cast<float>(params_.light_dir_y),
                                    static_cast<float>(params_.light_dir_z));
  l.ambient = static_cast<float>(params_.ambient);
  l.diffuse = static_cast<float>(params_.diffuse);
  return l;
}

RenderBuffers Rasterizer::render(const PinholeIntrinsics& K, std::span<const RenderItem> items,
                                 unsigned outputs, const Light* light) {
  RenderBuffers out;
  render(K, items, out, outputs, light);
  return out;
}

void Rasterizer::render(const PinholeIntrinsics& K, std::span<const RenderItem> items,
                        RenderBuffers& out, unsigned outputs, const Light* light_override) {
  std::string why;
  if (!K.IsValid(&why)) throw std::invalid_argument("Rasterizer: invalid intrinsics: " + why);
  for (size_t i = 0; i < items.size(); ++i) {
    if (!items[i].mesh)
      throw std::invalid_argument("Rasterizer: item " + std::to_string(i) + " has no mesh");
    if (!items[i].mesh->IsValid(&why))
      throw std::invalid_argument("Rasterizer: item " + std::to_string(i) + " (" +
                                  items[i].mesh->name + "): " + why);
  }
  const int threads = params_.threads > 0 ? params_.threads : omp_get_max_threads();
  RenderStats stats;
  project_vertices(K, items, threads, stats);
  setup_triangles(K, items, threads, stats);
  bin_triangles(K.height);
  rasterise(K, items.size(), (outputs & kRenderSilhouettes) != 0, threads, out);
  const Light light = light_override ? *light_override : default_light();
  stats.pixels_covered = resolve(K, items, outputs, light, threads, out);
  out.stats = stats;
}

void Rasterizer::project_vertices(const PinholeIntrinsics& K, std::span<const RenderItem> items,
                                  int threads, RenderStats& stats) {
  // Vertices to the camera frame, projected once (triangles share them).
  const int W = K.width, H = K.height;
  const double near = params_.near_m;
  const double gx0 = -kGuardBandPx, gx1 = W - 1 + kGuardBandPx, gy0 = -kGuardBandPx,
               gy1 = H - 1 + kGuardBandPx;
  cam_vertices_.resize(items.size());
  proj_vertices_.resize(items.size());
  for (size_t i = 0; i < items.size(); ++i) {
    const auto& src = items[i].mesh->vertices;
    auto& dst = cam_vertices_[i];
    auto& proj = proj_vertices_[i];
    dst.resize(src.size());
    proj.resize(src.size());
    const Eigen::Matrix3d R = items[i].T_cam_obj.rotation();
    const Eigen::Vector3d t = items[i].T_cam_obj.translation();
    const long n = static_cast<long>(src.size());
#pragma omp parallel for schedule(static) num_threads(threads) if (n > 20000)
    for (long k = 0; k < n; ++k) {
      const Eigen::Vector3d p = R * src[k].cast<double>() + t;
      dst[k] = p.cast<float>();
      ProjectedVertex& pv = proj[k];
      pv.needs_clip = !(p.z() >= near);
      if (pv.needs_clip) continue;
      const double sx = K.fx * p.x() / p.z() + K.cx, sy = K.fy * p.y() / p.z() + K.cy;
      pv.needs_clip = !(sx >= gx0 && sx <= gx1 && sy >= gy0 && sy <= gy1);
      if (pv.needs_clip) continue;
      pv.x = static_cast<std::int32_t>(std::nearbyint(sx * kOne));
      pv.y = static_cast<std::int32_t>(std::nearbyint(sy * kOne));
      pv.inv_z = 1.0 / p.z();
    }
    stats.triangles_in += items[i].mesh->triangles.size();
  }
}

void Rasterizer::setup_triangles(const PinholeIntrinsics& K, std::span<const RenderItem> items,
                                 int threads, RenderStats& stats) {
  // In fixed-size chunks of the global triangle sequence (deterministic whatever the threads).
  std::vector<size_t> item_first(items.size() + 1, 0);
  for (size_t i = 0; i < items.size(); ++i)
    item_first[i + 1] = item_first[i] + items[i].mesh->triangles.size();
  const size_t total = item_first.back();
  const size_t nchunks = (total + kSetupChunk - 1) / kSetupChunk;
  if (chunk_tris_.size() < nchunks) chunk_tris_.resize(nchunks);
  std::vector<size_t> chunk_culled(nchunks, 0), chunk_clipped(nchunks, 0);
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
  for (long c = 0; c < static_cast<long>(nchunks); ++c)
    setup_chunk(K, items, item_first, static_cast<size_t>(c), &chunk_culled[c], &chunk_clipped[c]);
  tris_.clear();
  for (size_t c = 0; c < nchunks; ++c) {
    tris_.insert(tris_.end(), chunk_tris_[c].begin(), chunk_tris_[c].end());
    stats.triangles_culled += chunk_culled[c];
    stats.triangles_clipped += chunk_clipped[c];
  }
  stats.triangles_drawn = tris_.size();
}

void Rasterizer::setup_chunk(const PinholeIntrinsics& K, std::span<const RenderItem> items,
                             const std::vector<size_t>& item_first, size_t c, size_t* culled,
                             size_t* clipped) {
  const int W = K.width, H = K.height;
  const double near = params_.near_m, far = params_.far_m;
  const bool cull = params_.cull_back_faces;
  const double gx0 = -kGuardBandPx, gx1 = W - 1 + kGuardBandPx, gy0 = -kGuardBandPx,
               gy1 = H - 1 + kGuardBandPx;
  const Plane near_plane{{0, 0, 1}, -near};
  const Plane guard[4] = {{{K.fx, 0, K.cx - gx0}, 0},
                          {{-K.fx, 0, gx1 - K.cx}, 0},
                          {{0, K.fy, K.cy - gy0}, 0},
                          {{0, -K.fy, gy1 - K.cy}, 0}};
  const size_t total = item_first.back();
  auto& outv = chunk_tris_[c];
  outv.clear();
  std::vector<Eigen::Vector3d> poly, tmp;
  poly.reserve(12), tmp.reserve(12);
  const size_t g0 = c * kSetupChunk, g1 = std::min(total, g0 + kSetupChunk);
  size_t item = static_cast<size_t>(std::upper_bound(item_first.begin(), item_first.end(), g0) -
                                    item_first.begin()) -
                1;
  for (size_t g = g0; g < g1; ++g) {
    while (g >= item_first[item + 1]) ++item;
    const int tri = static_cast<int>(g - item_first[item]);
    const Eigen::Vector3i& t = items[item].mesh->triangles[tri];
    const auto& cv = cam_vertices_[item];
    const Eigen::Vector3d P0 = cv[t[0]].cast<double>(), P1 = cv[t[1]].cast<double>(),
                          P2 = cv[t[2]].cast<double>();
    if ((P0.z() < near && P1.z() < near && P2.z() < near) ||
        (P0.z() > far && P1.z() > far && P2.z() > far)) {
      ++*culled;
      continue;
    }
    if (cull && (P1 - P0).cross(P2 - P0).dot(P0) >= 0) {
      ++*culled;
      continue;
    }
    // Fast path: all three vertices in front of the near plane and inside the guard band.
    const auto& pv = proj_vertices_[item];
    const ProjectedVertex &v0 = pv[t[0]], &v1 = pv[t[1]], &v2 = pv[t[2]];
    if (!v0.needs_clip && !v1.needs_clip && !v2.needs_clip) {
      const std::int64_t X[3] = {v0.x, v1.x, v2.x}, Y[3] = {v0.y, v1.y, v2.y};
      const double iz[3] = {v0.inv_z, v1.inv_z, v2.inv_z};
      emit(W, H, X, Y, iz, 0, 1, 2, static_cast<int>(item), tri, outv);
      continue;
    }
    poly.assign({P0, P1, P2});
    if (P0.z() < near || P1.z() < near || P2.z() < near) {
      clip_polygon(poly, near_plane, tmp);
      poly.swap(tmp);
    }
    for (const Plane& pl : guard) {
      bool outside = false;
      for (const auto& p : poly) outside |= pl.eval(p) < 0;
      if (!outside) continue;
      clip_polygon(poly, pl, tmp);
      poly.swap(tmp);
    }
    if (poly.size() < 3) {
      ++*culled;
      continue;
    }
    ++*clipped;
    double iz[12];
    std::int64_t X[12], Y[12];
    const size_t n = std::min<size_t>(poly.size(), 12);
    for (size_t k = 0; k < n; ++k) {
      const double z = std::max(poly[k].z(), near * 0.999999);
      X[k] = static_cast<std::int64_t>(std::nearbyint((K.fx * poly[k].x() / z + K.cx) * kOne));
      Y[k] = static_cast<std::int64_t>(std::nearbyint((K.fy * poly[k].y() / z + K.cy) * kOne));
      iz[k] = 1.0 / z;
    }
    for (size_t k = 1; k + 1 < n; ++k)
      emit(W, H, X, Y, iz, 0, static_cast<int>(k), static_cast<int>(k + 1), static_cast<int>(item),
           tri, outv);
  }
}

void Rasterizer::emit(int W, int H, const std::int64_t* X, const std::int64_t* Y, const double* iz,
                      int a, int b, int d, int item, int tri, std::vector<ScreenTriangle>& outv) {
  std::int64_t area2 = (X[b] - X[a]) * (Y[d] - Y[a]) - (Y[b] - Y[a]) * (X[d] - X[a]);
  if (area2 == 0) return;
  if (area2 < 0) std::swap(b, d);
  ScreenTriangle st;
  const int idx[3] = {a, b, d};
  std::int64_t xmin = X[a], xmax = X[a], ymin = Y[a], ymax = Y[a];
  for (int m = 0; m < 3; ++m) {
    st.x[m] = static_cast<std::int32_t>(X[idx[m]]);
    st.y[m] = static_cast<std::int32_t>(Y[idx[m]]);
    xmin = std::min(xmin, X[idx[m]]), xmax = std::max(xmax, X[idx[m]]);
    ymin = std::min(ymin, Y[idx[m]]), ymax = std::max(ymax, Y[idx[m]]);
  }
  st.u_min = static_cast<std::int32_t>(std::max<std::int64_t>(0, ceil_div(xmin, kOne)));
  st.u_max = static_cast<std::int32_t>(std::min<std::int64_t>(W - 1, floor_div(xmax, kOne)));
  st.v_min = static_cast<std::int32_t>(std::max<std::int64_t>(0, ceil_div(ymin, kOne)));
  st.v_max = static_cast<std::int32_t>(std::min<std::int64_t>(H - 1, floor_div(ymax, kOne)));
  if (st.u_min > st.u_max || st.v_min > st.v_max) return;
  // 1/z plane through the snapped vertices: iz = A u + B v + C.
  const double ux0 = X[a] / double(kOne), uy0 = Y[a] / double(kOne);
  const double ux1 = X[b] / double(kOne) - ux0, uy1 = Y[b] / double(kOne) - uy0;
  const double ux2 = X[d] / double(kOne) - ux0, uy2 = Y[d] / double(kOne) - uy0;
  const double dz1 = iz[b] - iz[a], dz2 = iz[d] - iz[a];
  const double det = ux1 * uy2 - ux2 * uy1;
  const double A = (dz1 * uy2 - dz2 * uy1) / det;
  const double B = (ux1 * dz2 - ux2 * dz1) / det;
  st.inv_z_du = static_cast<float>(A);
  st.inv_z_dv = static_cast<float>(B);
  st.inv_z_0 = static_cast<float>(iz[a] - A * ux0 - B * uy0);
  st.item = item;
  st.triangle = tri;
  outv.push_back(st);
}

void Rasterizer::bin_triangles(int H) {
  // Each screen triangle listed in the row bands it covers.
  const int band_rows = params_.band_rows;
  const int nbands = (H + band_rows - 1) / band_rows;
  band_offsets_.assign(nbands + 1, 0);
  for (const auto& st : tris_)
    for (int b = st.v_min / band_rows; b <= st.v_max / band_rows; ++b) ++band_offsets_[b + 1];
  for (int b = 0; b < nbands; ++b) band_offsets_[b + 1] += band_offsets_[b];
  band_tris_.resize(band_offsets_[nbands]);
  {
    std::vector<std::uint32_t> fill(band_offsets_.begin(), band_offsets_.end() - 1);
    for (size_t i = 0; i < tris_.size(); ++i)
      for (int b = tris_[i].v_min / band_rows; b <= tris_[i].v_max / band_rows; ++b)
        band_tris_[fill[b]++] = static_cast<std::uint32_t>(i);
  }
}

void Rasterizer::rasterise(const PinholeIntrinsics& K, size_t n_items, bool want_sil, int threads,
                           RenderBuffers& out) {
  // Visibility: per pixel, the nearest triangle (1/z buffer), band by band.
  const int W = K.width, H = K.height;
  const size_t npix = static_cast<size_t>(W) * H;
  const double far = params_.far_m;
  const int band_rows = params_.band_rows;
  const int nbands = (H + band_rows - 1) / band_rows;
  inv_z_.assign(npix, static_cast<float>(1.0 / far));
  visible_.assign(npix, -1);
  out.silhouettes.clear();
  if (want_sil) out.silhouettes.assign(n_items, MaskImage(W, H, 0));
  std::vector<std::uint8_t*> sil_ptr(n_items, nullptr);
  if (want_sil)
    for (size_t i = 0; i < n_items; ++i) sil_ptr[i] = out.silhouettes[i].data();

#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
  for (int b = 0; b < nbands; ++b) {
    const int band_v0 = b * band_rows, band_v1 = std::min(H, band_v0 + band_rows) - 1;
    for (std::uint32_t k = band_offsets_[b]; k < band_offsets_[b + 1]; ++k) {
      const std::uint32_t ti = band_tris_[k];
      const ScreenTriangle& st = tris_[ti];
      const int v0 = std::max(st.v_min, band_v0), v1 = std::min(st.v_max, band_v1);
      // Edge i -> j: E(p) = (xj - xi)(py - yi) - (yj - yi)(px - xi) >= bias, bias 0 on owned edges.
      std::int64_t ex[3], ey[3], exi[3], eyi[3], bias[3];
      for (int e = 0; e < 3; ++e) {
        const int i = e, j = (e + 1) % 3;
        ex[e] = st.x[j] - st.x[i];
        ey[e] = st.y[j] - st.y[i];
        exi[e] = st.x[i];
        eyi[e] = st.y[i];
        const bool owned = ex[e] > 0 || (ex[e] == 0 && ey[e] < 0);
        bias[e] = owned ? 0 : 1;
      }
      std::uint8_t* sil = want_sil ? sil_ptr[st.item] : nullptr;
      for (int v = v0; v <= v1; ++v) {
        const std::int64_t py = static_cast<std::int64_t>(v) * kOne;
        std::int64_t lo = st.u_min, hi = st.u_max;
        for (int e = 0; e < 3 && lo <= hi; ++e) {
          // E(u) = E(u_min) + (u - u_min) * step
          const std::int64_t e0 =
              ex[e] * (py - eyi[e]) - ey[e] * (static_cast<std::int64_t>(st.u_min) * kOne - exi[e]);
          const std::int64_t step = -ey[e] * kOne;
          if (step > 0)
            lo = std::max(lo, st.u_min + ceil_div(bias[e] - e0, step));
          else if (step < 0)
            hi = std::min(hi, st.u_min + floor_div(e0 - bias[e], -step));
          else if (e0 < bias[e])
            hi = lo - 1;
        }
        if (lo > hi) continue;
        const size_t row = static_cast<size_t>(v) * W;
        const float izr = st.inv_z_dv * v + st.inv_z_0;
        for (std::int64_t u = lo; u <= hi; ++u) {
          const size_t p = row + u;
          if (sil) sil[p] = 1;
          const float izp = st.inv_z_du * static_cast<float>(u) + izr;
          if (izp > inv_z_[p]) {
            inv_z_[p] = izp;
            visible_[p] = static_cast<std::int32_t>(ti);
          }
        }
      }
    }
  }
}

size_t Rasterizer::resolve(const PinholeIntrinsics& K, std::span<const RenderItem> items,
                           unsigned outputs, const Light& light, int threads, RenderBuffers& out) {
  // Per visible pixel: the ray's intersection with its triangle gives depth, normal and colour.
  const int W = K.width, H = K.height;
  const bool want_depth = outputs & kRenderDepth, want_ids = outputs & kRenderIds,
             want_color = outputs & kRenderColor, want_normals = outputs & kRenderNormals,
             want_tris = outputs & kRenderTriangles;
  const auto bg = static_cast<std::uint8_t>(params_.background_gray);
  auto prepare = [&](auto& img, bool want, const auto& fill) {
    if (!want)
      img = std::decay_t<decltype(img)>();
    else if (img.width() != W || img.height() != H)
      img = std::decay_t<decltype(img)>(W, H, fill);
    else
      img.fill(fill);
  };
  prepare(out.depth, want_depth, 0.0f);
  prepare(out.ids, want_ids, 0);
  prepare(out.color, want_color, Rgb8{bg, bg, bg});
  prepare(out.normals, want_normals, Eigen::Vector3f::Zero().eval());
  prepare(out.triangles, want_tris, -1);
  prepare(out.items, want_tris || want_ids, -1);

  const Eigen::Vector3f ldir = light.direction_cam.normalized();
  std::vector<Eigen::Matrix3f> item_R(items.size());
  for (size_t i = 0; i < items.size(); ++i) item_R[i] = items[i].T_cam_obj.rotation().cast<float>();
  const bool need_surface = want_depth || want_color || want_normals;
  size_t covered = 0;

#pragma omp parallel for schedule(dynamic, 4) num_threads(threads) reduction(+ : covered)
  for (int v = 0; v < H; ++v) {
    TriangleSurface surface;  // cached while consecutive pixels share a triangle
    std::int32_t cached = -1;
    for (int u = 0; u < W; ++u) {
      const size_t p = static_cast<size_t>(v) * W + u;
      const std::int32_t vi = visible_[p];
      if (vi < 0) continue;
      ++covered;
      const ScreenTriangle& st = tris_[vi];
      const RenderItem& it = items[st.item];
      if (want_ids) out.ids[p] = it.id;
      if (want_tris) out.triangles[p] = st.triangle;
      if (!out.items.empty()) out.items[p] = st.item;
      if (!need_surface) continue;
      if (vi != cached) {
        cached = vi;
        surface.load(*it.mesh, st.triangle, cam_vertices_[st.item], item_R[st.item], params_.near_m,
                     want_color);
      }
      const Eigen::Vector3d d((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);
      Eigen::Vector3f bary;
      const double z = surface.intersect(d, 1.0 / inv_z_[p], &bary);
      if (want_depth) out.depth[p] = static_cast<float>(z);
      if (!want_color && !want_normals) continue;
      const Eigen::Vector3f nrm = surface.normal(bary, d.cast<float>());
      if (want_normals) out.normals[p] = nrm;
      if (want_color) out.color[p] = surface.shade(bary, nrm, light, ldir);
    }
  }
  if (!(want_tris || want_ids)) out.items = Image<std::int32_t>();
  return covered;
}

}  // namespace orpe
