// Reconstruction error: closest points on triangles and model surfaces, surfel-to-model distances
// at the ground-truth pose, instance-to-object assignment, ICP registration, the semantic map
// reader.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <random>
#include <sstream>

#include "orpe/core/error.h"
#include "orpe/io/point_cloud_io.h"
#include "orpe/pipeline/reconstruction_error.h"
#include "orpe/render/primitives.h"
#include "orpe/semantic/semantic_output.h"
#include "orpe/slam/surfel_map.h"
#include "support/test_data.h"

namespace orpe {
namespace {

using V3 = Eigen::Vector3f;

TEST(ReconstructionError, ClosestPointOnTriangleMatchesDenseSampling) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-1, 1);
  for (int trial = 0; trial < 200; ++trial) {
    const V3 a(u(rng), u(rng), u(rng)), b(u(rng), u(rng), u(rng)), c(u(rng), u(rng), u(rng));
    const V3 p(2 * u(rng), 2 * u(rng), 2 * u(rng));
    const V3 q = closest_point_on_triangle(p, a, b, c);
    // q lies on the triangle (barycentrics in [0, 1]) and no sample of the triangle is closer.
    float best = 1e9f;
    const int n = 60;
    for (int i = 0; i <= n; ++i)
      for (int j = 0; i + j <= n; ++j) {
        const V3 s = a + (b - a) * (float(i) / n) + (c - a) * (float(j) / n);
        best = std::min(best, (s - p).norm());
      }
    EXPECT_LE((q - p).norm(), best + 1e-5f);
    EXPECT_GE((q - p).norm(), best - 0.05f * ((b - a).norm() + (c - a).norm()));
  }
}

TEST(MapSurfaceError, ADoubledShiftedSurfaceShowsInTheFarShares) {
  // A 2 x 2 m wall (the plane x = 0) scanned once, then a second copy of it 3 cm off (a loop that
  // was not closed): half the surfels lie beyond 2 cm. Low-confidence surfels are left out.
  const TriangleMesh wall = make_box(V3(0.001f, 2.0f, 2.0f), 1.0f);
  const ModelSurface s = ModelSurface::from_mesh(wall);
  PointCloudData map;
  for (int i = 0; i < 50; ++i)
    for (int j = 0; j < 50; ++j) {
      map.positions_m.emplace_back(0.0005f, -0.9f + 0.036f * i, -0.9f + 0.036f * j);
      map.confidences.push_back(20.0f);
    }
  const MapSurfaceError single = evaluate_map_surface(map, s);
  EXPECT_EQ(single.surfels, 2500);
  EXPECT_LT(single.mean_m, 1e-4);
  EXPECT_EQ(single.far_fraction, 0.0);
  PointCloudData doubled = map;
  for (size_t k = 0; k < map.size(); ++k) {
    doubled.positions_m.push_back(map.positions_m[k] + V3(0.03f, 0.0f, 0.0f));
    doubled.confidences.push_back(20.0f);
  }
  const MapSurfaceError two = evaluate_map_surface(doubled, s);
  EXPECT_NEAR(two.far_fraction, 0.5, 1e-9);
  EXPECT_NEAR(two.far_near_fraction, 0.5, 1e-9);
  EXPECT_NEAR(two.median_m, 0.03, 1e-4);  // nth_element at n / 2: the copy's smallest
  // The copy at confidence 1 is not counted at min_confidence 10.
  for (size_t k = map.size(); k < doubled.size(); ++k) doubled.confidences[k] = 1.0f;
  ReconstructionErrorParams params;
  params.min_confidence = 10.0f;
  const MapSurfaceError stable = evaluate_map_surface(doubled, s, params);
  EXPECT_EQ(stable.surfels, 2500);
  EXPECT_EQ(stable.far_fraction, 0.0);
  params.min_confidence = 50.0f;
  EXPECT_THROW(evaluate_map_surface(doubled, s, params), std::invalid_argument);
  const auto j = nlohmann::json::parse(two.to_json());
  EXPECT_NEAR(j["far_fraction"].get<double>(), 0.5, 1e-9);
}

