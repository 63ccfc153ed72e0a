// Object models: file reading (errors name the file), diameter, normals and symmetry detection on
// synthetic shapes, and the YCB-Video models when the shared data is present.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "orpe/core/error.h"
#include "orpe/pose/model_search.h"
#include "orpe/pose/object_model.h"
#include "pose/synthetic_scene.h"
#include "support/test_data.h"

namespace orpe {
namespace {

void write_text(const std::string& path, const std::string& text) {
  std::ofstream os(path);
  os << text;
}

/// A 3 x 8 cm cylinder's surface sampled every `spacing_m`, every `every`-th sample repeated at the
/// end (ties for the nearest-point searches).
test::SurfaceSamples cylinder_with_ties(float spacing_m, size_t every) {
  test::SurfaceSamples s = test::sample_cylinder(0.03f, 0.08f, spacing_m);
  const size_t n = s.points.size();
  for (size_t i = 0; i < n; i += every) s.points.push_back(s.points[i]);
  return s;
}

TEST(ObjectModel, LoadErrorsNameTheFile) {
  const std::string dir = test::scratch_dir("xyz");
  try {
    load_object_model(dir + "/missing.xyz");
    FAIL() << "no throw";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("missing.xyz"), std::string::npos);
  }
  write_text(dir + "/three.xyz", "0 0 0\n0.1 0 0\n0 0.2 0\n");
  try {
    load_object_model(dir + "/three.xyz");
    FAIL() << "no throw";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("fewer than 4"), std::string::npos) << e.what();
  }
  write_text(dir + "/ok.xyz", "0 0 0\n100 0 0\n0 200 0\n0 0 300\n");
  ModelLoadOptions mm;
  mm.units_per_m = 1000;
  mm.mesh_path = dir + "/missing.obj";
  EXPECT_THROW(load_object_model(dir + "/ok.xyz", mm), IoError);
  mm.mesh_path.clear();
  const ObjectModel m = load_object_model(dir + "/ok.xyz", mm);
  EXPECT_NEAR(m.points[3].z(), 0.3f, 1e-6f);
}

TEST(ObjectModel, ObjMeshNormalsAndLoadWithMesh) {
  // A unit cube (8 vertices, 12 triangles, counter-clockwise from outside): normals point outward.
  const std::string dir = test::scratch_dir("obj");
  write_text(dir + "/cube.obj",
             "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
             "f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\n"
             "f 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n");
  const MeshVerticesNormals mesh = read_obj_vertices_normals(dir + "/cube.obj");
  ASSERT_EQ(mesh.vertices.size(), 8u);
  const Eigen::Vector3f centre(0.5f, 0.5f, 0.5f);
  for (size_t i = 0; i < 8; ++i)
    EXPECT_GT(mesh.normals[i].dot(mesh.vertices[i] - centre), 0.5f) << i;
  write_text(dir + "/pts.xyz", "0.01 0.01 0.0\n0.99 0.5 0.99\n0.5 0.99 0.02\n0.0 0.5 0.5\n1 1 1\n");
  ModelLoadOptions opt;
  opt.mesh_path = dir + "/cube.obj";
  const ObjectModel m = load_object_model(dir + "/pts.xyz", opt, 3, "cube");
  ASSERT_TRUE(m.has_normals());
  EXPECT_TRUE(m.prepared());
  EXPECT_EQ(m.class_id, 3);
  for (size_t i = 0; i < m.points.size(); ++i)
    EXPECT_GT(m.normals[i].dot(m.points[i] - centre), 0.0f);
  write_text(dir + "/bad.obj", "v 0 0 0\nf 1 2 3\n");
  EXPECT_THROW(read_obj_vertices_normals(dir + "/bad.obj"), IoError);
}

TEST(ObjectModel, DiameterSpacingAndPcaNormals) {
  const test::SurfaceSamples box = test::sample_box({0.1f, 0.06f, 0.04f}, 0.005f);
  ObjectModel m;
  m.points = box.points;  // no normals: PCA, oriented away from the centroid
  prepare_object_model(m);
  EXPECT_NEAR(m.diameter_m, std::sqrt(0.01 + 0.0036 + 0.0016), 1e-6);
  EXPECT_GT(m.mean_spacing_m, 0.003);
  EXPECT_LT(m.mean_spacing_m, 0.0055);
  ASSERT_TRUE(m.has_normals());
  // Away from edges the PCA normal equals the face normal.
  int checked = 0;
  for (size_t i = 0; i < m.points.size(); ++i) {
    const Eigen::Vector3f p = m.points[i].cwiseAbs();
    if (p.x() < 0.03f && p.y() < 0.015f && p.z() > 0.019f) {
      EXPECT_GT(m.normals[i].dot(box.normals[i]), 0.99f);
      ++checked;
    }
  }
  EXPECT_GT(checked, 10);
  ObjectModel tiny;
  tiny.points = {Eigen::Vector3f::Zero()};
  EXPECT_THROW(prepare_object_model(tiny), std::invalid_argument);
}

