// The guards that keep an instance's segment to its object (segment_guard.h, issue #14): a small
// object in front of a far wall, seen through dilated masks, must keep no wall surfels; surfaces
// that are continuous in depth and objects split in two keep theirs.
#include <gtest/gtest.h>

#include <array>
#include <cmath>

#include "orpe/semantic/segment_guard.h"
#include "orpe/semantic/semantic_fusion.h"
#include "planar_setup.h"

namespace orpe {
namespace {

/// One surfel per pixel at depth depth_of(u, v), facing the camera at the origin; the frame's depth
/// is the same image (every pixel observes its own surfel).
struct DepthSetup {
  PinholeIntrinsics K;
  slam::SurfelMap map;
  slam::IndexImage pixel_surfel;
  DepthImage depth;

  template <class F>
  DepthSetup(int width, int height, double f, F depth_of) {
    K.width = width;
    K.height = height;
    K.fx = K.fy = f;
    K.cx = (width - 1) / 2.0;
    K.cy = (height - 1) / 2.0;
    pixel_surfel = slam::IndexImage(width, height, -1);
    depth = DepthImage(width, height, 0.0f);
    for (int v = 0; v < height; ++v)
      for (int u = 0; u < width; ++u) {
        const double z = depth_of(u, v);
        depth.at(u, v) = static_cast<float>(z);
        slam::Surfel s;
        s.position_world = K.backproject(u, v, z).cast<float>();
        s.normal_world = Eigen::Vector3f(0, 0, -1);
        s.radius_m = static_cast<float>(0.7 * z / f);
        s.confidence = 20;
        pixel_surfel.at(u, v) = static_cast<std::int32_t>(map.push_back(s));
      }
  }
  RgbdFrame frame(int index) const {
    RgbdFrame fr;
    fr.index = index;
    fr.name = "depth setup";
    fr.intrinsics = K;
    fr.color = ColorImage(K.width, K.height);
    fr.depth = depth;
    return fr;
  }
};

SemanticParams guards(bool edge, bool connectivity, bool support = false) {
  SemanticParams p;
  p.edge_depth_guard = edge;
  p.segment_connectivity_guard = connectivity;
  p.support_plane_guard = support;
  p.segment_confirmed_surfels_only = false;  // the scenes below are built by hand, not fused
  return p;
}

// A 3.3 cm object (20 x 20 px at 0.5 m) in front of a wall at 1.5 m; the detector's mask is the
// object dilated by 4 px on every side (the gt back-end's dilation, or a real detector's overhang).
struct WallScene {
  static constexpr int kU0 = 70, kU1 = 89, kV0 = 50, kV1 = 69, kDilate = 4;
  static bool on_object(int u, int v) { return u >= kU0 && u <= kU1 && v >= kV0 && v <= kV1; }
  DepthSetup s{160, 120, 300.0, [](int u, int v) { return on_object(u, v) ? 0.5 : 1.5; }};

