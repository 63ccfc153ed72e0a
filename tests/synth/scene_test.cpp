// Scene composition: objects rest on their supports, never interpenetrate, and the object set and
// output are deterministic.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <set>
#include <sstream>

#include "orpe/core/error.h"
#include "orpe/synth/generator.h"
#include "orpe/synth/objects.h"
#include "orpe/synth/scene.h"
#include "orpe/synth/trajectory.h"
#include "support/test_data.h"
#include "synth_test_util.h"

namespace orpe::test {
namespace {

namespace fs = std::filesystem;
using synth::SyntheticSceneGenerator;

TEST(SynthObjects, BuiltinWarehouseSetIsValid) {
  const auto& names = synth::builtin_class_names();
  ASSERT_EQ(names.size(), 11u);
  for (const auto& n : names) {
    const synth::ObjectModel m = synth::make_builtin_object(n);
    std::string why;
    ASSERT_TRUE(m.mesh->IsValid(&why)) << n << ": " << why;
    EXPECT_TRUE(m.mesh->has_texture()) << n << " should carry a printed/wood texture";
    EXPECT_FALSE(m.resting_poses.empty()) << n;
    EXPECT_TRUE(m.symmetries.any()) << n;
    // Frame at the bounding-box centre.
    const auto b = m.mesh->bounds();
    EXPECT_LT(b.center().norm(), 1e-4) << n;
    // The texture is not a uniform colour (bands, text, logos): many distinct values.
    std::map<int, int> colours;
    for (const Rgb8& c : *m.mesh->texture) ++colours[(c.r / 16) * 256 + (c.g / 16) * 16 + c.b / 16];
    EXPECT_GT(colours.size(), 8u) << n;
    // Upright resting pose: lifted by half the height.
    for (const auto& r : m.resting_poses)
      if ((r.R_support_obj * Vec3::UnitZ()).z() > 0.99) {
        EXPECT_NEAR(r.z_offset_m, -b.min().z(), 1e-5) << n;
      }
  }
  EXPECT_THROW(synth::make_builtin_object("nope"), std::invalid_argument);
  // Variants differ from the canonical look.
  const auto a = synth::make_builtin_object("003_jacky_box", 0),
             b = synth::make_builtin_object("003_jacky_box", 1);
  EXPECT_NE(a.name, b.name);
  EXPECT_FALSE(a.mesh->bounds().max().isApprox(b.mesh->bounds().max(), 1e-6));
}

TEST(SynthObjects, ConvexHullAndOverlap) {
  const auto h = synth::convex_hull_2d({{0, 0}, {1, 0}, {1, 1}, {0, 1}, {0.5, 0.5}, {0.2, 0.9}});
  EXPECT_EQ(h.size(), 4u);
  const std::vector<Eigen::Vector2d> a{{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  std::vector<Eigen::Vector2d> b = a;
  for (auto& q : b) q.x() += 1.004;
  EXPECT_FALSE(synth::polygons_overlap(a, b, 0.002));
  EXPECT_TRUE(synth::polygons_overlap(a, b, 0.005));  // closer than the gap
  for (auto& q : b) q.x() -= 0.5;
  EXPECT_TRUE(synth::polygons_overlap(a, b, 0.0));
}

TEST(SynthObjects, UserMeshStableRestingPoses) {
  ORPE_REQUIRE_DATA(data, "ycbv/models/003_cracker_box/textured_simple.obj");
  const auto m =
      synth::load_object_model(data + "/ycbv/models/003_cracker_box/textured_simple.obj");
  EXPECT_EQ(m.name, "003_cracker_box");
  EXPECT_GE(m.resting_poses.size(), 4u);  // a box is stable on (at least) its four larger faces
  const auto banana =
      synth::load_object_model(data + "/ycbv/models/011_banana/textured_simple.obj");
  EXPECT_FALSE(banana.resting_poses.empty());
}

TEST(SynthObjects, BadModelFileIsAnIoErrorNamingTheFile) {
  const std::string dir = scratch_dir("badmodel");
  const std::string path = dir + "/broken.obj";
  std::ofstream(path) << "v 0 0 0\nv 1 0 0\nf 1 2 7\n";
  SynthParams p = small_synth(1, 1, false);
  p.models = path;
  try {
    SyntheticSceneGenerator g(p);
    FAIL() << "expected IoError";
  } catch (const IoError& e) {
    EXPECT_EQ(e.path(), path);
  }
  p.models = dir + "/missing.ply";
  EXPECT_THROW(SyntheticSceneGenerator{p}, IoError);
}

/// Surface points of object a (pulled 1 mm inwards) that lie inside object b's closed mesh.
int penetrating_points(const synth::SynthScene& s, size_t a, size_t b) {
  const auto& oa = s.objects[a];
  const auto& ob = s.objects[b];
  const auto& mesh_a = *s.types[oa.type].mesh;
  const auto& mesh_b = *s.types[ob.type].mesh;
  Eigen::AlignedBox3d bb;
  for (const auto& v : mesh_b.vertices) bb.extend(ob.T_world_obj * v.cast<double>());
  bb.extend(bb.min() - Vec3::Constant(1e-3)).extend(bb.max() + Vec3::Constant(1e-3));
  // Pulled towards the centre: a stacked object touches the one below exactly, and a point on (or
  // rounding-level inside) a surface must not count as penetration.
  const Vec3 centre = oa.T_world_obj * mesh_a.bounds().center().cast<double>();
  int inside = 0;
  for (const auto& p : sample_surface_points(mesh_a, 400, 7 + a)) {
    Vec3 w = oa.T_world_obj * p;
    w += 0.001 * (centre - w).normalized();
    if (bb.contains(w))
      inside += winding_number(mesh_b, ob.T_world_obj, w) > 0.75;  // ~1 inside, 0.5 on the surface
  }
  return inside;
}

void check_scene(const synth::SynthScene& s, const std::string& what) {
  for (size_t i = 0; i < s.objects.size(); ++i) {
    const auto& o = s.objects[i];
    Eigen::AlignedBox3d box;
    for (const auto& v : s.types[o.type].mesh->vertices)
      box.extend(o.T_world_obj * v.cast<double>());
    // Resting: the lowest point is on the support surface, and the object fits under the next
    // shelf.
    const auto& sup = s.supports[o.support];
    EXPECT_NEAR(box.min().z(), sup.height_m, 1e-5) << what << " object " << i;
    EXPECT_LE(box.max().z(), sup.height_m + sup.clearance_m + 1e-6) << what << " object " << i;
  }
  for (size_t a = 0; a < s.objects.size(); ++a)
    for (size_t b = 0; b < s.objects.size(); ++b)
      if (a != b) {
        EXPECT_EQ(penetrating_points(s, a, b), 0)
            << what << ": object " << a << " penetrates object " << b;
      }
}

TEST(SynthScene, ObjectsRestWithoutInterpenetration) {
  int stacked = 0, total = 0;
  for (const std::string scene : {"floor", "table", "shelf"})
    for (int seed : {1, 2, 3}) {
      SynthParams p = small_synth(seed, 2, false);
      p.scene = scene;
      p.objects = 12;
      p.stack_probability = 0.5;
      p.repeat_types = seed == 3;
      const SyntheticSceneGenerator g(p);
      const auto& s = g.scene();
      EXPECT_GE(s.objects.size(), 8u) << scene << " seed " << seed << ": too many objects dropped";
      check_scene(s, scene + " seed " + std::to_string(seed));
      for (const auto& o : s.objects) stacked += s.supports[o.support].owner >= 0, ++total;
    }
  EXPECT_GT(stacked, 0) << "no object was ever stacked on another";
  EXPECT_LT(stacked, total);
}

// The room and its loop (issue 19): objects rest on the racks without interpenetration; the camera
// stays inside the room, and after 360 of its 390 degrees it is back where it started.
TEST(SynthScene, RoomLoopReturnsToItsStartInsideTheRoom) {
  SynthParams p = small_synth(1, 391, false);
  p.scene = "room";
  p.trajectory = "loop";
  p.objects = 16;
  p.loop_overlap_deg = 30;
  const SyntheticSceneGenerator g(p);
  EXPECT_GE(g.scene().objects.size(), 12u);
  check_scene(g.scene(), "room");
  const auto& T = g.trajectory();
  ASSERT_EQ(T.size(), 391u);
  for (const SE3& c : T) {
    EXPECT_LT(c.translation().head<2>().norm(), 1.1) << "camera outside its circle";
    EXPECT_GT(c.translation().head<2>().norm(), 0.7);
  }
  // Where the azimuth is back at its start (the speed varies, so look for the nearest camera among
  // the last 60 frames): within the hand shake (a few mm) and a few degrees of roll.
  double best = 1e9;
  for (size_t k = 300; k < T.size(); ++k)
    best = std::min(best, (T[k].translation() - T[0].translation()).norm());
  EXPECT_LT(best, 0.02);
  // ... while halfway round it is far away.
  EXPECT_GT((T[195].translation() - T[0].translation()).norm(), 1.2);
  SynthParams arc = p;
  arc.trajectory = "arc";
  std::string why;
  EXPECT_FALSE(arc.IsValid(&why)) << "the room needs the loop";
}

TEST(SynthScene, PenetrationCheckDetectsOverlap) {
  // The check above must be able to fail: move one object into another.
  const SyntheticSceneGenerator g(small_synth(1, 1, false));
  synth::SynthScene s = g.scene();
  ASSERT_GE(s.objects.size(), 2u);
  EXPECT_EQ(penetrating_points(s, 1, 0) + penetrating_points(s, 0, 1), 0);
  const Vec3 c0 =
      s.objects[0].T_world_obj * s.types[s.objects[0].type].mesh->bounds().center().cast<double>();
  const Vec3 c1 =
      s.objects[1].T_world_obj * s.types[s.objects[1].type].mesh->bounds().center().cast<double>();
  s.objects[1].T_world_obj.translation() += c0 - c1 + Vec3(0.01, 0, 0);
  EXPECT_GT(penetrating_points(s, 1, 0) + penetrating_points(s, 0, 1), 10);
}

TEST(SynthScene, TypesPerInstanceByDefaultRepeatedOnRequest) {
  SynthParams p = small_synth(4, 1, false);
  p.objects = 14;  // more than the 11 classes: variants keep types distinct
  const SyntheticSceneGenerator g(p);
  EXPECT_EQ(g.scene().types.size(), g.scene().objects.size());
  std::set<std::string> names;
  for (const auto& t : g.scene().types) names.insert(t.name);
  EXPECT_EQ(names.size(), g.scene().types.size());
  p.repeat_types = true;
  const SyntheticSceneGenerator r(p);
  EXPECT_LT(r.scene().types.size(), r.scene().objects.size());
}

TEST(SynthTrajectory, HandHeldPathLooksAtTheSceneFromWideBaselines) {
  SynthParams p = small_synth(2, 300, false);
  const SyntheticSceneGenerator g(p);
  const auto& T = g.trajectory();
  ASSERT_EQ(T.size(), 300u);
  const Vec3 c = g.scene().centre_world;
  double max_step = 0, min_dot = 1;
  for (size_t i = 0; i < T.size(); ++i) {
    const Vec3 to_centre = (c - T[i].translation()).normalized();
    min_dot = std::min(min_dot, to_centre.dot(T[i].rotation().col(2)));  // optical axis
    EXPECT_LT(std::abs(T[i].rotation().col(0).z()), 0.1);  // x nearly horizontal (small roll)
    if (i > 0) max_step = std::max(max_step, (T[i].translation() - T[i - 1].translation()).norm());
  }
  EXPECT_GT(min_dot, std::cos(8.0 * M_PI / 180));  // always looking at the scene
  EXPECT_LT(max_step, 0.05);                       // smooth at 30 Hz
  EXPECT_GT(synth::trajectory_extent_m(T), 1.0);   // wide baseline
  // Baseline option: first-to-last distance.
  p.baseline_m = 0.8;
  p.shake_m = 0;
  const SyntheticSceneGenerator b(p);
  EXPECT_NEAR((b.trajectory().front().translation() - b.trajectory().back().translation()).norm(),
              0.8, 0.25);
}

TEST(SynthDeterminism, SameSeedGivesByteIdenticalOutput) {
  const std::string a = scratch_dir("a"), b = scratch_dir("b"), c = scratch_dir("c");
  SynthParams p = small_synth(11, 3, true);
  p.preview_stride = 2;
  p.threads = 2;
  SyntheticSceneGenerator(p).write_bop(a);
  p.threads = 1;  // also independent of the thread count
  SyntheticSceneGenerator(p).write_bop(b);
  p.seed = 12;
  SyntheticSceneGenerator(p).write_bop(c);
  const auto fa = read_tree(a), fb = read_tree(b), fc = read_tree(c);
  ASSERT_GT(fa.size(), 40u);
  ASSERT_EQ(fa.size(), fb.size());
  for (const auto& [name, bytes] : fa) {
    ASSERT_TRUE(fb.count(name)) << name;
    EXPECT_TRUE(bytes == fb.at(name)) << name << " differs between two runs with the same seed";
  }
  EXPECT_NE(fa.at("test/000000/rgb/000000.png"), fc.at("test/000000/rgb/000000.png"));
  EXPECT_NE(fa.at("test/000000/scene_gt.json"), fc.at("test/000000/scene_gt.json"));
  // No temporary files left behind (atomic writes).
  for (const auto& [name, bytes] : fa) EXPECT_EQ(name.find(".tmp"), std::string::npos) << name;
}

}  // namespace
}  // namespace orpe::test
