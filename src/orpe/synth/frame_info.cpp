#include "orpe/synth/frame_info.h"

#include <Eigen/Core>
#include <algorithm>
#include <climits>
#include <cmath>
#include <span>

namespace orpe::synth {

/// Per instance k (label k + 1 in `visible`; `silhouettes[k]` its amodal mask): the visible mask
/// and the BOP scene_gt_info counts and boxes.
void object_frame_info(const LabelImage& visible, const std::vector<MaskImage>& silhouettes,
                       const DepthImage& depth, std::vector<MaskImage>& masks_visib,
                       std::vector<ObjectFrameInfo>& info) {
  const int W = visible.width(), H = visible.height(), n = static_cast<int>(silhouettes.size());
  masks_visib.assign(n, MaskImage(W, H, 0));
  info.assign(n, ObjectFrameInfo{});
  std::vector<int> vx0(n, W), vy0(n, H), vx1(n, -1), vy1(n, -1), ax0(n, W), ay0(n, H), ax1(n, -1),
      ay1(n, -1);
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      const int id = visible.at(u, v);
      if (id > 0 && id <= n) {
        const int k = id - 1;
        masks_visib[k].at(u, v) = 1;
        ObjectFrameInfo& inf = info[k];
        ++inf.px_count_visib;
        if (depth.at(u, v) > 0) ++inf.px_count_valid;
        vx0[k] = std::min(vx0[k], u), vx1[k] = std::max(vx1[k], u), vy0[k] = std::min(vy0[k], v),
        vy1[k] = std::max(vy1[k], v);
      }
      for (int k = 0; k < n; ++k)
        if (silhouettes[k].at(u, v)) {
          ++info[k].px_count_all;
          ax0[k] = std::min(ax0[k], u), ax1[k] = std::max(ax1[k], u), ay0[k] = std::min(ay0[k], v),
          ay1[k] = std::max(ay1[k], v);
        }
    }
  for (int k = 0; k < n; ++k) {
    ObjectFrameInfo& inf = info[k];
    // The visible surface is always part of the silhouette; guard against a 1-pixel disagreement at
    // clipped edges anyway so that visib_fract stays in [0, 1].
    inf.px_count_all = std::max(inf.px_count_all, inf.px_count_visib);
    inf.visib_fract =
        inf.px_count_all > 0 ? static_cast<double>(inf.px_count_visib) / inf.px_count_all : 0.0;
    if (vx1[k] >= 0) {
      const int b[4] = {vx0[k], vy0[k], vx1[k] - vx0[k] + 1, vy1[k] - vy0[k] + 1};
      std::copy(b, b + 4, inf.bbox_visib);
    }
    if (ax1[k] >= 0) {
      const int b[4] = {ax0[k], ay0[k], ax1[k] - ax0[k] + 1, ay1[k] - ay0[k] + 1};
      std::copy(b, b + 4, inf.bbox_obj);
    }
  }
}

/// bop_toolkit's px_count_all counts the whole silhouette, also the part cut off by the image
/// border (it renders into an image three times as large, the original in its middle). Adds the
/// pixels of the mesh's silhouette outside the image (within that larger image) to `info` and
/// widens bbox_obj to them; objects entirely inside the image are left alone (nothing is rendered).
void add_silhouette_outside_image(const TriangleMesh& mesh, const SE3& T_cam_obj,
                                  const PinholeIntrinsics& K, const RasterizerParams& rp,
                                  ObjectFrameInfo& info) {
  const int W = K.width, H = K.height;
  Eigen::Vector2d lo(1e30, 1e30), hi(-1e30, -1e30);
  bool behind = false;
  for (const auto& v : mesh.vertices) {
    const Vec3 p = T_cam_obj * v.cast<double>();
    if (p.z() <= rp.near_m) {
      behind = true;
      break;
    }
    const Eigen::Vector2d q = K.project(p);
    lo = lo.cwiseMin(q), hi = hi.cwiseMax(q);
  }
  if (behind) lo = Eigen::Vector2d(-W, -H), hi = Eigen::Vector2d(2 * W, 2 * H);
  // Pixel centres outside the image are at -1 or W, H and beyond.
  if (lo.x() > -1 && lo.y() > -1 && hi.x() < W && hi.y() < H) return;
  const int u0 = static_cast<int>(std::max<double>(-W, std::floor(lo.x())));
  const int v0 = static_cast<int>(std::max<double>(-H, std::floor(lo.y())));
  const int u1 = static_cast<int>(std::min<double>(2 * W, std::ceil(hi.x()) + 1));
  const int v1 = static_cast<int>(std::min<double>(2 * H, std::ceil(hi.y()) + 1));
  if (u1 <= u0 || v1 <= v0) return;
  PinholeIntrinsics crop = K;  // a crop of the larger image: the principal point shifted
  crop.width = u1 - u0, crop.height = v1 - v0, crop.cx = K.cx - u0, crop.cy = K.cy - v0;
  Rasterizer rast(rp);
  const RenderItem item{&mesh, T_cam_obj, 1};
  RenderBuffers buf;
  rast.render(crop, std::span<const RenderItem>(&item, 1), buf, kRenderDepth);
  int* b = info.bbox_obj;  // x, y, w, h (-1s when empty)
  int x0 = b[2] > 0 ? b[0] : INT_MAX, y0 = b[3] > 0 ? b[1] : INT_MAX;
  int x1 = b[2] > 0 ? b[0] + b[2] - 1 : INT_MIN, y1 = b[3] > 0 ? b[1] + b[3] - 1 : INT_MIN;
  for (int v = 0; v < crop.height; ++v)
    for (int u = 0; u < crop.width; ++u) {
      const int x = u + u0, y = v + v0;
      if (buf.depth.at(u, v) <= 0 || (x >= 0 && x < W && y >= 0 && y < H)) continue;
      ++info.px_count_all;
      x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
    }
  if (x1 >= x0) {
    const int box[4] = {x0, y0, x1 - x0 + 1, y1 - y0 + 1};
    std::copy(box, box + 4, b);
  }
  info.visib_fract =
      info.px_count_all > 0 ? static_cast<double>(info.px_count_visib) / info.px_count_all : 0.0;
}

}  // namespace orpe::synth
