#include "orpe/report/pose_overlays.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <span>

#include "orpe/core/error.h"
#include "orpe/render/mesh_io.h"
#include "orpe/render/rasterizer.h"

namespace orpe::report {
namespace {

/// Pixels of `mask` with a 4-neighbour outside it (or at the image border).
std::vector<int> boundary_pixels(const MaskImage& mask) {
  std::vector<int> out;
  const int W = mask.width(), H = mask.height();
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      if (!mask.at(u, v)) continue;
      const bool edge = u == 0 || v == 0 || u == W - 1 || v == H - 1 || !mask.at(u - 1, v) ||
                        !mask.at(u + 1, v) || !mask.at(u, v - 1) || !mask.at(u, v + 1);
      if (edge) out.push_back(v * W + u);
    }
  return out;
}

void paint_disc(ColorImage& img, int u0, int v0, int radius, Rgb8 c) {
  for (int dv = -radius; dv <= radius; ++dv)
    for (int du = -radius; du <= radius; ++du)
      if (du * du + dv * dv <= radius * radius + radius && img.in_bounds(u0 + du, v0 + dv))
        img.at(u0 + du, v0 + dv) = c;
}

std::uint8_t mix(std::uint8_t a, std::uint8_t b, double w) {
  return static_cast<std::uint8_t>(std::clamp(a * (1 - w) + b * w + 0.5, 0.0, 255.0));
}

}  // namespace

ColorImage draw_model_overlays(const ColorImage& image, const PinholeIntrinsics& K,
                               const std::vector<OverlayObject>& objects, int thickness_px,
                               double tint) {
  ColorImage out = image;
  std::vector<RenderItem> items;
  std::vector<Rgb8> colours;
  for (const auto& o : objects)
    if (o.mesh) {
      items.push_back(RenderItem{o.mesh, o.T_cam_obj, static_cast<std::int32_t>(items.size() + 1)});
      colours.push_back(o.colour);
    }
  if (items.empty() || image.empty()) return out;
  Rasterizer rast;
  RenderBuffers buf;
  rast.render(K, std::span<const RenderItem>(items), buf, kRenderIds | kRenderSilhouettes);
  for (size_t k = 0; k < out.size(); ++k) {
    const int id = buf.ids[k];
    if (id <= 0) continue;
    const Rgb8 c = colours[id - 1];
    out[k] = Rgb8{mix(out[k].r, c.r, tint), mix(out[k].g, c.g, tint), mix(out[k].b, c.b, tint)};
  }
  const int radius = std::max(0, thickness_px / 2);
  for (size_t i = 0; i < items.size(); ++i)
    for (int k : boundary_pixels(buf.silhouettes[i]))
      paint_disc(out, k % out.width(), k / out.width(), radius, colours[i]);
  return out;
}

const TriangleMesh* ModelMeshes::get(int class_id) {
  auto it = meshes_.find(class_id);
  if (it != meshes_.end()) return it->second.get();
  std::unique_ptr<TriangleMesh> mesh;
  std::string path;
  if (auto m = info_.model_mesh_paths.find(class_id); m != info_.model_mesh_paths.end())
    path = m->second;
  else if (auto p = info_.model_points_paths.find(class_id); p != info_.model_points_paths.end())
    path = p->second;  // a BOP model PLY is a mesh; a YCB points.xyz is refused by load_mesh
  if (!path.empty()) {
    try {
      MeshLoadOptions mo;
      mo.metres_per_unit = 1.0 / info_.model_units_per_m;
      mo.load_texture = false;
      mo.warn_missing_texture = false;
      auto m = std::make_unique<TriangleMesh>(load_mesh(path, mo));
      if (!m->triangles.empty()) mesh = std::move(m);
    } catch (const IoError& e) {
      spdlog::warn("report: class {}: no model outline ({})", class_id, e.what());
    }
  }
  return meshes_.emplace(class_id, std::move(mesh)).first->second.get();
}

}  // namespace orpe::report