TEST(ObjectModel, SearchIndexMatchesBruteForce) {
  const test::SurfaceSamples s = test::sample_cylinder(0.03f, 0.08f, 0.006f);
  const ModelSearchIndex index(s.points);
  std::mt19937 rng(2);
  std::uniform_real_distribution<float> u(-0.06f, 0.06f);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3f q(u(rng), u(rng), u(rng));
    float best = 1e9f;
    for (const auto& p : s.points) best = std::min(best, (p - q).squaredNorm());
    float d2 = 0;
    index.nearest(q, &d2);
    EXPECT_FLOAT_EQ(d2, best);
  }
}

// nearest_within (the registration's bounded and warm-started searches, issue #15): the very point
// nearest() returns when it is nearer than the bound, none otherwise -- also with duplicate points
// (ties) and with a bound just above the nearest distance.
TEST(ObjectModel, BoundedSearchReturnsTheExactNearestOrNone) {
  const test::SurfaceSamples s = cylinder_with_ties(0.006f, 7);
  const ModelSearchIndex index(s.points);
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> u(-0.07f, 0.07f);
  int found = 0, none = 0;
  for (int i = 0; i < 500; ++i) {
    const Eigen::Vector3f q(u(rng), u(rng), u(rng));
    float best = 0, d2 = -1;
    const std::uint32_t exact = index.nearest(q, &best);
    const float bound = (i % 2 == 0) ? 1e-4f : best * (1.0f + 1e-5f) + 1e-12f;
    const std::uint32_t j = index.nearest_within(q, bound, &d2);
    if (best < bound) {
      ASSERT_EQ(j, exact) << "query " << i;
      EXPECT_EQ(d2, best);
      ++found;
    } else {
      EXPECT_EQ(j, ModelSearchIndex::kNone)
          << "query " << i << ": nothing is nearer than the bound";
      ++none;
    }
  }
  EXPECT_GT(found, 250);
  EXPECT_GT(none, 50);
}

// nearest_near (the registration's warm-started search, issue #15): the exact nearest point within
// the bound whatever the hint -- the point found for a nearby query, a far point, or none -- since
// a hint only shortens the search; with duplicate points (ties) the distance is the nearest's.
TEST(ObjectModel, HintedSearchEqualsTheBoundedSearch) {
  const test::SurfaceSamples s = cylinder_with_ties(0.004f, 11);
  const size_t n = s.points.size();
  const ModelSearchIndex index(s.points);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-0.07f, 0.07f), step(-0.004f, 0.004f);
  std::uniform_int_distribution<std::uint32_t> any(0, static_cast<std::uint32_t>(n - 1));
  int found = 0, none = 0;
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector3f q(u(rng), u(rng), u(rng));
    float best = 0;
    index.nearest(q, &best);
    const Eigen::Vector3f before = q + Eigen::Vector3f(step(rng), step(rng), step(rng));
    std::uint32_t hint = ModelSearchIndex::kNone;
    if (i % 4 == 0) hint = index.nearest(before, nullptr);  // the previous iteration's answer
    if (i % 4 == 1) hint = any(rng);                        // a far hint
    if (i % 4 == 2) hint = index.nearest(q, nullptr);       // the answer itself
    const float bound = (i % 3 == 0) ? 1e-4f : 1.0f;
    float d2 = -1;
    const std::uint32_t j = index.nearest_near(q, hint, bound, &d2);
    if (best < bound) {
      ASSERT_NE(j, ModelSearchIndex::kNone) << "query " << i << " hint " << hint;
      EXPECT_FLOAT_EQ(d2, best) << "query " << i;
      EXPECT_FLOAT_EQ(d2, (s.points[j] - q).squaredNorm());
      ++found;
    } else {
      EXPECT_EQ(j, ModelSearchIndex::kNone) << "query " << i;
      ++none;
    }
  }
  EXPECT_GT(found, 1000);
  EXPECT_GT(none, 100);
  // Queries on the surface with the hint of a nearby point: the common case of a converging ICP.
  for (size_t i = 0; i < n; i += 3) {
    const Eigen::Vector3f q = s.points[i] + Eigen::Vector3f(step(rng), step(rng), step(rng)) * 0.5f;
    float best = 0, d2 = -1;
    index.nearest(q, &best);
    const std::uint32_t j = index.nearest_near(q, static_cast<std::uint32_t>(i), 1e-4f, &d2);
    ASSERT_NE(j, ModelSearchIndex::kNone);
    EXPECT_FLOAT_EQ(d2, best) << "surface query " << i;
  }
}