TEST(ReconstructionError, BoxSurfaceDistancesAreExact) {
  const TriangleMesh box = make_box(V3(0.2f, 0.1f, 0.3f), 0.05f);
  const ModelSurface s = ModelSurface::from_mesh(box);
  EXPECT_TRUE(s.has_triangles());
  EXPECT_NEAR(s.distance_m(V3(0.1f + 0.004f, 0.0f, 0.0f)), 0.004, 1e-6);  // outside a face
  EXPECT_NEAR(s.distance_m(V3(0.0f, 0.0f, 0.15f - 0.01f)), 0.01, 1e-6);   // inside, near the top
  EXPECT_NEAR(s.distance_m(V3(0.13f, 0.09f, 0.0f)), std::hypot(0.03, 0.04), 1e-6);  // off an edge
  EXPECT_NEAR(s.distance_m(V3(0.0f, 0.0f, 0.0f)), 0.05, 1e-6);  // centre: nearest face is y = 0.05
  V3 closest;
  s.distance_m(V3(0.5f, 0.0f, 0.0f), &closest);
  EXPECT_NEAR(closest.x(), 0.1f, 1e-6);
  // The point-set surface approximates (never under-estimates by more than the spacing).
  const ModelSurface pts = ModelSurface::from_points(box.vertices);
  EXPECT_FALSE(pts.has_triangles());
  EXPECT_GE(pts.distance_m(V3(0.104f, 0.0f, 0.0f)), 0.004 - 1e-6);
  EXPECT_THROW(ModelSurface::from_points({}), std::invalid_argument);
}

/// Surfels sampled on a box at `T_world_obj`, pushed `offset` along the face normal.
void add_box_surfels(PointCloudData& map, const TriangleMesh& box, const SE3& T_world_obj,
                     float offset, int instance, int cls, int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<size_t> pick(0, box.triangles.size() - 1);
  std::uniform_real_distribution<float> u(0, 1);
  for (int i = 0; i < n; ++i) {
    const auto& t = box.triangles[pick(rng)];
    float a = u(rng), b = u(rng);
    if (a + b > 1) a = 1 - a, b = 1 - b;
    const V3 p0 = box.vertices[t[0]], p1 = box.vertices[t[1]], p2 = box.vertices[t[2]];
    const V3 nrm = (p1 - p0).cross(p2 - p0).normalized();
    const V3 p = p0 + a * (p1 - p0) + b * (p2 - p0) + offset * nrm;
    map.positions_m.push_back((T_world_obj * p.cast<double>()).cast<float>());
    map.instance_ids.push_back(instance);
    map.class_ids.push_back(cls);
    map.confidences.push_back(20.0f);
  }
}

TEST(ReconstructionError, MeanDistanceAtTheGroundTruthPoseAndAssignment) {
  const TriangleMesh box = make_box(V3(0.2f, 0.1f, 0.3f), 0.05f);
  const ModelSurface surface = ModelSurface::from_mesh(box);
  const SE3 A(so3_exp(Vec3(0.1, 0.2, 0.3)), Vec3(0.5, 0, 1));
  const SE3 B(so3_exp(Vec3(-0.4, 0.1, 0.0)), Vec3(-0.5, 0.2, 1.2));
  PointCloudData map;
  add_box_surfels(map, box, A, 0.003f, /*instance=*/7, /*class=*/2, 3000, 1);
  add_box_surfels(map, box, B, 0.006f, /*instance=*/4, /*class=*/2, 3000, 2);
  add_box_surfels(map, box, A, 0.0f, /*instance=*/9, /*class=*/5, 200, 3);  // class without object
  // Background surfels are ignored.
  map.positions_m.push_back(V3(5, 5, 5));
  map.instance_ids.push_back(0);
  map.class_ids.push_back(0);
  map.confidences.push_back(20);
  const std::vector<GroundTruthObjectPose> objects = {{101, 2, A, {}}, {102, 2, B, {}}};
  const ReconstructionEvaluation ev =
      evaluate_reconstruction(map, objects, {{2, &surface}}, {{2, "box"}});
  ASSERT_EQ(ev.objects.size(), 2u);
  const auto& a = ev.objects[0].object_id == 101 ? ev.objects[0] : ev.objects[1];
  const auto& b = ev.objects[0].object_id == 101 ? ev.objects[1] : ev.objects[0];
  EXPECT_EQ(a.instances, std::vector<int>{7});
  EXPECT_EQ(b.instances, std::vector<int>{4});
  EXPECT_EQ(a.surfels, 3000);
  EXPECT_NEAR(a.mean_m, 0.003, 2e-4);  // a few surfels near edges are closer to another face
  EXPECT_NEAR(b.mean_m, 0.006, 4e-4);
  EXPECT_NEAR(ev.mean_m, (a.mean_m + b.mean_m) / 2, 1e-12);
  EXPECT_EQ(ev.unmatched_instances, std::vector<int>{9});
  EXPECT_LT(a.mean_registered_m, 0) << "not requested";
  EXPECT_NE(ev.markdown().find("| box |"), std::string::npos);
  EXPECT_NE(ev.to_json().find("\"mean_mm\""), std::string::npos);

  // Missing instance / class ids are an error, not a silent zero.
  PointCloudData bare;
  bare.positions_m = map.positions_m;
  EXPECT_THROW(evaluate_reconstruction(bare, objects, {{2, &surface}}, {}), std::invalid_argument);
}

