// `orpe convert` (docs/DATASETS.md, "orpe convert"): a dataset written as a BOP scene reads back as
// the same frames: colour and depth values, intrinsics, camera poses, object poses and visible
// masks. On a YCB-Video clip (real data, when present) and on a synthetic scene; bad output folders
// are refused and nothing is left half-written.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "orpe/io/dataset.h"
#include "pipeline/pipeline_test_util.h"
#include "support/cli_run.h"
#include "support/test_data.h"

namespace orpe {
namespace {

int orpe_cli(const std::string& args) {
  return test::run_cli(args + " > /dev/null 2>&1");
}

/// The one scene_gt_info.json under `root`.
nlohmann::json read_gt_info(const std::string& root) {
  for (const auto& e : std::filesystem::recursive_directory_iterator(root))
    if (e.path().filename() == "scene_gt_info.json")
      return nlohmann::json::parse(std::ifstream(e.path()));
  ADD_FAILURE() << "no scene_gt_info.json under " << root;
  return {};
}

/// Frames of `a` and `b` agree: pixels exactly, poses to 1e-6 (m and rotation-matrix entries).
void expect_same_frames(const DatasetReader& a, const DatasetReader& b, bool labels) {
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(a.info().intrinsics.K(), b.info().intrinsics.K());
  for (size_t i = 0; i < a.size(); ++i) {
    const RgbdFrame fa = a.read(i), fb = b.read(i);
    ASSERT_EQ(fa.color.width(), fb.color.width());
    ASSERT_EQ(fa.depth.height(), fb.depth.height());
    int colour_diff = 0, depth_diff = 0, label_diff = 0;
    for (int v = 0; v < fa.depth.height(); ++v)
      for (int u = 0; u < fa.depth.width(); ++u) {
        colour_diff += fa.color.at(u, v) != fb.color.at(u, v);
        depth_diff += std::abs(fa.depth.at(u, v) - fb.depth.at(u, v)) > 1e-6f;
        if (labels) label_diff += fa.labels_gt.at(u, v) != fb.labels_gt.at(u, v);
      }
    EXPECT_EQ(colour_diff, 0) << "frame " << i;
    EXPECT_EQ(depth_diff, 0) << "frame " << i;
    EXPECT_EQ(label_diff, 0) << "frame " << i;
    ASSERT_EQ(fa.T_world_cam_gt.has_value(), fb.T_world_cam_gt.has_value());
    if (fa.T_world_cam_gt) {
      EXPECT_LT((fa.T_world_cam_gt->matrix() - fb.T_world_cam_gt->matrix()).cwiseAbs().maxCoeff(),
                1e-6);
    }
    ASSERT_EQ(fa.objects_gt.size(), fb.objects_gt.size()) << "frame " << i;
    for (size_t k = 0; k < fa.objects_gt.size(); ++k) {
      EXPECT_EQ(fa.objects_gt[k].class_id, fb.objects_gt[k].class_id);
      EXPECT_LT((fa.objects_gt[k].T_cam_obj.matrix() - fb.objects_gt[k].T_cam_obj.matrix())
                    .cwiseAbs()
                    .maxCoeff(),
                1e-6);
    }
  }
}

TEST(ConvertCli, AYcbvClipReadsBackAsTheSameFramesInBopLayout) {
  ORPE_REQUIRE_DATA(data, "ycbv/data/0002/000001-meta.mat");
  const std::string clip = data + "/ycbv/data/0002";
  const std::string out = test::scratch_dir("convert_ycbv") + "/bop";
  std::filesystem::remove_all(out);
  ASSERT_EQ(orpe_cli("convert --dataset " + clip + " --out " + out + " --set dataset.last_frame=2"),
            0);
  DatasetParams p;
  p.last_frame = 2;
  const auto source = open_dataset(clip, p);
  const auto converted = open_dataset(out, DatasetParams{});
  EXPECT_EQ(converted->info().format, "bop");
  EXPECT_EQ(converted->info().depth_units_per_m, source->info().depth_units_per_m);
  expect_same_frames(*source, *converted, true);
  // Every class of the clip has its model, in mm, with the source's class ids as obj ids.
  for (const auto& g : source->read(0).objects_gt)
    EXPECT_TRUE(converted->info().model_points_paths.count(g.class_id)) << g.class_id;
  const auto meta = test::read_json(out + "/orpe_convert.json");
  EXPECT_EQ(meta["frames"].size(), 3u);
  EXPECT_EQ(meta["frames"][0]["source"], source->read_annotations(0).name);
}

TEST(ConvertCli, ASyntheticSceneReadsBackAndBadOutputsAreRefused) {
  const std::string scene =
      test::synthetic_scene("convert_cli", test::small_scene_params(120, 90, 4, 3, 3));
  const std::string out = test::scratch_dir("convert_synth") + "/bop";
  std::filesystem::remove_all(out);
  ASSERT_EQ(orpe_cli("convert --dataset " + scene + " --out " + out), 0);
  expect_same_frames(*open_dataset(scene, DatasetParams{}), *open_dataset(out, DatasetParams{}),
                     true);
  // Visibility as bop_toolkit computes it, the same code as `orpe synth` (synth/frame_info.h): the
  // converted counts and fractions are the generator's, to a few pixels of rasterisation from the
  // re-read (mm, float) meshes; at 120 x 90 some objects are cut by the image border, and those
  // count their outside part as not visible.
  const nlohmann::json src = read_gt_info(scene), dst = read_gt_info(out);
  ASSERT_EQ(src.size(), dst.size());
  int cut_by_border = 0;
  for (const auto& [im, objects] : src.items()) {
    ASSERT_TRUE(dst.contains(im)) << im;
    ASSERT_EQ(objects.size(), dst[im].size()) << im;
    for (size_t k = 0; k < objects.size(); ++k) {
      const auto &a = objects[k], &b = dst[im][k];
      EXPECT_EQ(a["px_count_visib"], b["px_count_visib"]) << im << " " << k;
      EXPECT_EQ(a["px_count_valid"], b["px_count_valid"]) << im << " " << k;
      EXPECT_NEAR(a["px_count_all"].get<double>(), b["px_count_all"].get<double>(),
                  2 + 0.02 * a["px_count_all"].get<double>())
          << im << " " << k;
      EXPECT_NEAR(a["visib_fract"].get<double>(), b["visib_fract"].get<double>(), 0.02)
          << im << " " << k;
      const auto& box = a["bbox_obj"];
      cut_by_border += box[0].get<int>() < 0 || box[1].get<int>() < 0 ||
                       box[0].get<int>() + box[2].get<int>() > 120 ||
                       box[1].get<int>() + box[3].get<int>() > 90;
    }
  }
  EXPECT_GT(cut_by_border, 0) << "the scene should have objects cut by the image border";
  // An existing output is kept without --overwrite, replaced with it; a folder that is not an
  // earlier conversion is never replaced; a failing conversion leaves nothing behind.
  EXPECT_NE(orpe_cli("convert --dataset " + scene + " --out " + out), 0);
  EXPECT_EQ(orpe_cli("convert --dataset " + scene + " --out " + out + " --overwrite"), 0);
  EXPECT_NE(orpe_cli("convert --dataset " + scene + " --out " + scene + " --overwrite"), 0);
  EXPECT_TRUE(std::filesystem::exists(scene + "/camera.json"));
  const std::string failed = test::scratch_dir("convert_fail") + "/bop";
  std::filesystem::remove_all(failed);
  EXPECT_NE(orpe_cli("convert --dataset " + scene + "/no_such_scene --out " + failed), 0);
  EXPECT_FALSE(std::filesystem::exists(failed));
}

}  // namespace
}  // namespace orpe
