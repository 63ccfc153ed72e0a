// SurfelMap storage (arrays in step, removal with remap) and the CPU map renderer.
#include <gtest/gtest.h>

#include <random>
#include <stdexcept>

#include "orpe/io/point_cloud_io.h"
#include "orpe/slam/map_io.h"
#include "orpe/slam/map_renderer.h"
#include "orpe/slam/surfel_map.h"
#include "support/test_data.h"

namespace orpe::slam {
namespace {

Surfel make_surfel(float x, float y, float z, int tag) {
  Surfel s;
  s.position_world = Vec3f(x, y, z);
  s.normal_world = Vec3f(0, 0, -1);
  s.radius_m = 0.01f;
  s.confidence = static_cast<float>(tag);
  s.instance_id = tag;
  s.color = Rgb8{static_cast<std::uint8_t>(tag), 0, 0};
  return s;
}

TEST(SurfelMap, PushGetSetKeepArraysInStep) {
  SurfelMap map;
  for (int i = 0; i < 5; ++i) map.push_back(make_surfel(i, 0, 1, i));
  EXPECT_EQ(map.size(), 5u);
  EXPECT_EQ(map.always_active.size(), 5u);
  EXPECT_EQ(map.object_obs_count.size(), 5u);
  Surfel s = map.get(3);
  EXPECT_EQ(s.instance_id, 3);
  s.p_object = 0.7f;
  s.boundary_counter = 4;
  map.set(1, s);
  EXPECT_FLOAT_EQ(map.p_object[1], 0.7f);
  EXPECT_EQ(map.boundary_counter[1], 4);
  EXPECT_EQ(map.bytes(), 5 * SurfelMap::kBytesPerSurfel);
}

TEST(SurfelMapPly, WritesTheSurfelsAboveTheConfidenceAndReadsBack) {
  SurfelMap map;
  for (int i = 1; i <= 4; ++i) map.push_back(make_surfel(0.1f * i, 0.2f, 1.0f + i, i));
  const std::string path = ::orpe::test::scratch_dir("ply") + "/map.ply";
  EXPECT_EQ(write_surfel_ply(path, map, 2.5f), 2u);  // confidences 3 and 4
  const PointCloudData cloud = read_point_cloud_ply(path);
  ASSERT_EQ(cloud.size(), 2u);
  ASSERT_EQ(cloud.instance_ids.size(), 2u);
  ASSERT_EQ(cloud.radii_m.size(), 2u);
  ASSERT_EQ(cloud.confidences.size(), 2u);
  for (size_t k = 0; k < 2; ++k) {
    const Surfel s = map.get(k + 2);
    EXPECT_TRUE(cloud.positions_m[k].isApprox(s.position_world));
    EXPECT_TRUE(cloud.normals[k].isApprox(s.normal_world));
    EXPECT_EQ(cloud.colors[k].r, s.color.r);
    EXPECT_FLOAT_EQ(cloud.radii_m[k], s.radius_m);
    EXPECT_FLOAT_EQ(cloud.confidences[k], s.confidence);
    EXPECT_EQ(cloud.instance_ids[k], s.instance_id);
  }
  EXPECT_TRUE(cloud.class_ids.empty());
}

TEST(SurfelMap, RemoveKeepsSurvivorsAndReportsMoves) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 200; ++trial) {
    SurfelMap map;
    const int n = 1 + static_cast<int>(rng() % 40);
    for (int i = 0; i < n; ++i) map.push_back(make_surfel(0, 0, 1, i));
    std::vector<std::uint32_t> removals;
    std::vector<bool> removed(n, false);
    const int k = static_cast<int>(rng() % (n + 1));
    for (int j = 0; j < k; ++j) {
      const auto r = static_cast<std::uint32_t>(rng() % n);
      removals.push_back(r);  // duplicates on purpose
      removed[r] = true;
    }
    std::vector<std::uint32_t> moved_from;
    map.remove(removals, &moved_from);
    const int expected = static_cast<int>(std::count(removed.begin(), removed.end(), false));
    ASSERT_EQ(static_cast<int>(map.size()), expected);
    ASSERT_EQ(moved_from.size(), map.size());
    std::vector<bool> seen(n, false);
    for (size_t i = 0; i < map.size(); ++i) {
      const int tag = map.instance_id[i];
      EXPECT_FALSE(removed[tag]) << "removed surfel " << tag << " survived";
      EXPECT_FALSE(seen[tag]) << "surfel " << tag << " duplicated";
      seen[tag] = true;
      EXPECT_EQ(static_cast<int>(moved_from[i]), tag);
      EXPECT_FLOAT_EQ(map.confidence[i], static_cast<float>(tag));  // other arrays moved too
    }
  }
}

