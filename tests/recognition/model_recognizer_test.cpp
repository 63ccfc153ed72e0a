#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>

#include "orpe/core/error.h"
#include "orpe/pose/colour_score.h"
#include "orpe/recognition/model_recognizer.h"
#include "orpe/recognition/scene_geometry.h"
#include "orpe/semantic/detection.h"
#include "recognition/recognition_scene.h"

namespace orpe {
namespace {

using test::PlacedObject;
using test::TestShapes;

const TestShapes& shapes() {
  static const TestShapes s;
  return s;
}

ModelRecognizer make_recognizer(const std::vector<int>& classes = {1, 2, 3},
                                const RecognitionParams& params = {},
                                const SceneGeometryParams& geometry = {}) {
  std::vector<ObjectModel> models;
  for (const auto& m : shapes().models())
    if (std::count(classes.begin(), classes.end(), m.class_id)) models.push_back(m);
  return ModelRecognizer(SegmentationParams{}, params, geometry, models);
}

std::map<int, int> class_counts(const std::vector<Detection>& dets) {
  std::map<int, int> out;
  for (const auto& d : dets) ++out[d.class_id];
  return out;
}

TEST(SceneGeometry, RemovesTheSupportPlaneAndKeepsTheObject) {
  const auto& s = shapes();
  const PlacedObject box{1, &s.box, TestShapes::on_table(0, 0, 0.4, 0.025)};
  const RgbdFrame f = test::render_table_scene({box});
  const SceneGeometryParams gp;
  SceneGrid g = make_scene_grid(f.depth, f.intrinsics, gp);
  remove_support_planes(g, gp);
  ASSERT_FALSE(g.planes.empty());
  // The table is z = 0: its normal in the camera frame is the world z axis.
  const Vec3 n_cam = f.T_world_cam_gt->rotation().transpose() * Vec3::UnitZ();
  EXPECT_GT(std::abs(n_cam.dot(g.planes.front().normal.cast<double>())), 0.999);
  int table_kept = 0, table = 0, object_kept = 0, object = 0;
  for (size_t c = 0; c < g.points.size(); ++c) {
    if (!g.valid[c]) continue;
    const Vec3 w = *f.T_world_cam_gt * g.points[c].cast<double>();
    const bool on_object = w.z() > 0.004;
    (on_object ? object : table) += 1;
    if (g.kept[c]) (on_object ? object_kept : table_kept) += 1;
  }
  ASSERT_GT(object, 300);
  EXPECT_EQ(table_kept, 0);
  EXPECT_GT(object_kept, 0.75 * object);  // the box's bottom centimetre goes with the plane
  const auto regions = split_regions(g, gp);
  ASSERT_EQ(regions.size(), 1u);
}

// Objects of one height: their tops are coplanar and, together, as large and as spread as a
// support. A support hides what lies below it, the tops do not (the table is seen between them):
// they are not removed (with what lies below them, i.e. the objects) as a second plane.
TEST(SceneGeometry, CoplanarTopsOfSeveralObjectsAreNoSupportPlane) {
  const auto& s = shapes();
  std::vector<PlacedObject> boxes;
  for (double x : {-0.2, 0.0, 0.2})
    for (double y : {-0.1, 0.12})
      boxes.push_back({1, &s.box, TestShapes::on_table(x, y, 0.2, 0.025)});
  const RgbdFrame f = test::render_table_scene(boxes, Vec3(0.0, -0.55, 0.5), Vec3(0, 0.02, 0.02));
  auto kept_object_fraction = [&](bool occlusion_test) {
    SceneGeometryParams gp;
    if (!occlusion_test) gp.max_seen_below_fraction = 1;
    gp.min_plane_fraction = 0.05;
    SceneGrid g = make_scene_grid(f.depth, f.intrinsics, gp);
    remove_support_planes(g, gp);
    int object = 0, kept = 0;
    for (size_t c = 0; c < g.points.size(); ++c) {
      if (!g.valid[c] || (*f.T_world_cam_gt * g.points[c].cast<double>()).z() < 0.012) continue;
      ++object;
      kept += g.kept[c];
    }
    return object > 0 ? static_cast<double>(kept) / object : 0.0;
  };
  EXPECT_GT(kept_object_fraction(true), 0.9);
  EXPECT_LT(kept_object_fraction(false), 0.5);  // the mechanism off: the tops went as a plane
}

// A square face turned in its plane: its principal axes are arbitrary (the covariance is
// isotropic), the least-area rectangle is the face's own (the cracker box of YCB-Video clip 0001
// measured its diagonal and was never searched).
TEST(SceneGeometry, ExtentsOfANearSquareFaceAreItsSides) {
  std::vector<Eigen::Vector3f> pts;
  const Eigen::Matrix3f R =
      Eigen::AngleAxisf(0.5f, Eigen::Vector3f::UnitZ()).toRotationMatrix();  // ~29 degrees
  for (int i = 0; i <= 40; ++i)
    for (int j = 0; j <= 40; ++j)
      pts.push_back(R * Eigen::Vector3f(0.1f * i / 40, 0.1f * j / 40, 0.0f));
  const Eigen::Vector3f e = principal_extents(pts);
  EXPECT_NEAR(e[0], 0.1f, 0.006f);
  EXPECT_NEAR(e[1], 0.1f, 0.006f);
  EXPECT_NEAR(e[2], 0.0f, 1e-4f);
  EXPECT_GT(principal_extents(pts, false)[0], 0.115f);  // the mechanism off: a diagonal's extent
}

TEST(SceneGeometry, SplitsSeparateObjectsIntoRegions) {
  const auto& s = shapes();
  const RgbdFrame f =
      test::render_table_scene({{1, &s.box, TestShapes::on_table(-0.12, 0, 0.3, 0.025)},
                                {2, &s.can, TestShapes::on_table(0.10, 0.02, 0, 0.055)}});
  const SceneGeometryParams gp;
  SceneGrid g = make_scene_grid(f.depth, f.intrinsics, gp);
  remove_support_planes(g, gp);
  const auto regions = split_regions(g, gp);
  ASSERT_EQ(regions.size(), 2u);
  SceneGeometryParams no_planes = gp;
  no_planes.max_planes = 0;
  SceneGrid g2 = make_scene_grid(f.depth, f.intrinsics, no_planes);
  remove_support_planes(g2, no_planes);
  const auto with_table = split_regions(g2, no_planes);
  ASSERT_FALSE(with_table.empty());  // without plane removal the table is the largest region
  EXPECT_GT(with_table.front().cells.size(),
            3 * (regions[0].cells.size() + regions[1].cells.size()));
}

TEST(SceneGeometry, RegionSizeSettingsAreChecked) {
  std::string why;
  SceneGeometryParams gp;
  EXPECT_TRUE(gp.IsValid(&why)) << why;
  gp.small_region_min_points = gp.min_region_points + 1;
  EXPECT_FALSE(gp.IsValid(&why));
  EXPECT_NE(why.find("small_region_min_points"), std::string::npos) << why;
  gp = SceneGeometryParams{};
  gp.min_region_area_m2 = -0.001;
  EXPECT_FALSE(gp.IsValid(&why));
  EXPECT_NE(why.find("min_region_area_m2"), std::string::npos) << why;
  RecognitionParams rp;
  rp.reject_memory_min_points = -1;
  EXPECT_FALSE(rp.IsValid(&why));
  EXPECT_NE(why.find("reject_memory_min_points"), std::string::npos) << why;
}

// A can 1.35 m away in a 320 x 240 image: ~100 grid points, under min_region_points, but ~75 cm^2
// of surface, so the area rule keeps it; a 3 cm cube beside it (9 cm^2) stays dropped.
TEST(SceneGeometry, KeepsAFarObjectsSmallRegionByItsArea) {
  const auto& s = shapes();
  const test::SurfaceSamples cube = test::sample_box({0.03f, 0.03f, 0.03f}, 0.0015f);
  const RgbdFrame f =
      test::render_table_scene({{2, &s.can, TestShapes::on_table(0, 0, 0, 0.055)},
                                {1, &cube, TestShapes::on_table(0.25, 0, 0, 0.015)}},
                               Vec3(0.0, -1.05, 0.85), Vec3(0.1, 0, 0.05));
  auto regions_with = [&](double min_area_m2) {
    SceneGeometryParams gp;
    gp.min_region_area_m2 = min_area_m2;
    SceneGrid g = make_scene_grid(f.depth, f.intrinsics, gp);
    remove_support_planes(g, gp);
    return std::make_pair(split_regions(g, gp), g);
  };
  const auto [regions, g] = regions_with(SceneGeometryParams{}.min_region_area_m2);
  ASSERT_EQ(regions.size(), 1u);
  const auto& can = regions.front();
  EXPECT_LT(static_cast<int>(can.cells.size()), SceneGeometryParams{}.min_region_points);
  EXPECT_NEAR(can.centroid.x(), (f.T_world_cam_gt->inverse() * Vec3(0, 0, 0.055)).x(), 0.03);
  EXPECT_GT(seen_area_m2(g, can.cells), 0.005);
  EXPECT_TRUE(regions_with(0).first.empty());  // the rule off: grid points alone drop the can
}

// A can standing on a large box: no depth step where they meet (the can's side runs into the
// box's top), but a concave crease. Objects are mostly convex, so the crease splits them.
TEST(SceneGeometry, SplitsAtTheConcaveCreaseWhereOneObjectRestsOnAnother) {
  const auto& s = shapes();
  const test::SurfaceSamples crate = test::sample_box({0.25f, 0.18f, 0.10f}, 0.002f);
  const RgbdFrame f =
      test::render_table_scene({{1, &crate, TestShapes::on_table(0, 0, 0.2, 0.05)},
                                {2, &s.can, TestShapes::on_table(0.0, 0.0, 0, 0.10 + 0.055)}},
                               Vec3(0.1, -0.6, 0.5), Vec3(0, 0, 0.1));
  auto regions_with = [&](double crease_deg) {
    SceneGeometryParams gp;
    gp.grid_stride_px = 1;  // the 320 x 240 test frame: every pixel, as 640 x 480 at stride 2
    gp.min_region_points = 4 * gp.min_region_points;
    gp.concave_edge_min_angle_deg = crease_deg;
    SceneGrid g = make_scene_grid(f.depth, f.intrinsics, gp);
    remove_support_planes(g, gp);
    const size_t n = split_regions(g, gp).size();
    return n;
  };
  EXPECT_EQ(regions_with(SceneGeometryParams{}.concave_edge_min_angle_deg), 2u);
  EXPECT_EQ(regions_with(0), 1u);  // the mechanism off: depth steps alone join them
}

// A large box seen by three faces: its principal axes run along none of its edges, and the
// extents along them exceed the box's (a 0.40 x 0.30 x 0.24 box measured 0.49 x 0.48 in the
// synthetic warehouse scenes). Any view of a model fits in the model's diameter.
TEST(ModelRecognizer, SizeTestOfABoxSeenByThreeFacesIsItsDiameter) {
  const Eigen::Vector3f size(0.40f, 0.30f, 0.24f);
  const test::SurfaceSamples dense = test::sample_box(size, 0.004f);
  ObjectModel model = test::make_model(test::sample_box(size, 0.01f));
  model.class_id = 7;
  model.name = "large_box";
  const RgbdFrame f = test::render_table_scene({{7, &dense, TestShapes::on_table(0, 0, 0.6, 0.12)}},
                                               Vec3(0.35, -0.75, 0.75), Vec3(0, 0, 0.1));
  auto detections_with = [&](bool by_diameter) {
    RecognitionParams p;
    p.extent_test_by_diameter = by_diameter;
    p.resting_search = false;  // the crop search alone (the resting search has no size test)
    return ModelRecognizer(SegmentationParams{}, p, SceneGeometryParams{}, {model}).detect(f);
  };
  EXPECT_EQ(class_counts(detections_with(true)), (std::map<int, int>{{7, 1}}));
  EXPECT_TRUE(detections_with(false).empty());  // the mechanism off: never searched
}

TEST(ModelRecognizer, RecognisesSeparateObjects) {
  const auto& s = shapes();
  const RgbdFrame f =
      test::render_table_scene({{1, &s.box, TestShapes::on_table(-0.12, 0, 0.3, 0.025)},
                                {2, &s.can, TestShapes::on_table(0.10, 0.02, 0, 0.055)}});
  const auto dets = make_recognizer().detect(f);
  EXPECT_EQ(class_counts(dets), (std::map<int, int>{{1, 1}, {2, 1}}));
}

// Open limitation (issue #11): the box's hypotheses explain the touching cube's points too, so the
// cube is not split off. Disabled until the verification separates touching objects.
TEST(ModelRecognizer, DISABLED_SplitsTouchingObjectsOfOneRegion) {
  const auto& s = shapes();
  // The box and the cube side by side, touching: one region, two objects.
  const RgbdFrame f =
      test::render_table_scene({{1, &s.box, TestShapes::on_table(-0.03, 0, 0, 0.025)},
                                {3, &s.cube, TestShapes::on_table(0.0525, 0.0, 0, 0.0225)}});
  const SceneGeometryParams gp;
  SceneGrid g = make_scene_grid(f.depth, f.intrinsics, gp);
  remove_support_planes(g, gp);
  ASSERT_EQ(split_regions(g, gp).size(), 1u);
  const auto dets = make_recognizer().detect(f);
  EXPECT_EQ(class_counts(dets), (std::map<int, int>{{1, 1}, {3, 1}}));
}

TEST(ModelRecognizer, ExplainsEachPointOnce) {
  const auto& s = shapes();
  // The cube fits inside the box's points; with joint verification only the box survives.
  const RgbdFrame f =
      test::render_table_scene({{1, &s.box, TestShapes::on_table(0, 0, 0.5, 0.025)}});
  const auto dets = make_recognizer().detect(f);
  EXPECT_EQ(class_counts(dets), (std::map<int, int>{{1, 1}}));
}

TEST(ModelRecognizer, MergesFragmentsOfAnOccludedObject) {
  const auto& s = shapes();
  // A thin pole in front of the box splits its visible surface in two regions.
  static const test::SurfaceSamples pole = test::sample_box({0.012f, 0.012f, 0.30f}, 0.0015f);
  const RgbdFrame f = test::render_table_scene(
      {{1, &s.box, TestShapes::on_table(0, 0, 0.0, 0.025)}}, Vec3(0.05, -0.5, 0.45),
      Vec3(0, 0, 0.03), 0, {{9, &pole, TestShapes::on_table(0.005, -0.15, 0, 0.15)}});
  const SceneGeometryParams gp;
  SceneGrid g = make_scene_grid(f.depth, f.intrinsics, gp);
  remove_support_planes(g, gp);
  const auto regions = split_regions(g, gp);
  ASSERT_GE(regions.size(), 2u);  // box fragments and the pole
  const auto dets = make_recognizer({1}).detect(f);
  ASSERT_EQ(dets.size(), 1u);
  // One detection covers both fragments: pixels left and right of the pole.
  int left = 0, right = 0;
  const int u_pole = static_cast<int>(
      f.intrinsics.project(f.T_world_cam_gt->inverse() * Vec3(0.005, -0.15, 0.05)).x());
  for (int v = 0; v < f.depth.height(); ++v)
    for (int u = 0; u < f.depth.width(); ++u)
      if (dets[0].probability.at(u, v) >= 0.5f) (u < u_pole ? left : right) += 1;
  EXPECT_GT(left, 100);
  EXPECT_GT(right, 100);
}

// A slab no model explains: two box hypotheses tile it, each explaining the other's neighbourhood
// (so neither outline leaks into unexplained surface), but their shared edge is seamless --
// surface, normals and colour continue across it -- so it is one surface, not two objects.
TEST(ModelRecognizer, RejectsWhatNoModelExplains) {
  const auto& s = shapes();
  static const test::SurfaceSamples slab = test::sample_box({0.25f, 0.02f, 0.09f}, 0.0015f);
  const RgbdFrame f =
      test::render_table_scene({{2, &s.can, TestShapes::on_table(0.12, 0.02, 0, 0.055)},
                                {9, &slab, TestShapes::on_table(-0.1, 0.0, 0.2, 0.045)}});
  EXPECT_EQ(class_counts(make_recognizer().detect(f)), (std::map<int, int>{{2, 1}}));
  // Without the seam test the two tiles survive (measured: two boxes).
  RecognitionParams no_seam;
  no_seam.max_seam_fraction = 1.0;
  no_seam.require_standing = false;  // a tile over the other stands on nothing: dropped by that
  EXPECT_GT(class_counts(make_recognizer({1, 2, 3}, no_seam).detect(f))[1], 0);
}

// A dent in the box's top face (a cone, 5 cm deep: its middle is unexplained but continues the
// surface smoothly) is enclosed by the box: no part of its outline, so the box is no clutter.
TEST(ModelRecognizer, HolesEnclosedByAnObjectAreNoOutline) {
  const auto& s = shapes();
  RgbdFrame f = test::render_table_scene({{1, &s.box, TestShapes::on_table(0, 0, 0.3, 0.025)}},
                                         Vec3(0.0, -0.28, 0.32), Vec3(0, 0, 0.03));
  const Eigen::Vector2d c = f.intrinsics.project(f.T_world_cam_gt->inverse() * Vec3(0, 0, 0.05));
  for (int dv = -14; dv <= 14; ++dv)
    for (int du = -30; du <= 30; ++du) {
      const double rho = std::hypot(du / 30.0, dv / 14.0);
      if (rho < 1)
        f.depth.at(static_cast<int>(c.x()) + du, static_cast<int>(c.y()) + dv) +=
            static_cast<float>(0.05 * (1 - rho));
    }
  RecognitionParams strict;  // the dent's rim alone is ~0.15 of the outline: a strict leak test
  strict.max_boundary_leak = 0.1;
  EXPECT_EQ(class_counts(make_recognizer({1, 2, 3}, strict).detect(f)),
            (std::map<int, int>{{1, 1}}));
  RecognitionParams holes_are_outline = strict;
  holes_are_outline.fill_outline_holes = false;
  holes_are_outline.concave_crease_stops_leak = false;  // the dent's rim is a concave crease too
  EXPECT_EQ(class_counts(make_recognizer({1, 2, 3}, holes_are_outline).detect(f))[1], 0);
}

// An unknown object (no model) standing on a known box: the box's outline runs into the unknown
// object's unexplained surface, but across a concave crease, where the surface does not continue
// the box: the box is no part of something larger.
TEST(ModelRecognizer, AConcaveCreaseAtTheOutlineIsNoLeak) {
  const test::SurfaceSamples crate = test::sample_box({0.25f, 0.18f, 0.10f}, 0.002f);
  const test::SurfaceSamples unknown = test::sample_cylinder(0.05f, 0.12f, 0.002f);
  ObjectModel model = test::make_model(test::sample_box({0.25f, 0.18f, 0.10f}, 0.005f));
  model.class_id = 5;
  model.name = "crate";
  const RgbdFrame f =
      test::render_table_scene({{5, &crate, TestShapes::on_table(0, 0, 0.2, 0.05)},
                                {0, &unknown, TestShapes::on_table(0.03, 0.02, 0, 0.10 + 0.06)}},
                               Vec3(0.1, -0.6, 0.5), Vec3(0, 0, 0.1));
  auto crates_with = [&](bool crease_rule) {
    RecognitionParams p;  // the contact is a small part of the box's outline: a strict leak test
    p.max_boundary_leak = 0.1;
    p.concave_crease_stops_leak = crease_rule;
    SceneGeometryParams gp;
    gp.grid_stride_px = 1;  // the 320 x 240 test frame: every pixel, as 640 x 480 at stride 2
    gp.min_region_points = 4 * gp.min_region_points;
    gp.concave_edge_min_angle_deg = 0;  // one region: the outline test alone decides
    return class_counts(ModelRecognizer(SegmentationParams{}, p, gp, {model}).detect(f))[5];
  };
  EXPECT_EQ(crates_with(true), 1);
  EXPECT_EQ(crates_with(false), 0);  // the mechanism off: dropped as a part of something larger
}

// Objects rest on something. The support plane's removal takes the bottom 12 mm of a box with
// it, so a model 1 cm shorter (same footprint) fits the rest exactly -- hovering 1 cm over the
// table -- and, here, better than the box's own model, made 3 mm wider on every side (a scanned
// model is never exact). The resting model wins by the resting bonus; without it the hovering one.
TEST(ModelRecognizer, AnObjectRestingOnTheSupportOutranksOneHoveringOverIt) {
  const test::SurfaceSamples dense = test::sample_box({0.12f, 0.07f, 0.05f}, 0.0015f);
  ObjectModel resting = test::make_model(test::sample_box({0.126f, 0.076f, 0.05f}, 0.004f));
  ObjectModel hovering = test::make_model(test::sample_box({0.12f, 0.07f, 0.04f}, 0.004f));
  resting.class_id = 1, resting.name = "resting";
  hovering.class_id = 2, hovering.name = "hovering";
  const RgbdFrame f =
      test::render_table_scene({{1, &dense, TestShapes::on_table(0, 0, 0.4, 0.025)}});
  auto classes_with = [&](double bonus) {
    RecognitionParams p;
    p.resting_bonus = bonus;
    return class_counts(
        ModelRecognizer(SegmentationParams{}, p, SceneGeometryParams{}, {hovering, resting})
            .detect(f));
  };
  EXPECT_EQ(classes_with(RecognitionParams{}.resting_bonus), (std::map<int, int>{{1, 1}}));
  EXPECT_EQ(classes_with(0), (std::map<int, int>{{2, 1}}));  // the rule off: the hovering model
}

// A model's samples are a fixed number spread over its area, so a large model's lie centimetres
// apart (2620 samples on a 0.40 x 0.30 x 0.24 m box: 1.5 cm). Here a box modelled by samples 2.5 cm
// apart at its exact pose: with the distance to the nearest sample about a third of its own visible
// surface is farther than the 1 cm inlier distance, and its detection mask is full of holes; with
// the distance to the surface the samples stand for (surface_distance) it covers the box.
namespace {

/// Fraction of the pixels of a 0.20 x 0.15 x 0.10 m box on a table that the detections of a model
/// of it sampled 2.5 cm apart (at its exact pose) cover, with the given distance rules.
double sparse_box_coverage(bool surface_distance, double sparse_model_spacing_fraction) {
  const Eigen::Vector3f size(0.20f, 0.15f, 0.10f);
  const test::SurfaceSamples dense = test::sample_box(size, 0.0015f);
  ObjectModel sparse = test::make_model(test::sample_box(size, 0.025f));
  sparse.class_id = 1, sparse.name = "sparse box";
  const RgbdFrame f = test::render_table_scene({{1, &dense, TestShapes::on_table(0, 0, 0.3, 0.05)}},
                                               Vec3(0.05, -0.6, 0.55));
  // The box's pixels: depth above the table plane by more than 1.5 cm.
  const SE3 T_world_cam = *f.T_world_cam_gt;
  RecognitionParams p;
  p.surface_distance = surface_distance;
  p.sparse_model_spacing_fraction = sparse_model_spacing_fraction;
  const auto dets =
      ModelRecognizer(SegmentationParams{}, p, SceneGeometryParams{}, {sparse}).detect(f);
  int box = 0, hit = 0;
  for (int v = 0; v < f.depth.height(); ++v)
    for (int u = 0; u < f.depth.width(); ++u) {
      const float z = f.depth.at(u, v);
      if (!(z > 0 && (T_world_cam * f.intrinsics.backproject(u, v, z)).z() > 0.015)) continue;
      ++box;
      hit += std::any_of(dets.begin(), dets.end(),
                         [&](const Detection& d) { return d.probability.at(u, v) >= 0.5f; });
    }
  return static_cast<double>(hit) / std::max(1, box);
}

}  // namespace

TEST(ModelRecognizer, ALargeSparselySampledModelExplainsItsWholeSurface) {
  EXPECT_GT(sparse_box_coverage(true, 0), 0.9);
  EXPECT_LT(sparse_box_coverage(false, 0), 0.8);  // the rule off: the nearest-sample distance
}

// sparse_model_spacing_fraction: the surface distance is taken for a model whose samples lie at
// least that fraction of the inlier distance apart, whatever surface_distance says (the 2.5 cm box
// above: covered with the default 0.5 x 1 cm; with the rule off, holes); a model sampled more
// densely than the threshold keeps the nearest-sample distance.
TEST(ModelRecognizer, ASparselySampledModelIsMeasuredByItsSurfaceByDefault) {
  EXPECT_GT(sparse_box_coverage(false, RecognitionParams{}.sparse_model_spacing_fraction), 0.9);
  EXPECT_LT(sparse_box_coverage(false, 0), 0.8);
  EXPECT_LT(sparse_box_coverage(false, 3), 0.8);  // 2.5 cm apart is under a 3 cm threshold
}

// A printed box (stripes across its length) and a flat-painted box of the same shape and size
// beside it (image noise on both): geometry explains both by the model; the model's own colour
// correlates with the print (NCC ~1) and not with the flat paint (~0).
TEST(ModelRecognizer, AFlatPaintedObjectOfAPrintedModelsShapeIsRejected) {
  const auto& s = shapes();
  auto stripes = [](float x) {
    return std::sin(2 * static_cast<float>(M_PI) * x / 0.03f) > 0 ? 0.85f : 0.15f;
  };
  ObjectModel box = shapes().models()[0];
  prepare_object_model(box);
  auto colour = std::make_shared<ModelColour>();
  colour->points = box.points, colour->normals = box.normals, colour->source = "test";
  for (const auto& q : box.points)
    colour->grey.push_back(stripes(q.x())), colour->weight.push_back(1);
  box.colour = colour;
  const SE3 printed = TestShapes::on_table(-0.12, 0, 0.3, 0.025);
  RgbdFrame f = test::render_table_scene(
      {{1, &s.box, printed}, {1, &s.box, TestShapes::on_table(0.11, 0.02, -0.2, 0.025)}});
  std::mt19937 rng(5);
  std::normal_distribution<float> noise(0, 4);
  for (int v = 0; v < f.depth.height(); ++v)
    for (int u = 0; u < f.depth.width(); ++u) {
      float grey = 128;
      if (f.depth.at(u, v) > 0) {
        const Vec3 w = *f.T_world_cam_gt * f.intrinsics.backproject(u, v, f.depth.at(u, v));
        const Vec3 o = printed.inverse() * w;
        if (std::abs(o.x()) < 0.062 && std::abs(o.y()) < 0.037 && std::abs(o.z()) < 0.027)
          grey = 255 * stripes(static_cast<float>(o.x()));
      }
      const auto c = static_cast<std::uint8_t>(std::clamp(grey + noise(rng), 0.0f, 255.0f));
      f.color.at(u, v) = Rgb8{c, c, c};
    }
  auto boxes_with = [&](double min_ncc) {
    RecognitionParams p;
    p.min_colour_ncc = min_ncc;
    return class_counts(
        ModelRecognizer(SegmentationParams{}, p, SceneGeometryParams{}, {box}).detect(f))[1];
  };
  EXPECT_EQ(boxes_with(RecognitionParams{}.min_colour_ncc), 1);
  EXPECT_EQ(boxes_with(-1), 2);  // the rule off: the flat box is a box too
}

TEST(ModelRecognizer, ClassRestriction) {
  const auto& s = shapes();
  const RgbdFrame f =
      test::render_table_scene({{1, &s.box, TestShapes::on_table(-0.12, 0, 0.3, 0.025)},
                                {2, &s.can, TestShapes::on_table(0.10, 0.02, 0, 0.055)}});
  const auto only_cans = make_recognizer({2}).detect(f);
  ASSERT_FALSE(only_cans.empty());
  for (const auto& d : only_cans) EXPECT_EQ(d.class_id, 2);
  const auto only_boxes = make_recognizer({1}).detect(f);
  ASSERT_FALSE(only_boxes.empty());
  for (const auto& d : only_boxes) EXPECT_EQ(d.class_id, 1);
  const std::map<int, std::string> names = {{1, "box"}, {2, "can"}, {3, "cube"}};
  EXPECT_EQ(resolve_model_classes("", names, {1, 2, 3}), (std::vector<int>{1, 2, 3}));
  EXPECT_EQ(resolve_model_classes("can, 3", names, {1, 2, 3}), (std::vector<int>{2, 3}));
  try {
    resolve_model_classes("can,mug", names, {1, 2, 3});
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("unknown class 'mug'"), std::string::npos) << e.what();
  }
  EXPECT_THROW(resolve_model_classes("7", names, {1, 2, 3}), ConfigError);
  try {
    resolve_model_classes("", names, {});
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("no object models"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ModelRecognizer(SegmentationParams{}, {}, {}, {}), ConfigError);
}

TEST(ModelRecognizer, KnownObjectsAreRefinedNotSearched) {
  const auto& s = shapes();
  const std::vector<PlacedObject> scene = {{1, &s.box, TestShapes::on_table(-0.12, 0, 0.3, 0.025)},
                                           {2, &s.can, TestShapes::on_table(0.10, 0.02, 0, 0.055)}};
  ModelRecognizer rec = make_recognizer();
  const RgbdFrame f0 = test::render_table_scene(scene);
  SegmentationContext c0;
  c0.T_world_cam = *f0.T_world_cam_gt;
  EXPECT_EQ(rec.detect_in_context(f0, c0).size(), 2u);
  const int search = rec.last_registrations();
  const RgbdFrame f1 = test::render_table_scene(scene, Vec3(0.1, -0.48, 0.45));
  SegmentationContext c1;
  c1.T_world_cam = *f1.T_world_cam_gt;
  EXPECT_EQ(class_counts(rec.detect_in_context(f1, c1)), (std::map<int, int>{{1, 1}, {2, 1}}));
  EXPECT_EQ(rec.last_registrations(), 2);  // one refinement per known object
  EXPECT_GT(search, 4);
  for (const auto& o : rec.last_objects()) EXPECT_TRUE(o.from_track);
}

// A small unknown object far away (a 6 cm cube at 1.35 m: a region of ~60 grid points that the area
// rule keeps): no model explains it, and its search is searched again on the next keyframe, since
// a region under reject_memory_min_points is not remembered; with every region remembered, not.
TEST(ModelRecognizer, SmallSearchedRegionsAreSearchedAgainOnTheNextKeyframe) {
  const test::SurfaceSamples cube = test::sample_box({0.06f, 0.06f, 0.06f}, 0.0015f);
  const RgbdFrame f = test::render_table_scene({{9, &cube, TestShapes::on_table(0, 0, 0.3, 0.03)}},
                                               Vec3(0.0, -1.05, 0.85), Vec3(0.1, 0, 0.05));
  auto searches_on_second_keyframe = [&](int memory_min_points) {
    RecognitionParams p;
    p.reject_memory_min_points = memory_min_points;
    ModelRecognizer rec = make_recognizer({1, 2}, p);
    SegmentationContext c;
    c.T_world_cam = *f.T_world_cam_gt;
    rec.detect_in_context(f, c);
    EXPECT_GT(rec.last_timing().searches, 0);
    EXPECT_TRUE(rec.last_objects().empty());
    rec.detect_in_context(f, c);
    return rec.last_timing().searches;
  };
  EXPECT_GT(searches_on_second_keyframe(RecognitionParams{}.reject_memory_min_points), 0);
  EXPECT_EQ(searches_on_second_keyframe(0), 0);  // every searched region remembered
}

}  // namespace
}  // namespace orpe