TEST(ObjectModel, GridNearestIsWithinOneCellOfTheExactNearest) {
  const test::SurfaceSamples s = test::sample_cylinder(0.03f, 0.08f, 0.006f);
  const ModelSearchIndex index(s.points);
  const float cell = 0.004f, margin = 0.02f;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-0.08f, 0.08f);
  int inside = 0, exact = 0;
  for (int i = 0; i < 500; ++i) {
    const Eigen::Vector3f q(u(rng), u(rng), u(rng));
    float best = 0, d2 = 0;
    index.nearest(q, &best);
    const std::uint32_t j = index.nearest_approx(q, &d2, cell, margin);
    EXPECT_FLOAT_EQ(d2, (s.points[j] - q).squaredNorm());  // the query's own distance
    EXPECT_GE(d2, best - 1e-9f);
    // The returned point is the nearest of the cell's centre, at most half a diagonal away.
    EXPECT_LE(std::sqrt(d2), std::sqrt(best) + std::sqrt(3.0f) * cell + 1e-6f);
    const bool in_box = std::abs(q.x()) < 0.03f + margin && std::abs(q.y()) < 0.03f + margin &&
                        q.z() > -0.04f - margin && q.z() < 0.04f + margin;
    inside += in_box;
    exact += d2 == best;
  }
  EXPECT_GT(inside, 100);
  EXPECT_GT(exact, 250);  // most cells have the query's own nearest point
}

TEST(ObjectModel, DetectsCylinderBoxAndNoSymmetry) {
  const ObjectModel cyl = test::make_model(test::sample_cylinder(0.035f, 0.10f, 0.004f), true);
  EXPECT_EQ(cyl.symmetry.kind(), SymmetryKind::kContinuous) << cyl.symmetry.describe();
  EXPECT_GT(std::abs(cyl.symmetry.axis_obj.z()), 0.999);
  EXPECT_EQ(cyl.symmetry.discrete.size(), 1u) << "end-over-end flip";

  const ObjectModel box = test::make_model(test::sample_box({0.1f, 0.07f, 0.04f}, 0.004f), true);
  EXPECT_EQ(box.symmetry.kind(), SymmetryKind::kDiscrete) << box.symmetry.describe();
  EXPECT_EQ(box.symmetry.discrete.size(), 3u) << box.symmetry.describe();
  for (const auto& S : box.symmetry.discrete) EXPECT_NEAR(S.rotation_angle_deg(), 180.0, 0.5);

  const ObjectModel ell = test::make_model(test::sample_l_shape(0.004f), true);
  EXPECT_EQ(ell.symmetry.kind(), SymmetryKind::kNone) << ell.symmetry.describe();
}

TEST(ObjectModel, YcbModelsLoadWithMeshNormals) {
  ORPE_REQUIRE_DATA(data, "ycbv/models/006_mustard_bottle/points.xyz");
  const std::string dir = data + "/ycbv/models/";
  ModelLoadOptions opt;
  opt.mesh_path = dir + "005_tomato_soup_can/textured_simple.obj";
  const ObjectModel can = load_object_model(dir + "005_tomato_soup_can/points.xyz", opt, 4);
  EXPECT_GT(can.points.size(), 2600u);
  EXPECT_GT(can.diameter_m, 0.08);
  EXPECT_LT(can.diameter_m, 0.13);
  EXPECT_EQ(can.symmetry.kind(), SymmetryKind::kContinuous) << can.symmetry.describe();
  opt.mesh_path = dir + "006_mustard_bottle/textured_simple.obj";
  const ObjectModel bottle = load_object_model(dir + "006_mustard_bottle/points.xyz", opt, 5);
  EXPECT_NE(bottle.symmetry.kind(), SymmetryKind::kContinuous) << bottle.symmetry.describe();
  // Outward normals: most point away from the centroid on this convex-ish bottle.
  Eigen::Vector3f c = Eigen::Vector3f::Zero();
  for (const auto& p : bottle.points) c += p;
  c /= static_cast<float>(bottle.points.size());
  int outward = 0;
  for (size_t i = 0; i < bottle.points.size(); ++i)
    outward += bottle.normals[i].dot(bottle.points[i] - c) > 0;
  EXPECT_GT(outward, static_cast<int>(0.9 * bottle.points.size()));
}

}  // namespace
}  // namespace orpe