  /// Counts (wall surfels, object surfels) that carry an instance after five keyframes + finalize.
  std::pair<int, int> labelled_after_fusion(const SemanticParams& params) {
    SemanticFusion fusion(params);
    const Detection d = test::rect_detection(160, 120, 3, 0.95f, kU0 - kDilate, kV0 - kDilate,
                                             kU1 + kDilate, kV1 + kDilate, 0.9f, 0.02f);
    for (int k = 0; k < 5; ++k) fusion.integrate(s.frame(k), {d}, SE3(), s.map, &s.pixel_surfel);
    fusion.finalize(s.map);
    int wall = 0, object = 0;
    for (int v = 0; v < 120; ++v)
      for (int u = 0; u < 160; ++u)
        if (s.map.instance_id[s.pixel_surfel.at(u, v)] > 0) ++(on_object(u, v) ? object : wall);
    return {wall, object};
  }
};

TEST(SegmentGuard, ASmallObjectSeenThroughDilatedMasksKeepsNoWallSurfels) {
  const int object_px = 20 * 20;
  {
    WallScene scene;
    const auto [wall, object] = scene.labelled_after_fusion(guards(true, true, true));
    EXPECT_EQ(wall, 0);
    EXPECT_EQ(object, object_px);
  }
  // Each guard on its own removes the wall ring: the pixel rule before labelling, the connectivity
  // rule (a piece entirely behind the segment's main body) after it.
  for (const auto& [edge, connectivity] : {std::pair{true, false}, std::pair{false, true}}) {
    WallScene scene;
    const auto [wall, object] = scene.labelled_after_fusion(guards(edge, connectivity));
    EXPECT_EQ(wall, 0) << "edge guard " << edge << ", connectivity guard " << connectivity;
    EXPECT_EQ(object, object_px);
  }
  // Without the guards the dilated ring of wall surfels (28^2 - 20^2 px) carries the label (the
  // support-plane guard alone would release it too: the wall is a large plane).
  WallScene scene;
  const auto [wall, object] = scene.labelled_after_fusion(guards(false, false));
  EXPECT_EQ(wall, 28 * 28 - 20 * 20);
  EXPECT_EQ(object, object_px);
}

TEST(SegmentGuard, ContinuousSurfacesAndSplitObjectsKeepTheirSurfels) {
  // A plane sloping away at 2 mm per pixel (a steep face): no depth jump, nothing is dropped.
  {
    DepthSetup s(120, 90, 300.0, [](int u, int) { return 0.5 + 0.002 * u; });
    SemanticFusion fusion(guards(true, true, true));
    const Detection d = test::rect_detection(120, 90, 3, 0.95f, 30, 20, 89, 69, 0.9f, 0.02f);
    for (int k = 0; k < 3; ++k) fusion.integrate(s.frame(k), {d}, SE3(), s.map, &s.pixel_surfel);
    fusion.finalize(s.map);
    int labelled = 0;
    for (const auto id : s.map.instance_id) labelled += id > 0;
    EXPECT_EQ(labelled, 60 * 50);
  }
  // An object split by an occluder strip in front of it: both halves lie at the object's depth and
  // both are kept, though they are disconnected in 3D.
  {
    auto on_strip = [](int u) { return u >= 55 && u <= 64; };
    DepthSetup s(120, 90, 300.0, [&](int u, int v) {
      if (on_strip(u)) return 0.3;
      return (u >= 30 && u <= 89 && v >= 20 && v <= 69) ? 0.6 : 1.5;
    });
    SemanticFusion fusion(guards(true, true, true));
    const Detection d = test::make_detection(120, 90, 3, 0.95f, [&](int u, int v) {
      return (u >= 30 && u <= 89 && v >= 20 && v <= 69 && !on_strip(u)) ? 0.9f : 0.02f;
    });
    for (int k = 0; k < 3; ++k) fusion.integrate(s.frame(k), {d}, SE3(), s.map, &s.pixel_surfel);
    fusion.finalize(s.map);
    int left = 0, right = 0;
    for (int v = 20; v <= 69; ++v)
      for (int u = 30; u <= 89; ++u)
        if (s.map.instance_id[s.pixel_surfel.at(u, v)] > 0) ++(u < 55 ? left : right);
    EXPECT_EQ(left, 25 * 50);
    EXPECT_EQ(right, 25 * 50);
  }
}

/// A 1.2 x 1.2 m table (plane y = 0, normal +y, 1 mm of deterministic noise) with a 6 cm box
/// standing on it and a flat 10 x 10 cm sheet lying on it. The box's instance also holds the table
/// surfels of a 3 cm ring around its footprint (what a mask overhanging the silhouette labels: the
/// table there is continuous in depth with the box's base, so the edge and connectivity guards
/// keep it).
struct TableScene {
  static constexpr int kBox = 1, kSheet = 2;
  slam::SurfelMap map;
  std::vector<char> is_ring, is_box, is_sheet;

