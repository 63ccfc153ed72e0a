#include "orpe/slam/map_io.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace orpe::slam {

PointCloudData surfel_map_cloud(const SurfelMap& map, float min_confidence) {
  PointCloudData cloud;
  for (size_t i = 0; i < map.size(); ++i) {
    if (map.confidence[i] < min_confidence) continue;
    cloud.positions_m.push_back(map.position_world[i]);
    cloud.normals.push_back(map.normal_world[i]);
    cloud.colors.push_back(map.color[i]);
    cloud.radii_m.push_back(map.radius_m[i]);
    cloud.confidences.push_back(map.confidence[i]);
    cloud.instance_ids.push_back(map.instance_id[i]);
  }
  return cloud;
}

size_t write_surfel_ply(const std::string& path, const SurfelMap& map, float min_confidence) {
  const PointCloudData cloud = surfel_map_cloud(map, min_confidence);
  write_point_cloud_ply(path, cloud);
  return cloud.size();
}

SE3 overview_pose(const SurfelMap& map, const SE3& T_world_cam, float min_confidence, double back_m,
                  double up_m) {
  Vec3 centroid = Vec3::Zero();
  size_t n = 0;
  for (size_t i = 0; i < map.size(); ++i) {
    if (map.confidence[i] < min_confidence) continue;
    centroid += map.position_world[i].cast<double>();
    ++n;
  }
  const Mat3& R = T_world_cam.rotation();
  if (n == 0)
    centroid = T_world_cam * Vec3(0, 0, 2);
  else
    centroid /= double(n);
  const Vec3 eye = T_world_cam.translation() - back_m * R.col(2) - up_m * R.col(1);
  return look_at(eye, centroid, -R.col(1));  // the first camera's up
}

Eigen::AlignedBox3d map_focus_box(const SurfelMap& map, float min_confidence, size_t min_points) {
  std::vector<Vec3> objects, all;
  for (size_t i = 0; i < map.size(); ++i) {
    if (map.confidence[i] < min_confidence) continue;
    all.push_back(map.position_world[i].cast<double>());
    if (map.instance_id[i] > 0) objects.push_back(all.back());
  }
  const std::vector<Vec3>& pts = objects.size() >= min_points ? objects : all;
  Eigen::AlignedBox3d box;
  if (pts.size() < min_points) return box;
  Vec3 lo, hi;
  std::vector<double> axis(pts.size());
  for (int a = 0; a < 3; ++a) {
    for (size_t i = 0; i < pts.size(); ++i) axis[i] = pts[i][a];
    const size_t i_lo = pts.size() / 50, i_hi = pts.size() - 1 - pts.size() / 50;
    std::nth_element(axis.begin(), axis.begin() + i_lo, axis.end());
    lo[a] = axis[i_lo];
    std::nth_element(axis.begin(), axis.begin() + i_hi, axis.end());
    hi[a] = axis[i_hi];
  }
  box.extend(lo).extend(hi);
  return box;
}

SE3 framing_pose(const Eigen::AlignedBox3d& box, const SE3& T_world_cam, const PinholeIntrinsics& K,
                 double elevation_deg, double fill) {
  const Vec3 centre = box.center();
  const Mat3& R = T_world_cam.rotation();
  const Vec3 up = -R.col(1);
  Vec3 forward = centre - T_world_cam.translation();
  if (!(forward.norm() > 1e-9)) forward = R.col(2);
  forward.normalize();
  const Vec3 right = forward.cross(up).norm() > 1e-6 ? forward.cross(up).normalized() : R.col(0);
  // Tilted down about the camera's right axis: the viewer sits higher, looking down on the box.
  const Vec3 view = Eigen::AngleAxisd(-elevation_deg * M_PI / 180.0, right) * forward;
  auto fits = [&](double d) {
    const SE3 T_cam_world = look_at(centre - d * view, centre, up).inverse();
    for (int c = 0; c < 8; ++c) {
      const Vec3 p = T_cam_world * box.corner(static_cast<Eigen::AlignedBox3d::CornerType>(c));
      if (p.z() < 0.05) return false;
      const Eigen::Vector2d q = K.project(p);
      if (std::abs(q.x() - K.cx) > 0.5 * fill * K.width ||
          std::abs(q.y() - K.cy) > 0.5 * fill * K.height)
        return false;
    }
    return true;
  };
  // The corners only shrink towards the centre as the viewer backs off: bisect on the distance.
  double lo = 0.0, hi = std::max(0.5, 2.0 * box.diagonal().norm());
  while (!fits(hi) && hi < 1e4) hi *= 2;
  for (int it = 0; it < 50; ++it) {
    const double mid = 0.5 * (lo + hi);
    (fits(mid) ? hi : lo) = mid;
  }
  return look_at(centre - hi * view, centre, up);
}

ColorImage render_map_image(MapRenderer& renderer, const SurfelMap& map, const SE3& T_world_cam,
                            const PinholeIntrinsics& K, float min_confidence, Rgb8 background) {
  RenderOptions opt;
  opt.min_confidence = min_confidence;
  opt.far_m = 100.0f;
  opt.max_splat_radius_px = 24.0f;
  RenderedView view;
  renderer.render(map, T_world_cam, K, opt, &view);
  ColorImage img(K.width, K.height, background);
  for (size_t k = 0; k < img.size(); ++k) {
    if (view.surfel_index[k] < 0) continue;
    // Headlight shading: surfaces facing the camera keep their colour, oblique ones darken a
    // little.
    const Vec3f& n = view.normal[k];
    const Vec3f& p = view.vertex[k];
    const float facing = p.norm() > 0 ? std::fabs(n.dot(p)) / p.norm() : 1.0f;
    const float shade = 0.55f + 0.45f * facing;
    const Rgb8 c = view.color[k];
    auto sh = [&](std::uint8_t x) {
      return static_cast<std::uint8_t>(std::min(255.0f, x * shade + 0.5f));
    };
    img[k] = Rgb8{sh(c.r), sh(c.g), sh(c.b)};
  }
  return img;
}

}  // namespace orpe::slam
