// The guards that keep an instance's segment to its object (segment_guard.h, issue #14): a small
// object in front of a far wall, seen through dilated masks, must keep no wall surfels; surfaces
// that are continuous in depth and objects split in two keep theirs.
#include <gtest/gtest.h>

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

SemanticParams guards(bool edge, bool connectivity) {
  SemanticParams p;
  p.edge_depth_guard = edge;
  p.segment_connectivity_guard = connectivity;
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
    const auto [wall, object] = scene.labelled_after_fusion(guards(true, true));
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
  // Without the guards the dilated ring of wall surfels (28^2 - 20^2 px) carries the label.
  WallScene scene;
  const auto [wall, object] = scene.labelled_after_fusion(guards(false, false));
  EXPECT_EQ(wall, 28 * 28 - 20 * 20);
  EXPECT_EQ(object, object_px);
}

TEST(SegmentGuard, ContinuousSurfacesAndSplitObjectsKeepTheirSurfels) {
  // A plane sloping away at 2 mm per pixel (a steep face): no depth jump, nothing is dropped.
  {
    DepthSetup s(120, 90, 300.0, [](int u, int) { return 0.5 + 0.002 * u; });
    SemanticFusion fusion(guards(true, true));
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
    SemanticFusion fusion(guards(true, true));
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
