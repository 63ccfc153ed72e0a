#include "orpe/pose/single_view.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <numeric>
#include <random>
#include <sstream>

#include "orpe/pose/model_search.h"

namespace orpe {

bool SingleViewInput::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (!mask || !depth) return fail("mask and depth are required");
  if (!model) return fail("no object model for class " + std::to_string(class_id));
  if (model->points.size() < 4) return fail("object model has fewer than 4 points");
  if (mask->empty() || depth->empty()) return fail("empty mask or depth image");
  if (mask->width() != depth->width() || mask->height() != depth->height())
    return fail("mask and depth sizes differ");
  if (color && !color->empty() &&
      (color->width() != depth->width() || color->height() != depth->height()))
    return fail("colour and depth sizes differ");
  std::string reason;
  if (!intrinsics.IsValid(&reason)) return fail("intrinsics: " + reason);
  return true;
}

std::string SingleViewPose::report() const {
  std::ostringstream os;
  os.precision(4);
  if (!valid) {
    os << "invalid: " << reason;
    return os.str();
  }
  const Vec3 t = T_cam_obj.translation();
  os << "t = (" << t.x() << ", " << t.y() << ", " << t.z() << ") m, rot "
     << T_cam_obj.rotation_angle_deg() << " deg, score " << score << ", mu " << mu_m * 1000.0
     << " mm, inliers " << inlier_fraction << ", free-space violations " << free_space_violation
     << ", " << num_points << " points, " << time_ms << " ms";
  return os.str();
}

namespace {

/// Erosion with a (2r+1)^2 square, separable (rows then columns).
MaskImage erode_mask(const MaskImage& mask, int r) {
  if (r <= 0) return mask;
  const int w = mask.width(), h = mask.height();
  MaskImage tmp(w, h, 0), out(w, h, 0);
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      bool all = true;
      for (int k = -r; k <= r && all; ++k) {
        const int uu = u + k;
        all = uu >= 0 && uu < w && mask.at(uu, v) != 0;
      }
      tmp.at(u, v) = all ? 1 : 0;
    }
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      bool all = true;
      for (int k = -r; k <= r && all; ++k) {
        const int vv = v + k;
        all = vv >= 0 && vv < h && tmp.at(u, vv) != 0;
      }
      out.at(u, v) = all ? 1 : 0;
    }
  return out;
}

/// `mask` is the window of the full image at (u0, v0).
void collect(const MaskImage& mask, int u0, int v0, const DepthImage& depth,
             const PinholeIntrinsics& K, std::vector<Eigen::Vector3f>& out) {
  out.clear();
  for (int v = 0; v < mask.height(); ++v)
    for (int u = 0; u < mask.width(); ++u) {
      if (!mask.at(u, v)) continue;
      const float z = depth.at(u0 + u, v0 + v);
      if (!(z > 0.0f) || !std::isfinite(z)) continue;
      out.push_back(K.backproject(u0 + u, v0 + v, z).cast<float>());
    }
}

/// The mask cropped to its bounding box (empty when the mask is); its corner in (u0, v0). Erosion
/// and collection on the crop equal those on the full image (outside the box the mask is 0).
MaskImage crop_to_box(const MaskImage& mask, int* u0, int* v0) {
  int a = mask.width(), b = mask.height(), c = -1, d = -1;
  for (int v = 0; v < mask.height(); ++v)
    for (int u = 0; u < mask.width(); ++u)
      if (mask.at(u, v)) a = std::min(a, u), b = std::min(b, v), c = std::max(c, u), d = v;
  *u0 = std::max(a, 0), *v0 = std::max(b, 0);
  if (c < a) return MaskImage();
  MaskImage out(c - a + 1, d - b + 1, 0);
  for (int v = b; v <= d; ++v)
    for (int u = a; u <= c; ++u) out.at(u - a, v - b) = mask.at(u, v);
  return out;
}

}  // namespace

SegmentedCloud extract_segmented_cloud(const MaskImage& mask, const DepthImage& depth,
                                       const PinholeIntrinsics& intrinsics, double diameter_m,
                                       const SegmentedCloudParams& params) {
  SegmentedCloud cloud;
  if (mask.empty() || mask.width() != depth.width() || mask.height() != depth.height())
    return cloud;
  int u0 = 0, v0 = 0;
  const MaskImage box = crop_to_box(mask, &u0, &v0);
  for (const auto m : box) cloud.mask_pixels += m != 0;
  std::vector<Eigen::Vector3f> pts;
  if (params.erode_px > 0 && !box.empty())
    collect(erode_mask(box, params.erode_px), u0, v0, depth, intrinsics, pts);
  if (static_cast<int>(pts.size()) < std::max(params.min_points, 1) && !box.empty())
    collect(box, u0, v0, depth, intrinsics, pts);  // small or thin instance: keep the boundary
  cloud.valid_depth_pixels = static_cast<int>(pts.size());
  if (pts.empty()) return cloud;

  if (diameter_m > 0 && params.outlier_radius_factor > 0) {
    // Coordinate-wise median: robust against background pixels leaking into the mask.
    Eigen::Vector3f median;
    std::vector<float> coord(pts.size());
    for (int d = 0; d < 3; ++d) {
      for (size_t i = 0; i < pts.size(); ++i) coord[i] = pts[i][d];
      std::nth_element(coord.begin(), coord.begin() + coord.size() / 2, coord.end());
      median[d] = coord[coord.size() / 2];
    }
    const float r2 = static_cast<float>(std::pow(params.outlier_radius_factor * diameter_m, 2));
    const size_t before = pts.size();
    std::erase_if(pts, [&](const Eigen::Vector3f& p) { return (p - median).squaredNorm() > r2; });
    cloud.outliers_removed = static_cast<int>(before - pts.size());
  }
  if (params.max_points > 0 && static_cast<int>(pts.size()) > params.max_points) {
    std::vector<size_t> order(pts.size());
    std::iota(order.begin(), order.end(), size_t{0});
    std::mt19937 rng(params.seed);
    std::shuffle(order.begin(), order.end(), rng);
    order.resize(static_cast<size_t>(params.max_points));
    std::sort(order.begin(), order.end());  // keep image order (cache friendly, deterministic)
    std::vector<Eigen::Vector3f> sub;
    sub.reserve(order.size());
    for (size_t i : order) sub.push_back(pts[i]);
    pts.swap(sub);
  }
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const auto& p : pts) c += p.cast<double>();
  if (!pts.empty()) cloud.centroid = (c / static_cast<double>(pts.size())).cast<float>();
  cloud.points = std::move(pts);
  return cloud;
}

double mean_model_distance_m(const std::vector<Eigen::Vector3f>& points_cam,
                             const ObjectModel& model, const SE3& T_cam_obj) {
  if (points_cam.empty() || model.points.empty()) return 0.0;
  std::shared_ptr<const ModelSearchIndex> index = model.search_index;
  if (!index) index = std::make_shared<ModelSearchIndex>(model.points);
  const SE3 T_obj_cam = T_cam_obj.inverse();
  const Eigen::Matrix3f R = T_obj_cam.rotation().cast<float>();
  const Eigen::Vector3f t = T_obj_cam.translation().cast<float>();
  double sum = 0;
  for (const auto& q : points_cam) {
    float d2 = 0;
    index->nearest(R * q + t, &d2);
    sum += std::sqrt(d2);
  }
  return sum / static_cast<double>(points_cam.size());
}

}  // namespace orpe