// A map whose objects have no surfels printed "MEAN 0.00" (issue 12): now "-", null in JSON, and
// objects_measured = 0 (`orpe eval recon` then exits with an error).
TEST(ReconstructionError, NoObjectSurfelsMeasureNothing) {
  const TriangleMesh box = make_box(V3(0.2f, 0.1f, 0.3f), 0.05f);
  const ModelSurface surface = ModelSurface::from_mesh(box);
  PointCloudData map;
  map.positions_m.push_back(V3(5, 5, 5));
  map.instance_ids.push_back(0);
  map.class_ids.push_back(0);
  map.confidences.push_back(20);
  const std::vector<GroundTruthObjectPose> objects = {{101, 2, SE3(), {}}};
  const ReconstructionEvaluation ev =
      evaluate_reconstruction(map, objects, {{2, &surface}}, {{2, "box"}});
  EXPECT_EQ(ev.objects_measured, 0);
  EXPECT_EQ(ev.objects_without_surfels, 1);
  const std::string report = ev.report();
  // The first column after the row's name is the mean (mm).
  std::istringstream mean_row(report.substr(report.find("MEAN (objects)") + 14));
  std::string mean_field;
  mean_row >> mean_field;
  EXPECT_EQ(mean_field, "-") << report;
  EXPECT_NE(ev.markdown().find("| **mean** | | | - |"), std::string::npos) << ev.markdown();
  const auto j = nlohmann::json::parse(ev.to_json());
  EXPECT_TRUE(j["mean_mm"].is_null()) << j.dump();
  EXPECT_EQ(j["objects_measured"], 0);
}

TEST(ReconstructionError, FarFractionsAndCompletenessOverTheSeenSurface) {
  const TriangleMesh box = make_box(V3(0.2f, 0.1f, 0.3f), 0.05f);
  const ModelSurface surface = ModelSurface::from_mesh(box);
  ASSERT_GE(surface.samples().size(), 2000u);
  const SE3 A(so3_exp(Vec3(0.1, 0.2, 0.3)), Vec3(0.5, 0, 1));
  // A dense segment of the half x > 0 of the box, plus 100 surfels 3 cm and 100 surfels 1.5 cm out.
  PointCloudData all, map;
  add_box_surfels(all, box, A, 0.0f, 7, 2, 40000, 1);
  for (size_t i = 0; i < all.size(); ++i)
    if ((A.inverse() * all.positions_m[i].cast<double>()).x() > 0) {
      map.positions_m.push_back(all.positions_m[i]);
      map.instance_ids.push_back(7);
      map.class_ids.push_back(2);
      map.confidences.push_back(20);
    }
  const double on_surface = static_cast<double>(map.size());
  add_box_surfels(map, box, A, 0.03f, 7, 2, 100, 2);
  add_box_surfels(map, box, A, 0.015f, 7, 2, 100, 3);
  const double n = static_cast<double>(map.size());
  GroundTruthObjectPose o{101, 2, A, {}};
  for (const auto& p : surface.samples()) o.seen_surface_obj.push_back(p);
  ReconstructionEvaluation ev = evaluate_reconstruction(map, {o}, {{2, &surface}}, {{2, "box"}});
  ASSERT_EQ(ev.objects.size(), 1u);
  EXPECT_NEAR(ev.objects[0].far_fraction, 100 / n, 1e-9);
  EXPECT_NEAR(ev.objects[0].far_near_fraction, 200 / n, 1e-9);
  EXPECT_NEAR(ev.max_far_fraction, 100 / n, 1e-9);
  // Half the surface plus a 1 cm strip past x = 0 (0.008 of 0.22 m^2) is covered.
  EXPECT_NEAR(ev.objects[0].completeness, 0.5 + 0.008 / 0.22, 0.02);
  EXPECT_NEAR(ev.mean_completeness, ev.objects[0].completeness, 1e-12);
  EXPECT_NE(ev.to_json().find("\"far_2cm_fraction\""), std::string::npos);
  // Seen only where the segment is: complete.
  o.seen_surface_obj.clear();
  for (const auto& p : surface.samples())
    if (p.x() > 0.01f) o.seen_surface_obj.push_back(p);
  ev = evaluate_reconstruction(map, {o}, {{2, &surface}}, {});
  EXPECT_GT(ev.objects[0].completeness, 0.999);
  EXPECT_EQ(ev.objects[0].surfels, static_cast<int>(on_surface) + 200);
  // Nothing seen: not computed.
  o.seen_surface_obj.clear();
  ev = evaluate_reconstruction(map, {o}, {{2, &surface}}, {});
  EXPECT_LT(ev.objects[0].completeness, 0);
  EXPECT_LT(ev.mean_completeness, 0);
}