// A fronto-parallel wall of surfels at z = 2 m seen by a camera at the origin.
SurfelMap make_wall(float z, int instance, float spacing = 0.01f) {
  SurfelMap map;
  for (float y = -0.5f; y <= 0.5f; y += spacing)
    for (float x = -0.5f; x <= 0.5f; x += spacing) {
      Surfel s = make_surfel(x, y, z, 1);
      s.radius_m = spacing;
      s.instance_id = instance;
      s.color = Rgb8{200, 100, 50};
      map.push_back(s);
    }
  return map;
}

PinholeIntrinsics small_camera() {
  PinholeIntrinsics K;
  K.width = 160;
  K.height = 120;
  K.fx = K.fy = 150;
  K.cx = 79.5;
  K.cy = 59.5;
  return K;
}

TEST(MapRenderer, SplatsAWallAtItsDepthWithoutHoles) {
  const SurfelMap map = make_wall(2.0f, 3);
  MapRenderer renderer;
  RenderedView view;
  RenderOptions opt;
  opt.want_instance = true;
  renderer.render(map, SE3(), small_camera(), opt, &view);
  // The wall spans x, y in [-0.5, 0.5] at 2 m: pixels within +-37 of the centre.
  int covered = 0;
  for (int v = 30; v < 90; ++v)
    for (int u = 50; u < 110; ++u) {
      ASSERT_NEAR(view.depth.at(u, v), 2.0f, 1e-4) << u << "," << v;
      ASSERT_GE(view.surfel_index.at(u, v), 0);
      EXPECT_EQ(view.instance_id.at(u, v), 3);
      EXPECT_EQ(view.color.at(u, v), (Rgb8{200, 100, 50}));
      EXPECT_NEAR(view.normal.at(u, v).z(), -1.0f, 1e-5);
      EXPECT_NEAR(view.vertex.at(u, v).z(), 2.0f, 1e-4);
      ++covered;
    }
  EXPECT_EQ(covered, 60 * 60);
  EXPECT_EQ(view.depth.at(5, 5), 0.0f);
  EXPECT_EQ(view.surfel_index.at(5, 5), -1);
}

TEST(MapRenderer, NearerSurfaceOccludesAndBackFacesAreSkipped) {
  SurfelMap map = make_wall(2.0f, 1);
  const SurfelMap front = make_wall(1.5f, 2, 0.02f);
  for (size_t i = 0; i < front.size(); ++i) map.push_back(front.get(i));
  MapRenderer renderer;
  RenderedView view;
  RenderOptions opt;
  opt.want_instance = true;
  renderer.render(map, SE3(), small_camera(), opt, &view);
  EXPECT_EQ(view.instance_id.at(80, 60), 2);
  EXPECT_NEAR(view.depth.at(80, 60), 1.5f, 1e-4);
  // Only one instance requested.
  opt.only_instance = 1;
  renderer.render(map, SE3(), small_camera(), opt, &view);
  EXPECT_EQ(view.instance_id.at(80, 60), 1);
  EXPECT_NEAR(view.depth.at(80, 60), 2.0f, 1e-4);
  // Seen from behind (camera at z = 4 looking back), the walls face away: nothing is drawn.
  const SE3 T_world_cam(so3_exp(Vec3(0, M_PI, 0)), Vec3(0, 0, 4));
  opt.only_instance = 0;
  renderer.render(map, T_world_cam, small_camera(), opt, &view);
  EXPECT_EQ(view.drawn_surfels, 0u);
  EXPECT_EQ(view.surfel_index.at(80, 60), -1);
}

