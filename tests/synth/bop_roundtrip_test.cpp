// The generator's BOP output read back through the project's dataset reader (src/orpe/io)
// unchanged: same poses, intrinsics, depth, colour, labels and model files as the generator holds
// in memory.
#include <gtest/gtest.h>

#include "orpe/io/dataset.h"
#include "orpe/io/model_io.h"
#include "orpe/io/point_cloud_io.h"
#include "orpe/pipeline/reconstruction_error.h"
#include "orpe/render/mesh_io.h"
#include "orpe/synth/generator.h"
#include "support/test_data.h"
#include "synth_test_util.h"

namespace orpe::test {
namespace {

TEST(SynthBop, ReadBackThroughTheDatasetReader) {
  const std::string dir = scratch_dir("bop");
  SynthParams p = small_synth(8, 4, true);
  const synth::SyntheticSceneGenerator gen(p);
  gen.write_bop(dir);

  EXPECT_EQ(detect_dataset_format(dir), "bop");
  DatasetParams dp;
  const auto reader = open_dataset(dir, dp);
  const DatasetInfo& info = reader->info();
  ASSERT_EQ(reader->size(), 4u);
  EXPECT_DOUBLE_EQ(info.depth_units_per_m, 10000.0);  // depth_scale 0.1 mm per raw unit
  EXPECT_EQ(info.intrinsics, gen.intrinsics());
  const size_t n_types = gen.scene().types.size();
  EXPECT_EQ(info.model_mesh_paths.size(), n_types);
  // Shape symmetries written to models_info.json reach the reader (all built-in shapes have some).
  EXPECT_EQ(info.symmetric_classes.size(), n_types);

  for (size_t i = 0; i < reader->size(); ++i) {
    const RgbdFrame f = reader->read(i);
    const synth::SynthFrame s = gen.render_frame(static_cast<int>(i));
    ASSERT_TRUE(f.T_world_cam_gt.has_value());
    EXPECT_LT((f.T_world_cam_gt->inverse() * s.T_world_cam).log().norm(), 1e-9);
    ASSERT_EQ(f.objects_gt.size(), s.T_cam_obj.size());
    for (size_t k = 0; k < f.objects_gt.size(); ++k) {
      EXPECT_EQ(f.objects_gt[k].class_id, gen.scene().objects[k].type + 1);
      EXPECT_EQ(f.objects_gt[k].instance_id, f.objects_gt[k].class_id);  // one instance per type
      EXPECT_LT((f.objects_gt[k].T_cam_obj.inverse() * s.T_cam_obj[k]).log().norm(), 1e-9);
      EXPECT_NEAR(f.objects_gt[k].visible_fraction, s.info[k].visib_fract, 1e-12);
    }
    ASSERT_EQ(f.depth.size(), s.depth.size());
    double worst = 0;
    for (size_t q = 0; q < f.depth.size(); ++q)
      worst = std::max(worst, std::abs(double(f.depth[q]) - s.depth[q]));
    EXPECT_LE(worst, 0.5e-4 + 1e-6);  // 0.1 mm raw units
    EXPECT_TRUE(std::equal(f.color.begin(), f.color.end(), s.rgb.begin()));
    EXPECT_TRUE(std::equal(f.labels_gt.begin(), f.labels_gt.end(), s.instances.begin()));
  }
  // Model points in the reader's units (mm PLY -> metres) match the generator's mesh.
  const auto& mesh = *gen.scene().types[0].mesh;
  const auto pts = read_model_points(info.model_points_paths.at(1), info.model_units_per_m);
  ASSERT_EQ(pts.size(), mesh.vertices.size());
  for (size_t i = 0; i < pts.size(); i += 97)
    EXPECT_LT((pts[i] - mesh.vertices[i].cast<double>()).norm(), 2e-6);
  // The surface samples for ADD-S.
  const auto xyz = read_model_points(dir + "/models/obj_000001_points.xyz", 1.0);
  EXPECT_EQ(xyz.size(), static_cast<size_t>(p.model_points));
}

TEST(SynthBop, TheSceneMeshIsTheSurfaceTheDepthImagesShow) {
  // scene_mesh.ply (metres, world frame) is the ground truth `orpe eval map` scores a map against:
  // every depth pixel of a noise-free frame, moved into the world at the frame's ground-truth
  // pose, lies on it; a mesh written in another frame or unit would miss by centimetres.
  const std::string dir = scratch_dir("bop_scene_mesh");
  SynthParams p = small_synth(5, 2, false);
  p.scene = "shelf";
  synth::SyntheticSceneGenerator(p).write_bop(dir);
  const std::string mesh_path = dir + "/test/000000/scene_mesh.ply";
  const ModelSurface surface = ModelSurface::from_mesh(load_mesh(mesh_path));
  DatasetParams dp;
  const auto reader = open_dataset(dir, dp);
  const RgbdFrame f = reader->read(1);
  ASSERT_TRUE(f.T_world_cam_gt.has_value());
  const PinholeIntrinsics& K = f.intrinsics;
  PointCloudData cloud;
  for (int v = 0; v < f.depth.height(); v += 2)
    for (int u = 0; u < f.depth.width(); u += 2) {
      const float z = f.depth.at(u, v);
      if (!(z > 0)) continue;
      const Vec3 x_cam((u - K.cx) * z / K.fx, (v - K.cy) * z / K.fy, z);
      cloud.positions_m.push_back((*f.T_world_cam_gt * x_cam).cast<float>());
    }
  ASSERT_GT(cloud.size(), 1000u);
  const MapSurfaceError e = evaluate_map_surface(cloud, surface);
  EXPECT_LT(e.median_m, 0.0005);  // the depth's 0.1 mm steps and the rasteriser's precision
  EXPECT_LT(e.far_near_fraction, 0.01);
}

}  // namespace
}  // namespace orpe::test
