// The label-aware instance render: a render of every surfel kept by one call (the semantic stage's)
// and reused by a later one at the same camera and map (the pose stage's), with the same images.
#include <gtest/gtest.h>

#include "orpe/semantic/instance_render.h"
#include "semantic/planar_setup.h"

namespace orpe {
namespace {

/// The planar wall with a labelled 20 x 16 patch of surfels 10 cm in front of it (instance 3), and
/// an unlabelled 6 x 6 occluder 20 cm in front of part of the patch.
struct PatchScene : test::PlanarSetup {
  PatchScene() : test::PlanarSetup(80, 60) {
    for (int v = 20; v < 36; ++v)
      for (int u = 30; u < 50; ++u) add(u, v, 0.9, 3);
    for (int v = 24; v < 30; ++v)
      for (int u = 44; u < 50; ++u) add(u, v, 0.8, 0);
  }
  void add(int u, int v, double z, int instance) {
    slam::Surfel s;
    s.position_world = K.backproject(u, v, z).cast<float>();
    s.normal_world = Eigen::Vector3f(0, 0, -1);
    s.radius_m = static_cast<float>(0.7 * z / 80.0);
    s.confidence = 20;
    s.color = Rgb8{200, static_cast<std::uint8_t>(u), static_cast<std::uint8_t>(v)};
    const size_t i = map.push_back(s);
    map.instance_id[i] = instance;
  }
};

InstanceRenderOptions pose_stage_options() {
  InstanceRenderOptions o;
  o.want_color = true;
  o.scene_margin_px = 4;
  return o;
}

void expect_same_images(const InstanceImages& a, const InstanceImages& b) {
  ASSERT_EQ(a.instance_id.size(), b.instance_id.size());
  for (size_t k = 0; k < a.instance_id.size(); ++k) {
    ASSERT_EQ(a.instance_id[k], b.instance_id[k]) << "pixel " << k;
    ASSERT_EQ(a.depth[k], b.depth[k]) << "pixel " << k;
    ASSERT_EQ(a.color[k], b.color[k]) << "pixel " << k;
    ASSERT_EQ(a.scene_depth[k], b.scene_depth[k]) << "pixel " << k;
    ASSERT_EQ(a.scene_color[k], b.scene_color[k]) << "pixel " << k;
  }
}

TEST(InstanceRender, AKeptSceneIsReusedByALaterRenderWithTheSameImages) {
  PatchScene s;
  const SE3 T_world_cam;
  // The semantic stage's render keeps the scene over its window grown by 8 pixels ...
  InstanceRenderer semantic;
  SceneRender kept;
  InstanceRenderOptions keep;
  keep.keep_scene = &kept;
  keep.keep_margin_px = 8;
  InstanceImages first;
  semantic.render(s.map, T_world_cam, s.K, keep, &first);
  ASSERT_NE(kept.map, nullptr);
  EXPECT_FALSE(first.scene_reused);
  // ... then labels change (the semantic update: two more columns join the instance) ...
  for (size_t i = 0; i < s.map.size(); ++i) {
    const Eigen::Vector3f p = s.map.position_world[i];
    const double u = s.K.fx * p.x() / p.z() + s.K.cx;
    if (p.z() > 0.95f && u >= 27.5 && u < 29.5 && p.y() / p.z() * s.K.fy + s.K.cy >= 20 &&
        p.y() / p.z() * s.K.fy + s.K.cy < 36)
      s.map.instance_id[i] = 3;
  }
  // ... and the pose stage's render at the same camera takes the scene from it.
  InstanceRenderer pose, fresh;
  InstanceRenderOptions reuse = pose_stage_options();
  reuse.reuse_scene = &kept;
  InstanceImages reused, rendered;
  pose.render(s.map, T_world_cam, s.K, reuse, &reused);
  fresh.render(s.map, T_world_cam, s.K, pose_stage_options(), &rendered);
  EXPECT_TRUE(reused.scene_reused);
  EXPECT_FALSE(rendered.scene_reused);
  expect_same_images(reused, rendered);
  // The occluder hides part of the patch in both.
  EXPECT_EQ(reused.instance_id.at(46, 26), 0);
  EXPECT_EQ(reused.instance_id.at(40, 26), 3);
  EXPECT_EQ(reused.instance_id.at(28, 26), 3);
}

TEST(InstanceRender, BothViewsComeFromOnePassOverTheMapWithTheImagesOfTwo) {
  PatchScene s;
  InstanceRenderer renderer;
  InstanceRenderOptions o = pose_stage_options();
  InstanceImages one, two;
  SceneRender kept;
  o.keep_scene = &kept;  // the semantic stage's render: the kept window is larger
  o.keep_margin_px = 6;
  renderer.render(s.map, SE3(), s.K, o, &one);
  EXPECT_EQ(one.map_passes, 1);
  o.one_pass = false;
  renderer.render(s.map, SE3(), s.K, o, &two);
  EXPECT_EQ(two.map_passes, 2);
  expect_same_images(one, two);
  EXPECT_EQ(one.instance_id.at(40, 26), 3);
  EXPECT_EQ(one.instance_id.at(46, 26), 0);  // the occluder
  // With the scene reused, the labelled surfels alone: one pass.
  o.keep_scene = nullptr;
  o.reuse_scene = &kept;
  renderer.render(s.map, SE3(), s.K, o, &two);
  EXPECT_TRUE(two.scene_reused);
  EXPECT_EQ(two.map_passes, 1);
  expect_same_images(one, two);
}

TEST(InstanceRender, AKeptSceneIsNotReusedForAnotherMapCameraOrALargerWindow) {
  PatchScene s;
  InstanceRenderer semantic, pose;
  SceneRender kept;
  InstanceRenderOptions keep;
  keep.keep_scene = &kept;
  keep.keep_margin_px = 2;
  InstanceImages images;
  semantic.render(s.map, SE3(), s.K, keep, &images);
  InstanceRenderOptions reuse = pose_stage_options();
  reuse.reuse_scene = &kept;
  // The pose stage's window (4 pixels of margin) reaches beyond the kept one (2 pixels).
  pose.render(s.map, SE3(), s.K, reuse, &images);
  EXPECT_FALSE(images.scene_reused);
  // Within it: reused.
  reuse.scene_margin_px = 2;
  pose.render(s.map, SE3(), s.K, reuse, &images);
  EXPECT_TRUE(images.scene_reused);
  // Another camera.
  SE3 moved;
  moved.translation().x() = 0.01;
  pose.render(s.map, moved, s.K, reuse, &images);
  EXPECT_FALSE(images.scene_reused);
  // The map changed (a surfel fused in front of the patch): rendered again, the new surfel hides.
  s.add(35, 25, 0.7, 0);
  pose.render(s.map, SE3(), s.K, reuse, &images);
  EXPECT_FALSE(images.scene_reused);
  EXPECT_EQ(images.instance_id.at(35, 25), 0);
  EXPECT_NEAR(images.scene_depth.at(35, 25), 0.7f, 1e-4f);
}

}  // namespace
}  // namespace orpe