TEST(MapRenderer, FiltersByConfidenceAndActiveWindow) {
  SurfelMap map = make_wall(2.0f, 1);
  for (size_t i = 0; i < map.size(); ++i) {
    map.confidence[i] = (i % 2 == 0) ? 20.0f : 1.0f;
    map.last_seen_time[i] = (i % 3 == 0) ? 0 : 500;
  }
  MapRenderer renderer;
  RenderedView view;
  RenderOptions opt;
  opt.min_confidence = 10.0f;
  renderer.render(map, SE3(), small_camera(), opt, &view);
  for (int v = 0; v < 120; ++v)
    for (int u = 0; u < 160; ++u)
      if (const int s = view.surfel_index.at(u, v); s >= 0) {
        ASSERT_GE(map.confidence[s], 10.0f);
      }
  opt.min_confidence = 0.0f;
  opt.active_window_frames = 200;
  opt.now = 600;
  renderer.render(map, SE3(), small_camera(), opt, &view);
  for (int v = 0; v < 120; ++v)
    for (int u = 0; u < 160; ++u)
      if (const int s = view.surfel_index.at(u, v); s >= 0) {
        ASSERT_EQ(map.last_seen_time[s], 500);
      }
  EXPECT_GT(view.drawn_surfels, 0u);
}

TEST(MapRenderer, AWindowEqualsThatWindowOfTheWholeImageBitForBit) {
  // Two walls with tilted, jittered surfels seen obliquely, through a camera whose principal point
  // is not a pixel centre (a cropped camera would round it differently).
  SurfelMap map = make_wall(2.0f, 1);
  const SurfelMap front = make_wall(1.5f, 2, 0.02f);
  for (size_t i = 0; i < front.size(); ++i) map.push_back(front.get(i));
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> jitter(-0.2f, 0.2f);
  for (size_t i = 0; i < map.size(); ++i) {
    map.normal_world[i] = Vec3f(jitter(rng), jitter(rng), -1.0f).normalized();
    map.color[i] = Rgb8{static_cast<std::uint8_t>(i), static_cast<std::uint8_t>(i / 7), 9};
  }
  PinholeIntrinsics K = small_camera();
  K.cx = 79.37, K.cy = 61.81;
  const SE3 T_world_cam(so3_exp(Vec3(0.05, -0.08, 0.03)), Vec3(0.03, -0.02, 0.1));
  RenderOptions opt;
  opt.want_instance = opt.want_surfel_centre = true;
  MapRenderer renderer;
  RenderedView whole, window;
  renderer.render(map, T_world_cam, K, opt, &whole);
  opt.window_u0 = 37, opt.window_v0 = 23, opt.window_width = 61, opt.window_height = 45;
  renderer.render(map, T_world_cam, K, opt, &window);
  ASSERT_EQ(window.depth.width(), 61);
  ASSERT_EQ(window.depth.height(), 45);
  int covered = 0;
  for (int v = 0; v < 45; ++v)
    for (int u = 0; u < 61; ++u) {
      const int x = u + 37, y = v + 23;
      ASSERT_EQ(window.surfel_index.at(u, v), whole.surfel_index.at(x, y)) << x << "," << y;
      ASSERT_EQ(window.depth.at(u, v), whole.depth.at(x, y)) << x << "," << y;
      ASSERT_EQ(window.vertex.at(u, v), whole.vertex.at(x, y)) << x << "," << y;
      ASSERT_EQ(window.normal.at(u, v), whole.normal.at(x, y)) << x << "," << y;
      ASSERT_EQ(window.color.at(u, v), whole.color.at(x, y)) << x << "," << y;
      ASSERT_EQ(window.instance_id.at(u, v), whole.instance_id.at(x, y)) << x << "," << y;
      ASSERT_EQ(window.surfel_centre.at(u, v), whole.surfel_centre.at(x, y)) << x << "," << y;
      covered += window.surfel_index.at(u, v) >= 0;
    }
  EXPECT_GT(covered, 61 * 45 / 2);
  // Fewer surfels reach the window than the whole image.
  EXPECT_LT(window.drawn_surfels, whole.drawn_surfels);
}

