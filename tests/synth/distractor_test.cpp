// Distractors (`synth.distractors`): objects outside the model set, rendered like the objects but
// never targets: not in scene_gt.json, models/, the masks or the instance image, not detected by
// the gt back-end; the objects and the camera path do not move when they are added.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "orpe/io/dataset.h"
#include "orpe/semantic/segmenter.h"
#include "orpe/synth/bop_writer.h"
#include "orpe/synth/generator.h"
#include "support/test_data.h"
#include "synth_test_util.h"

namespace orpe::test {
namespace {

namespace fs = std::filesystem;
using synth::SyntheticSceneGenerator;

SynthParams with_distractors(int seed, int frames, int distractors) {
  SynthParams p = small_synth(seed, frames, false);
  p.scene = "table";
  p.objects = 6;
  p.distractors = distractors;
  return p;
}

/// Surface points of `a` (pulled 1 mm inwards) inside the closed mesh `b`.
int points_inside(const TriangleMesh& a, const SE3& Ta, const TriangleMesh& b, const SE3& Tb) {
  const Vec3 centre = Ta * a.bounds().center().cast<double>();
  Eigen::AlignedBox3d box_b;
  for (const auto& v : b.vertices) box_b.extend(Tb * v.cast<double>());
  int inside = 0;
  for (const auto& p : sample_surface_points(a, 300, 3)) {
    Vec3 w = Ta * p;
    w += 0.001 * (centre - w).normalized();
    if (box_b.contains(w)) inside += winding_number(b, Tb, w) > 0.75;
  }
  return inside;
}

TEST(SynthDistractors, AddedWithoutMovingObjectsOrCameraAndUnlikeTheObjects) {
  const SyntheticSceneGenerator g0(with_distractors(5, 30, 0)), g(with_distractors(5, 30, 4));
  const auto& s0 = g0.scene();
  const auto& s = g.scene();
  EXPECT_TRUE(s0.distractors.empty());
  ASSERT_EQ(s.distractors.size(), 4u);
  ASSERT_EQ(s.distractor_types.size(), 4u);
  ASSERT_EQ(s.objects.size(), s0.objects.size());
  for (size_t k = 0; k < s.objects.size(); ++k)
    EXPECT_LT((s.objects[k].T_world_obj.inverse() * s0.objects[k].T_world_obj).log().norm(), 1e-12);
  for (int i = 0; i < g.num_frames(); ++i)
    EXPECT_LT((g.trajectory()[i].inverse() * g0.trajectory()[i]).log().norm(), 1e-12);
  for (size_t j = 0; j < s.distractors.size(); ++j) {
    const auto& d = s.distractors[j];
    const TriangleMesh& dm = *s.distractor_types[d.type].mesh;
    EXPECT_FALSE(dm.has_texture());
    for (const auto& t : s.types)
      EXPECT_FALSE(synth::similar_size(dm, *t.mesh, synth::kDistractorSizeRatio))
          << s.distractor_types[d.type].name << " is as large as " << t.name;
    // Resting on its support, and clear of every object.
    Eigen::AlignedBox3d box;
    for (const auto& v : dm.vertices) box.extend(d.T_world_obj * v.cast<double>());
    EXPECT_NEAR(box.min().z(), s.supports[d.support].height_m, 1e-5);
    for (const auto& o : s.objects) {
      const TriangleMesh& om = *s.types[o.type].mesh;
      EXPECT_EQ(points_inside(dm, d.T_world_obj, om, o.T_world_obj) +
                    points_inside(om, o.T_world_obj, dm, d.T_world_obj),
                0)
          << s.distractor_types[d.type].name << " penetrates " << s.types[o.type].name;
    }
  }
}

TEST(SynthDistractors, RenderedInDepthAndColourButNotAsInstances) {
  const SyntheticSceneGenerator g0(with_distractors(5, 30, 0)), g(with_distractors(5, 30, 4));
  const PinholeIntrinsics& K = g.intrinsics();
  int seen = 0;
  for (int i : {0, 15, 29}) {
    const synth::SynthFrame f0 = g0.render_frame(i), f = g.render_frame(i);
    ASSERT_EQ(f.distractor_labels.size(), f.instances.size());
    ASSERT_EQ(f.distractor_info.size(), g.scene().distractors.size());
    std::vector<int> count(g.scene().distractors.size(), 0);
    int colour_differs = 0, here = 0;
    for (int v = 0; v < K.height; ++v)
      for (int u = 0; u < K.width; ++u) {
        const int j = f.distractor_labels.at(u, v) - 1;
        if (j < 0) {
          // Where no distractor is the visible surface, the frame is the one without distractors.
          ASSERT_EQ(f.instances.at(u, v), f0.instances.at(u, v)) << u << "," << v;
          ASSERT_EQ(f.depth_clean.at(u, v), f0.depth_clean.at(u, v)) << u << "," << v;
          continue;
        }
        ++count[j], ++here;
        EXPECT_EQ(f.instances.at(u, v), 0) << "a distractor pixel has a target label";
        const float z0 = f0.depth_clean.at(u, v), z = f.depth_clean.at(u, v);
        EXPECT_TRUE(z > 0 && (z0 == 0 || z <= z0)) << u << "," << v;  // in front of what was there
        colour_differs += !(f.rgb.at(u, v) == f0.rgb.at(u, v));
        if ((u + v) % 7 == 0) {  // its depth is the distractor's surface (independent ray cast)
          const auto& d = g.scene().distractors[j];
          const Vec3 ray((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);
          const double t = ray_cast(*g.scene().distractor_types[d.type].mesh, f.T_cam_distractor[j],
                                    ray, nullptr, 1e-4);
          EXPECT_NEAR(z, t, 2e-3) << "distractor " << j << " at " << u << "," << v;
        }
      }
    for (size_t j = 0; j < count.size(); ++j)
      EXPECT_EQ(f.distractor_info[j].px_count_visib, count[j]);
    EXPECT_GT(colour_differs, 0.9 * here);
    seen += here;
  }
  EXPECT_GT(seen, 200) << "the distractors are hardly ever in view";
}

TEST(SynthDistractors, AbsentFromTheBopTargetsAndFromGtSegmentation) {
  const std::string dir = scratch_dir("bop"), plain = scratch_dir("plain");
  const SyntheticSceneGenerator g(with_distractors(5, 2, 4));
  g.write_bop(dir);
  SyntheticSceneGenerator(with_distractors(5, 2, 0)).write_bop(plain);
  const size_t n = g.scene().objects.size(), nd = g.scene().distractors.size();
  ASSERT_EQ(nd, 4u);

  // The targets' poses are those of the scene without distractors; the distractors have their own
  // files.
  EXPECT_EQ(read_bytes(synth::bop_scene_dir(dir) + "/scene_gt.json"),
            read_bytes(synth::bop_scene_dir(plain) + "/scene_gt.json"));
  EXPECT_EQ(read_json(dir + "/models/models_info.json").size(), g.scene().types.size());
  EXPECT_FALSE(fs::exists(synth::bop_scene_dir(plain) + "/scene_gt_distractors.json"));
  EXPECT_FALSE(fs::exists(synth::bop_scene_dir(plain) + "/distractor"));
  EXPECT_FALSE(read_json(plain + "/synth_info.json")["params"].contains("distractors"));
  const auto dgt = read_json(synth::bop_scene_dir(dir) + "/scene_gt_distractors.json");
  const auto dinfo = read_json(synth::bop_scene_dir(dir) + "/scene_gt_info_distractors.json");
  ASSERT_EQ(dgt["0"].size(), nd);
  EXPECT_EQ(dinfo["1"].size(), nd);
  EXPECT_EQ(dgt["0"][2]["distractor_id"], 3);
  EXPECT_FALSE(dgt["0"][0].contains("obj_id"));
  EXPECT_EQ(read_json(dir + "/models_distractors/models_info.json").size(), nd);
  EXPECT_EQ(read_json(dir + "/synth_info.json")["distractors"].size(), nd);
  for (const auto& e : fs::directory_iterator(synth::bop_scene_dir(dir) + "/mask_visib"))
    EXPECT_LT(std::stoi(e.path().filename().string().substr(7, 6)), static_cast<int>(n));

  // Through the dataset reader and the gt back-end: targets only, nothing on a distractor.
  const auto reader = open_dataset(dir, DatasetParams{});
  SegmentationParams sp;
  sp.gt_degrade = false;
  sp.gt_min_visible_px = 1;
  sp.min_mask_area_px = 1;
  std::vector<int> classes;
  for (size_t t = 0; t < g.scene().types.size(); ++t) classes.push_back(static_cast<int>(t) + 1);
  const auto segmenter = make_segmenter(sp, classes);
  int distractor_px = 0;
  for (size_t i = 0; i < reader->size(); ++i) {
    const RgbdFrame f = reader->read(i);
    const synth::SynthFrame s = g.render_frame(static_cast<int>(i));
    ASSERT_EQ(f.objects_gt.size(), n);
    const auto detections = segmenter->detect(f);
    EXPECT_FALSE(detections.empty());
    for (size_t p = 0; p < s.distractor_labels.size(); ++p) {
      if (s.distractor_labels[p] == 0) continue;
      ++distractor_px;
      ASSERT_EQ(f.labels_gt[p], 0) << "a distractor pixel is labelled as a target";
      for (const auto& d : detections)
        ASSERT_LT(d.probability[p], sp.mask_threshold) << "class " << d.class_id;
    }
  }
  EXPECT_GT(distractor_px, 50);
}

TEST(SynthDistractors, DeterministicPerSeed) {
  const std::string a = scratch_dir("a"), b = scratch_dir("b");
  SynthParams p = with_distractors(9, 2, 3);
  p.noise = true;
  p.threads = 2;
  SyntheticSceneGenerator(p).write_bop(a);
  p.threads = 1;
  SyntheticSceneGenerator(p).write_bop(b);
  const auto fa = read_tree(a), fb = read_tree(b);
  ASSERT_TRUE(fa.count("test/000000/scene_gt_distractors.json"));
  ASSERT_TRUE(fa.count("test/000000/distractor/000001.png"));
  ASSERT_EQ(fa.size(), fb.size());
  for (const auto& [name, data] : fa) {
    ASSERT_TRUE(fb.count(name)) << name;
    EXPECT_TRUE(data == fb.at(name)) << name << " differs between two runs with the same seed";
  }
  // Another seed: other distractors (sizes, colours, places).
  p.seed = 10;
  const SyntheticSceneGenerator c(p), d(with_distractors(9, 2, 3));
  ASSERT_FALSE(c.scene().distractors.empty());
  EXPECT_GT((c.scene().distractors[0].T_world_obj.translation() -
             d.scene().distractors[0].T_world_obj.translation())
                .norm(),
            1e-3);
  EXPECT_FALSE(c.scene().distractor_types[0].mesh->base_color ==
               d.scene().distractor_types[0].mesh->base_color);
}

TEST(SynthDistractors, BadCountIsAConfigError) {
  SynthParams p = with_distractors(1, 1, -1);
  std::string why;
  EXPECT_FALSE(p.IsValid(&why));
  EXPECT_NE(why.find("distractors"), std::string::npos);
  p.distractors = 201;
  EXPECT_FALSE(p.IsValid(&why));
}

}  // namespace
}  // namespace orpe::test