TEST(ReconstructionError, RegistrationRemovesARigidOffset) {
  const TriangleMesh box = make_box(V3(0.2f, 0.1f, 0.3f), 0.05f);
  const ModelSurface surface = ModelSurface::from_mesh(box);
  const SE3 truth(so3_exp(Vec3(0.1, 0.2, 0.3)), Vec3(0.5, 0, 1));
  // The map's object sits 4 mm and 1 degree away from the ground truth (tracking drift).
  const SE3 drift = SE3(so3_exp(Vec3(0, 0, 0.0175)), Vec3(0.004, 0, 0)) * truth;
  PointCloudData map;
  add_box_surfels(map, box, drift, 0.0f, 1, 3, 4000, 5);
  ReconstructionErrorParams params;
  params.register_model = true;
  const ReconstructionEvaluation ev =
      evaluate_reconstruction(map, {{1, 3, truth, {}}}, {{3, &surface}}, {}, params);
  ASSERT_EQ(ev.objects.size(), 1u);
  EXPECT_GT(ev.objects[0].mean_m, 0.0015);
  EXPECT_LT(ev.objects[0].mean_registered_m, 0.0003);
  EXPECT_GT(ev.objects[0].registration_shift_m, 0.002);
}

TEST(ReconstructionError, ReadsTheSemanticStagesMapFile) {
  slam::SurfelMap map;
  for (int i = 0; i < 10; ++i) {
    slam::Surfel s;
    s.position_world = V3(0.01f * i, 0, 1);
    s.confidence = 12;
    s.instance_id = i < 5 ? 3 : 0;
    map.push_back(s);
  }
  std::map<int, InstanceInfo> instances;
  instances[3].id = 3;
  instances[3].detections = 2;
  instances[3].class_probability_sum[6] = 1.8;
  const std::string dir = test::scratch_dir("semantic_map");
  write_semantic_map_ply(dir + "/semantic_map.ply", map, instances, false);
  const PointCloudData cloud = read_semantic_map_ply(dir + "/semantic_map.ply");
  ASSERT_EQ(cloud.size(), 10u);
  ASSERT_EQ(cloud.instance_ids.size(), 10u);
  ASSERT_EQ(cloud.class_ids.size(), 10u);
  EXPECT_EQ(cloud.instance_ids[0], 3);
  EXPECT_EQ(cloud.class_ids[0], 6);
  EXPECT_EQ(cloud.instance_ids[9], 0);
  // A plain point cloud has no ids: a clear error naming the file.
  PointCloudData plain;
  plain.positions_m = {V3(0, 0, 1)};
  write_point_cloud_ply(dir + "/plain.ply", plain);
  try {
    read_semantic_map_ply(dir + "/plain.ply");
    FAIL();
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("plain.ply"), std::string::npos);
  }
}

}  // namespace
}  // namespace orpe