// The label-aware instance render's two views in one pass: every surfel, and the labelled ones
// (some hidden by unlabelled ones in the first), equal to two render() calls bit for bit.
TEST(MapRenderer, RenderWithLabelledEqualsTwoRendersBitForBit) {
  SurfelMap map = make_wall(2.0f, 0);
  const SurfelMap object = make_wall(1.5f, 4, 0.02f);
  for (size_t i = 0; i < object.size(); i += 3) {  // a sparse front, half of it unlabelled
    Surfel sf = object.get(i);
    sf.instance_id = i % 2 == 0 ? 4 : 0;
    map.push_back(sf);
  }
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> jitter(-0.2f, 0.2f);
  for (size_t i = 0; i < map.size(); ++i) {
    map.normal_world[i] = Vec3f(jitter(rng), jitter(rng), -1.0f).normalized();
    map.color[i] = Rgb8{static_cast<std::uint8_t>(i), static_cast<std::uint8_t>(i / 5), 3};
    if (map.instance_id[i] == 0 && i % 7 == 0) map.instance_id[i] = 2;  // labelled in the back
  }
  const SE3 T_world_cam(so3_exp(Vec3(0.04, -0.06, 0.02)), Vec3(0.02, -0.01, 0.05));
  RenderOptions opt;
  opt.max_splat_radius_px = 2.0f;
  opt.want_vertex = opt.want_normal = false;
  opt.window_u0 = 21, opt.window_v0 = 17, opt.window_width = 97, opt.window_height = 71;
  RenderOptions wants = opt;
  wants.want_instance = true;
  wants.want_color = false;
  MapRenderer renderer;
  RenderedView all, labelled, all_ref, labelled_ref;
  renderer.render_with_labelled(map, T_world_cam, small_camera(), opt, wants, &all, &labelled);
  renderer.render(map, T_world_cam, small_camera(), opt, &all_ref);
  wants.only_labelled = true;
  renderer.render(map, T_world_cam, small_camera(), wants, &labelled_ref);
  ASSERT_EQ(labelled.instance_id.size(), labelled_ref.instance_id.size());
  EXPECT_TRUE(labelled.color.empty());
  int front = 0, back = 0, hidden = 0;
  for (size_t k = 0; k < all.depth.size(); ++k) {
    ASSERT_EQ(all.surfel_index[k], all_ref.surfel_index[k]) << k;
    ASSERT_EQ(all.depth[k], all_ref.depth[k]) << k;
    ASSERT_EQ(all.color[k], all_ref.color[k]) << k;
    ASSERT_EQ(labelled.surfel_index[k], labelled_ref.surfel_index[k]) << k;
    ASSERT_EQ(labelled.depth[k], labelled_ref.depth[k]) << k;
    ASSERT_EQ(labelled.instance_id[k], labelled_ref.instance_id[k]) << k;
    if (labelled.surfel_index[k] >= 0) {
      ASSERT_GT(labelled.instance_id[k], 0) << k;
    }
    front += labelled.instance_id[k] == 4;
    back += labelled.instance_id[k] == 2;
    // A labelled surfel behind an unlabelled one.
    hidden += labelled.instance_id[k] > 0 && map.instance_id[all.surfel_index[k]] == 0;
  }
  EXPECT_GT(front, 100);
  EXPECT_GT(back, 100);
  EXPECT_GT(hidden, 0);
  EXPECT_EQ(labelled.drawn_surfels, labelled_ref.drawn_surfels);
  EXPECT_LT(labelled.drawn_surfels, all.drawn_surfels);
  // The surface band is one z-buffer pass more: not in one pass.
  opt.surface_band_m = 0.05f;
  EXPECT_THROW(
      renderer.render_with_labelled(map, T_world_cam, small_camera(), opt, wants, &all, &labelled),
      std::invalid_argument);
}

