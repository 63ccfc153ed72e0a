#include "orpe/slam/map_io.h"

#include <algorithm>
#include <cmath>

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
  if (n == 0) centroid = T_world_cam * Vec3(0, 0, 2);
  else centroid /= double(n);
  const Vec3 eye = T_world_cam.translation() - back_m * R.col(2) - up_m * R.col(1);
  return look_at(eye, centroid, -R.col(1));  // the first camera's up
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
    // Headlight shading: surfaces facing the camera keep their colour, oblique ones darken a little.
    const Vec3f& n = view.normal[k];
    const Vec3f& p = view.vertex[k];
    const float facing = p.norm() > 0 ? std::fabs(n.dot(p)) / p.norm() : 1.0f;
    const float shade = 0.55f + 0.45f * facing;
    const Rgb8 c = view.color[k];
    auto sh = [&](std::uint8_t x) { return static_cast<std::uint8_t>(std::min(255.0f, x * shade + 0.5f)); };
    img[k] = Rgb8{sh(c.r), sh(c.g), sh(c.b)};
  }
  return img;
}

}  // namespace orpe::slam