  TableScene() {
    auto add = [&](const Eigen::Vector3f& p, const Eigen::Vector3f& n, int id, char ring, char box,
                   char sheet) {
      slam::Surfel s;
      s.position_world = p;
      s.normal_world = n;
      s.radius_m = 0.003f;
      s.confidence = 20;
      s.instance_id = id;
      map.push_back(s);
      is_ring.push_back(ring);
      is_box.push_back(box);
      is_sheet.push_back(sheet);
    };
    const float h = 0.06f, step = 0.005f;
    for (int i = 0; i <= 240; ++i)
      for (int k = 0; k <= 240; ++k) {
        const float x = -0.6f + step * i, z = 0.4f + step * k;
        const float noise = 0.001f * static_cast<float>(((i * 7 + k * 13) % 5) - 2) / 2;
        const bool under_box = std::abs(x) < h / 2 && std::abs(z - 1.0f) < h / 2;
        if (under_box) continue;
        const bool ring = std::abs(x) < h / 2 + 0.03f && std::abs(z - 1.0f) < h / 2 + 0.03f;
        const bool sheet = x > 0.3f && x < 0.4f && z > 0.6f && z < 0.7f;
        add({x, noise, z}, Eigen::Vector3f::UnitY(),
            ring    ? kBox
            : sheet ? kSheet
                    : 0,
            ring, 0, sheet);
      }
    // The box: its top and its four sides, down to 2 mm above the table.
    for (float a = -h / 2; a <= h / 2 + 1e-6f; a += step)
      for (float b = -h / 2; b <= h / 2 + 1e-6f; b += step) {
        add({a, h, 1.0f + b}, Eigen::Vector3f::UnitY(), kBox, 0, 1, 0);
        const float y = 0.002f + (b + h / 2) * (h - 0.002f) / h;
        add({a, y, 1.0f - h / 2}, -Eigen::Vector3f::UnitZ(), kBox, 0, 1, 0);
        add({a, y, 1.0f + h / 2}, Eigen::Vector3f::UnitZ(), kBox, 0, 1, 0);
        add({-h / 2, y, 1.0f + a}, -Eigen::Vector3f::UnitX(), kBox, 0, 1, 0);
        add({h / 2, y, 1.0f + a}, Eigen::Vector3f::UnitX(), kBox, 0, 1, 0);
      }
  }
  /// (ring, box, sheet) surfels that still carry their instance.
  std::array<int, 3> labelled() const {
    std::array<int, 3> n{0, 0, 0};
    for (size_t i = 0; i < map.size(); ++i) {
      if (map.instance_id[i] <= 0) continue;
      n[0] += is_ring[i];
      n[1] += is_box[i];
      n[2] += is_sheet[i];
    }
    return n;
  }
  std::array<int, 3> all() const {
    std::array<int, 3> n{0, 0, 0};
    for (size_t i = 0; i < map.size(); ++i) {
      n[0] += is_ring[i];
      n[1] += is_box[i];
      n[2] += is_sheet[i];
    }
    return n;
  }
};

TEST(SegmentGuard, AnObjectOnATableKeepsNoTableSurfels) {
  TableScene scene;
  const auto planes = find_support_planes(scene.map, 3, 0.15, 0.35, 0.01);
  ASSERT_EQ(planes.size(), 1u);  // the table; the box's faces are far too small
  EXPECT_GT(std::abs(planes[0].plane.normal.y()), 0.999f);
  EXPECT_NEAR(planes[0].tolerance_m, 0.003f, 1e-4f);  // 1 mm noise: the 3 mm floor
  const auto all = scene.all();
  const int released = release_support_plane_surfels(scene.map, planes, 30.0, true);
  const auto kept = scene.labelled();
  EXPECT_EQ(released, all[0]);
  EXPECT_EQ(kept[0], 0) << "table ring";
  EXPECT_EQ(kept[1], all[1]) << "the box keeps its sides down to 2 mm above the table";
  EXPECT_EQ(kept[2], all[2]) << "a sheet lying flat is itself on the plane: left to the class "
                                "average";
}

TEST(SegmentGuard, ASubsetOfTheMapFindsTheSameSupportPlane) {
  // The table scene's ~58k background surfels searched on a strided subset of 5000: the same plane
  // (normal within 0.1 degree, offset within 0.5 mm), the same tolerance, the same surfels released.
  TableScene all_points, subset;
  const auto a = find_support_planes(all_points.map, 3, 0.15, 0.35, 0.01);
  const auto b = find_support_planes(subset.map, 3, 0.15, 0.35, 0.01, 5000);
  ASSERT_EQ(a.size(), 1u);
  ASSERT_EQ(b.size(), 1u);
  EXPECT_GT(std::abs(a[0].plane.normal.dot(b[0].plane.normal)), std::cos(0.1 * M_PI / 180));
  EXPECT_NEAR(a[0].plane.d, b[0].plane.d, 5e-4);
  EXPECT_NEAR(a[0].tolerance_m, b[0].tolerance_m, 1e-4);
  EXPECT_LT(b[0].inliers, 5001u);
  EXPECT_EQ(release_support_plane_surfels(all_points.map, a, 30.0, true),
            release_support_plane_surfels(subset.map, b, 30.0, true));
}

TEST(SegmentGuard, FinalizeAppliesTheSupportPlaneGuardOnlyWhenOn) {
  for (const bool on : {true, false}) {
    TableScene scene;
    SemanticFusion fusion(guards(true, true, on));
    fusion.finalize(scene.map);
    const auto kept = scene.labelled();
    EXPECT_EQ(kept[0], on ? 0 : scene.all()[0]) << "guard " << on;
    EXPECT_EQ(kept[1], scene.all()[1]);
  }
  // On by default.
  EXPECT_TRUE(SemanticParams().support_plane_guard);
}

TEST(SegmentGuard, FinalizeReleasesOnceSeenSurfelsNextToConfirmedSurfaceWhenOn) {
  // Instance 1: 100 confirmed surfels (fused in frames 3..9) on a 1 mm line; 30 once-seen surfels
  // (created in frame 9, never re-observed: last_seen_time == init_time) 6 mm off that line, next
  // to it (an outlier of a surface already known); 20 once-seen surfels 10 cm away (new surface,
  // kept); 10 once-seen background surfels keep label 0.
  auto scene = [] {
    slam::SurfelMap map;
    auto add = [&](const Eigen::Vector3f& p, int init, int id) {
      slam::Surfel s;
      s.position_world = p;
      s.radius_m = 0.002f;
      s.confidence = init < 9 ? 5.0f : 0.8f;
      s.init_time = init;
      s.last_seen_time = 9;
      s.instance_id = id;
      s.always_active = id > 0;
      map.push_back(s);
    };
    for (int i = 0; i < 100; ++i) add({0.001f * i, 0, 1}, 3, 1);
    for (int i = 0; i < 30; ++i) add({0.003f * i, 0.0f, 1.006f}, 9, 1);
    for (int i = 0; i < 20; ++i) add({0.001f * i, 0.1f, 1}, 9, 1);
    for (int i = 0; i < 10; ++i) add({0.001f * i, 0.5f, 1}, 9, 0);
    return map;
  };
  for (const bool on : {true, false}) {
    slam::SurfelMap map = scene();
    SemanticParams p = guards(false, false, false);
    p.segment_confirmed_surfels_only = on;
    SemanticFusion(p).finalize(map);
    int outliers = 0, confirmed = 0, new_surface = 0, active = 0;
    for (size_t i = 0; i < map.size(); ++i) {
      const bool labelled = map.instance_id[i] == 1;
      (i < 100 ? confirmed : i < 130 ? outliers : i < 150 ? new_surface : active) += labelled;
      if (i < 150) active += map.always_active[i];
    }
    EXPECT_EQ(confirmed, 100);
    EXPECT_EQ(outliers, on ? 0 : 30) << "rule " << on;
    EXPECT_EQ(new_surface, 20)
        << "once-seen surfels away from the confirmed surface are new surface";
    EXPECT_EQ(active, on ? 120 : 150) << "released surfels are no longer always active";
    EXPECT_EQ(map.size(), 160u) << "the surfels stay in the map";
  }
  EXPECT_TRUE(SemanticParams().segment_confirmed_surfels_only);  // on by default
}

TEST(SegmentGuard, PixelsBehindTheMaskEdgeAreDropped) {
  // Label 1 over a 10 x 10 block at 0.5 m plus a 2-px ring at 1.5 m; label 2 elsewhere at 1.5 m.
  const int W = 40, H = 30;
  DepthImage depth(W, H, 1.5f);
  LabelImage labels(W, H, 2);
  ProbabilityImage prob(W, H, 0.9f);
  for (int v = 8; v <= 21; ++v)
    for (int u = 13; u <= 26; ++u) {
      labels.at(u, v) = 1;
      if (u >= 15 && u <= 24 && v >= 10 && v <= 19) depth.at(u, v) = 0.5f;
    }
  const int dropped = drop_pixels_behind_mask_edges(depth, &labels, &prob, 4, 0.02, 500.0);
  EXPECT_EQ(dropped, 14 * 14 - 10 * 10);
  EXPECT_EQ(labels.at(13, 8), 0);
  EXPECT_EQ(prob.at(13, 8), 0.0f);
  EXPECT_EQ(labels.at(15, 10), 1);
  EXPECT_EQ(labels.at(0, 0), 2) << "label 2 has no nearer pixels of its own";
  EXPECT_EQ(labels.at(30, 15), 2);
}

TEST(SegmentGuard, ComponentsAreNumberedBySize) {
  std::vector<Eigen::Vector3f> pts;
  for (int i = 0; i < 30; ++i) pts.emplace_back(0.002f * i, 0, 1);         // a 6 cm line
  for (int i = 0; i < 10; ++i) pts.emplace_back(0.5f + 0.002f * i, 0, 1);  // 44 cm away
  pts.emplace_back(0.0f, 0.2f, 1.0f);                                      // alone
  const auto c = segment_components(pts, 0.01f);
  for (int i = 0; i < 30; ++i) EXPECT_EQ(c[i], 0);
  for (int i = 30; i < 40; ++i) EXPECT_EQ(c[i], 1);
  EXPECT_EQ(c[40], 2);
}

}  // namespace
}  // namespace orpe