// Where noisy surfels of one surface overlap, the nearest disc is biased towards the camera; with
// a surface band the disc centred nearest the pixel shows, and the surface's depth is unbiased,
// while a nearer surface beyond the band still occludes (docs/SLAM.md, "Session 19: the tracking
// prediction's surface band").
TEST(MapRenderer, ASurfaceBandShowsNoisyOverlappingSurfelsWithoutBias) {
  SurfelMap map = make_wall(2.0f, 1);  // 1 cm spacing, radius 1 cm: each pixel meets ~3 discs
  std::mt19937 rng(3);
  std::normal_distribution<float> noise(0.0f, 0.01f);
  for (Vec3f& p : map.position_world) p.z() += noise(rng);
  const SurfelMap front = make_wall(1.5f, 2, 0.02f);  // 0.5 m nearer, on the left half only
  for (size_t i = 0; i < front.size(); ++i)
    if (front.position_world[i].x() < -0.1f) map.push_back(front.get(i));
  MapRenderer renderer;
  RenderedView view;
  RenderOptions opt;
  opt.want_instance = true;
  auto mean_wall_depth = [&] {
    double sum = 0;
    int n = 0;
    for (int v = 30; v < 90; ++v)
      for (int u = 90; u < 110; ++u) {  // x in [0.07, 0.2] m: the noisy wall only
        sum += view.depth.at(u, v);
        ++n;
      }
    return sum / n;
  };
  renderer.render(map, SE3(), small_camera(), opt, &view);
  const double nearest = mean_wall_depth();
  EXPECT_LT(nearest, 1.995);  // the nearest of the overlapping discs: 8 mm in front
  opt.surface_band_m = 0.05f;
  renderer.render(map, SE3(), small_camera(), opt, &view);
  EXPECT_NEAR(mean_wall_depth(), 2.0, 0.001);  // 0.3 mm
  EXPECT_EQ(view.instance_id.at(50, 60), 2);   // the front wall, 0.5 m nearer, still occludes
  EXPECT_NEAR(view.depth.at(50, 60), 1.5f, 1e-4);
}

TEST(MapRenderer, IndexMapHoldsEachSurfelCentreInItsCell) {
  const SurfelMap map = make_wall(2.0f, 1, 0.02f);
  MapRenderer renderer;
  IndexMap index;
  renderer.render_index_map(map, SE3(), small_camera(), 2, RenderOptions{}, &index);
  ASSERT_EQ(index.surfel_index.width(), 320);
  ASSERT_EQ(index.surfel_index.height(), 240);
  const PinholeIntrinsics K = small_camera();
  size_t found = 0;
  for (int y = 0; y < 240; ++y)
    for (int x = 0; x < 320; ++x) {
      const int s = index.surfel_index.at(x, y);
      if (s < 0) continue;
      ++found;
      const Vec3f p = map.position_world[s];
      const double u = K.fx * p.x() / p.z() + K.cx, v = K.fy * p.y() / p.z() + K.cy;
      EXPECT_EQ(static_cast<int>(std::floor((u + 0.5) * 2)), x);
      EXPECT_EQ(static_cast<int>(std::floor((v + 0.5) * 2)), y);
      EXPECT_NEAR(index.depth.at(x, y), 2.0f, 1e-5);
    }
  // 2 cm spacing at 2 m is 1.5 px: every surfel gets its own cell.
  EXPECT_EQ(found, map.size());
  EXPECT_EQ(index.drawn_surfels, map.size());
}

}  // namespace
}  // namespace orpe::slam
