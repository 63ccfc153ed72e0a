// The --render-view viewpoint: the box to show (objects first, robust to stray surfels) and a
// viewpoint that frames it tightly, compared with the old fixed offset behind the first camera.
#include <gtest/gtest.h>

#include <limits>

#include "orpe/slam/map_io.h"

namespace orpe::slam {
namespace {

void add(SurfelMap& map, const Vec3& p, int instance) {
  Surfel s;
  s.position_world = p.cast<float>();
  s.normal_world = Vec3f(0, 0, -1);
  s.confidence = 10;
  s.instance_id = instance;
  map.push_back(s);
}

/// Objects on a table 1 m in front of the first camera (identity pose, world = its frame), a wall
/// at 3 m, and a few stray surfels far away.
SurfelMap scene(bool with_objects) {
  SurfelMap map;
  for (int i = 0; i <= 20; ++i)
    for (int j = 0; j <= 20; ++j) {
      add(map, Vec3(-2 + 0.2 * i, -1.5 + 0.15 * j, 3.0), 0);  // wall
      if (with_objects) add(map, Vec3(0.3 + 0.02 * i, 0.1 - 0.01 * j, 0.9 + 0.01 * j), 1);
    }
  for (int k = 0; k < 5; ++k) add(map, Vec3(10.0 * k, 0, 60.0), 0);
  return map;
}

PinholeIntrinsics viewer() {
  PinholeIntrinsics K;
  K.fx = K.fy = 420;
  K.cx = 319.5;
  K.cy = 239.5;
  return K;
}

/// Largest |corner - principal point| / half size over the box's corners (1 = at the border), or
/// +inf when a corner is behind the viewer.
double extent(const Eigen::AlignedBox3d& box, const SE3& T_world_cam, const PinholeIntrinsics& K) {
  double e = 0;
  for (int c = 0; c < 8; ++c) {
    const Vec3 p =
        T_world_cam.inverse() * box.corner(static_cast<Eigen::AlignedBox3d::CornerType>(c));
    if (p.z() <= 0) return std::numeric_limits<double>::infinity();
    const auto q = K.project(p);
    e = std::max(
        {e, std::abs(q.x() - K.cx) / (0.5 * K.width), std::abs(q.y() - K.cy) / (0.5 * K.height)});
  }
  return e;
}

/// The fraction of the image the box's projection spans (the larger of width and height).
double coverage(const Eigen::AlignedBox3d& box, const SE3& T_world_cam,
                const PinholeIntrinsics& K) {
  Eigen::AlignedBox2d b;
  for (int c = 0; c < 8; ++c)
    b.extend(K.project(T_world_cam.inverse() *
                       box.corner(static_cast<Eigen::AlignedBox3d::CornerType>(c))));
  return std::max(b.sizes().x() / K.width, b.sizes().y() / K.height);
}

TEST(MapFraming, FocusBoxPrefersObjectsAndIgnoresStraySurfels) {
  const Eigen::AlignedBox3d objects = map_focus_box(scene(true), 0);
  EXPECT_LT((objects.min() - Vec3(0.3, -0.1, 0.9)).norm(), 0.03);
  EXPECT_LT((objects.max() - Vec3(0.7, 0.1, 1.1)).norm(), 0.03);
  const Eigen::AlignedBox3d all = map_focus_box(scene(false), 0);
  EXPECT_LT(all.max().z(), 3.01);  // the five surfels at 60 m are outliers
  EXPECT_LT((all.min() - Vec3(-2, -1.5, 3)).norm(), 0.2);
  EXPECT_TRUE(map_focus_box(SurfelMap(), 0).isEmpty());
}

TEST(MapFraming, ViewpointFramesTheBoxTightlyFromAbove) {
  const SurfelMap map = scene(true);
  const Eigen::AlignedBox3d box = map_focus_box(map, 0);
  const PinholeIntrinsics K = viewer();
  const SE3 first;  // identity: x right, y down, z forward
  const SE3 view = framing_pose(box, first, K, 25, 0.9);
  const double e = extent(box, view, K);
  EXPECT_LE(e, 0.9 + 1e-6);  // every corner inside the central 90 %
  EXPECT_GT(e, 0.88);        // and as near as that allows
  // Looking at the box's centre, from higher up than the first camera (y is down).
  const Vec3 axis = view.rotation().col(2);
  EXPECT_GT(axis.dot((box.center() - view.translation()).normalized()), 0.9999);
  EXPECT_LT(view.translation().y(), box.center().y() - 0.05);
  // The old fixed offset (1.5 m behind, 0.6 m above) shows the objects much smaller.
  const SE3 fixed = overview_pose(map, first, 0, 1.5, 0.6);
  EXPECT_GT(coverage(box, view, K), 0.6);  // perspective: the box is not centred-symmetric
  EXPECT_LT(coverage(box, fixed, K), 0.5 * coverage(box, view, K));
}

}  // namespace
}  // namespace orpe::slam
