// BOP reader on a tiny dataset (root/models + root/test/000002) written here.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "io/dataset_fixtures.h"
#include "orpe/core/error.h"
#include "orpe/io/dataset.h"
#include "orpe/io/model_io.h"
#include "support/test_data.h"

namespace orpe {
namespace {
using nlohmann::json;
using test::kH;
using test::kW;

constexpr double kDepthScaleMm = 0.1;  // raw * 0.1 = mm, as the orpe synth writes

std::vector<double> row_major(const Mat3& R) {
  return {R(0, 0), R(0, 1), R(0, 2), R(1, 0), R(1, 1), R(1, 2), R(2, 0), R(2, 1), R(2, 2)};
}
std::vector<double> mm(const Vec3& t) {
  return {1000 * t.x(), 1000 * t.y(), 1000 * t.z()};
}

const std::vector<int> kImageIds = {0, 1, 3};
const std::vector<int> kObjIds = {1, 2, 1};  // two instances of object 1

SE3 gt_pose(int im, size_t k) {
  return test::test_pose(3 * im + static_cast<int>(k));
}
SE3 T_cam_world(int im) {
  return test::test_pose(50 + im);
}

/// Masks: object k covers column block [2k, 2k+2) of rows 1..4.
MaskImage object_mask(size_t k) {
  MaskImage m(kW, kH, 0);
  for (int v = 1; v < 5; ++v)
    for (int u = 2 * static_cast<int>(k); u < 2 * static_cast<int>(k) + 2; ++u) m.at(u, v) = 1;
  return m;
}

std::string make_bop(const std::string& root) {
  const std::string scene = root + "/test/000002";
  json cams = json::object(), gt = json::object(), info = json::object();
  for (int im : kImageIds) {
    const std::string key = std::to_string(im);
    cams[key] = {{"cam_K", {500.0, 0.0, 3.5, 0.0, 510.0, 2.5, 0.0, 0.0, 1.0}},
                 {"depth_scale", kDepthScaleMm},
                 {"cam_R_w2c", row_major(T_cam_world(im).rotation())},
                 {"cam_t_w2c", mm(T_cam_world(im).translation())}};
    gt[key] = json::array();
    info[key] = json::array();
    for (size_t k = 0; k < kObjIds.size(); ++k) {
      gt[key].push_back({{"cam_R_m2c", row_major(gt_pose(im, k).rotation())},
                         {"cam_t_m2c", mm(gt_pose(im, k).translation())},
                         {"obj_id", kObjIds[k]}});
      info[key].push_back(
          {{"visib_fract", 0.25 * static_cast<double>(k + 1)}, {"px_count_visib", 8}});
      write_mask_png(fmt::format("{}/mask_visib/{:06d}_{:06d}.png", scene, im, k), object_mask(k));
    }
    write_color_png(fmt::format("{}/rgb/{:06d}.png", scene, im), test::tiny_color(im));
    write_depth_png(fmt::format("{}/depth/{:06d}.png", scene, im), test::tiny_depth(0.6 + 0.1 * im),
                    1000.0 / kDepthScaleMm);
  }
  test::write_text(scene + "/scene_camera.json", cams.dump(1));
  test::write_text(scene + "/scene_gt.json", gt.dump(1));
  test::write_text(scene + "/scene_gt_info.json", info.dump(1));
  // A second scene, so the dataset root has a choice.
  std::filesystem::create_directories(root + "/test/000005/rgb");
  test::write_text(root + "/test/000005/scene_camera.json",
                   R"({"7": {"cam_K": [1, 0, 0, 0, 1, 0, 0, 0, 1], "depth_scale": 1.0}})");
  // Models: two ascii PLY in mm, object 2 symmetric.
  for (int id : {1, 2})
    test::write_text(fmt::format("{}/models/obj_{:06d}.ply", root, id),
                     "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
                     "property float z\nend_header\n0 0 0\n10 20 30\n");
  test::write_text(root + "/models/models_info.json",
                   R"({"1": {"diameter": 40.0, "symmetries_discrete": []},
                       "2": {"diameter": 30.0, "symmetries_continuous": [{"axis": [0, 0, 1], "offset": [0, 0, 0]}]}})");
  return scene;
}

TEST(BopReader, ReadsSceneGroundTruthMasksAndModels) {
  const std::string root = test::scratch_dir("bop");
  const std::string scene = make_bop(root);
  EXPECT_EQ(detect_dataset_format(scene), "bop");
  auto reader = open_dataset(scene, DatasetParams{});
  ASSERT_EQ(reader->size(), 3u);
  const DatasetInfo& info = reader->info();
  EXPECT_EQ(info.format, "bop");
  EXPECT_EQ(info.scene_id, 2);
  EXPECT_DOUBLE_EQ(info.depth_units_per_m, 10000.0);
  EXPECT_DOUBLE_EQ(info.intrinsics.fx, 500.0);
  EXPECT_DOUBLE_EQ(info.intrinsics.fy, 510.0);
  EXPECT_DOUBLE_EQ(info.intrinsics.cy, 2.5);
  EXPECT_EQ(info.intrinsics.width, kW);
  EXPECT_DOUBLE_EQ(info.model_units_per_m, 1000.0);
  ASSERT_EQ(info.class_names.size(), 2u);
  EXPECT_EQ(info.class_names.at(2), "obj_000002");
  EXPECT_EQ(info.symmetric_classes, (std::vector<int>{2}));
  ASSERT_EQ(info.model_points_paths.count(1), 1u);
  const auto pts = read_model_points(info.model_points_paths.at(1), info.model_units_per_m);
  ASSERT_EQ(pts.size(), 2u);
  EXPECT_NEAR(pts[1].z(), 0.03, 1e-9);

  for (size_t i = 0; i < 3; ++i) {
    const int im = kImageIds[i];
    const RgbdFrame f = reader->read(i);
    EXPECT_EQ(f.index, im);
    EXPECT_NEAR(f.depth.at(4, 2), 0.6 + 0.1 * im + 0.004, 1e-6);
    ASSERT_TRUE(f.T_world_cam_gt);
    EXPECT_LT((f.T_world_cam_gt->matrix() - T_cam_world(im).inverse().matrix()).norm(), 1e-6);
    ASSERT_EQ(f.objects_gt.size(), 3u);
    const std::vector<int> instances = {1, 2, 1001};
    for (size_t k = 0; k < 3; ++k) {
      EXPECT_EQ(f.objects_gt[k].class_id, kObjIds[k]);
      EXPECT_EQ(f.objects_gt[k].instance_id, instances[k]);
      EXPECT_NEAR(f.objects_gt[k].visible_fraction, 0.25 * (k + 1), 1e-12);
      EXPECT_LT((f.objects_gt[k].T_cam_obj.matrix() - gt_pose(im, k).matrix()).norm(), 1e-6);
    }
    ASSERT_EQ(f.labels_gt.width(), kW);
    EXPECT_EQ(f.labels_gt.at(0, 0), 0);
    EXPECT_EQ(f.labels_gt.at(1, 2), 1);
    EXPECT_EQ(f.labels_gt.at(3, 2), 2);
    EXPECT_EQ(f.labels_gt.at(4, 4), 3);
    EXPECT_EQ(f.labels_gt.at(4, 5), 0);
  }
  EXPECT_EQ(reader->ground_truth_trajectory().size(), 3u);
  test::expect_annotations_match_frames(*reader);
}

TEST(BopReader, DatasetRootPicksSceneAndFindsModels) {
  const std::string root = test::scratch_dir("bop");
  make_bop(root);
  EXPECT_EQ(detect_dataset_format(root + "/test"), "bop");
  auto first = open_dataset(root + "/test", DatasetParams{});
  EXPECT_EQ(first->info().scene_id, 2);
  EXPECT_EQ(first->info().class_names.size(), 2u);
  DatasetParams p;
  p.scene = "5";  // numeric match of folder 000005
  auto other = open_dataset(root + "/test", p);
  EXPECT_EQ(other->info().scene_id, 5);
  EXPECT_EQ(other->size(), 1u);
  p.scene = "000009";
  EXPECT_THROW(open_dataset(root + "/test", p), ConfigError);
  // The dataset root itself (as orpe synth writes it): the scenes are found in its split folder,
  // test/ before the others.
  EXPECT_EQ(detect_dataset_format(root), "bop");
  EXPECT_EQ(open_dataset(root, DatasetParams{})->info().scene_id, 2);
  std::filesystem::create_directories(root + "/train/000001/rgb");
  test::write_text(root + "/train/000001/scene_camera.json",
                   R"({"3": {"cam_K": [1, 0, 0, 0, 1, 0, 0, 0, 1], "depth_scale": 1.0}})");
  p.scene = "5";
  EXPECT_EQ(open_dataset(root, p)->info().scene_id, 5);
  EXPECT_EQ(open_dataset(root, p)->info().class_names.size(), 2u);  // <root>/models
  const std::string no_scenes = test::scratch_dir("empty");
  std::filesystem::create_directories(no_scenes + "/test/000001");
  EXPECT_THROW(open_dataset(no_scenes, DatasetParams{}), IoError);
}

// A missing models_info.json silently dropped every symmetry (ADD instead of ADD-S); issue 12.
TEST(BopReader, MissingModelsInfoIsRefusedUnlessAskedFor) {
  const std::string root = test::scratch_dir("bop");
  const std::string scene = make_bop(root);
  EXPECT_EQ(open_dataset(scene, DatasetParams{})->info().symmetric_classes, std::vector<int>{2});
  std::filesystem::remove(root + "/models/models_info.json");
  test::expect_io_error_naming([&] { open_dataset(scene, DatasetParams{}); }, "models_info.json");
  DatasetParams p;
  p.bop_without_models_info = true;
  const auto reader = open_dataset(scene, p);
  EXPECT_TRUE(reader->info().symmetric_classes.empty());
  EXPECT_EQ(reader->info().model_points_paths.size(), 2u);
}

// Overflowing ids were a bare "[error] stoi" (issue 12); now they name the file or folder.
TEST(BopReader, OverflowingIdsAreErrorsNamingTheFile) {
  const std::string root = test::scratch_dir("bop");
  const std::string scene = make_bop(root);
  json cams = json::parse(std::ifstream(scene + "/scene_camera.json"));
  cams["99999999999"] = cams["0"];
  test::write_text(scene + "/scene_camera.json", cams.dump());
  test::expect_io_error_naming([&] { open_dataset(scene, DatasetParams{}); }, "scene_camera.json");
  try {
    open_dataset(scene, DatasetParams{});
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("'99999999999' is out of range"), std::string::npos)
        << e.what();
  }
  const std::string root2 = test::scratch_dir("bop2");
  const std::string scene2 = make_bop(root2);
  const std::string big = root2 + "/test/99999999999999";
  std::filesystem::rename(scene2, big);
  test::expect_io_error_naming([&] { open_dataset(big, DatasetParams{}); }, "99999999999999");
  test::write_text(root2 + "/models/models_info.json",
                   R"({"1": {"diameter": 40.0}, "99999999999": {"diameter": 1}})");
  DatasetParams p;
  p.scene = "000005";
  test::expect_io_error_naming([&] { open_dataset(root2, p); }, "models_info.json");
}

TEST(BopReader, BadEntriesAreErrorsNamingTheFile) {
  const std::string root = test::scratch_dir("bop");
  const std::string scene = make_bop(root);
  json cams = json::parse(std::ifstream(scene + "/scene_camera.json"));
  cams["1"].erase("depth_scale");  // image 1: no depth scale
  cams["3"]["cam_K"] = {1, 2, 3};  // image 3: malformed K
  test::write_text(scene + "/scene_camera.json", cams.dump());
  auto reader = open_dataset(scene, DatasetParams{});
  ASSERT_EQ(reader->size(), 3u);
  EXPECT_NO_THROW(reader->read(0));
  test::expect_io_error_naming([&] { reader->read(1); }, "scene_camera.json");
  test::expect_io_error_naming([&] { reader->read(2); }, "scene_camera.json");
  EXPECT_NO_THROW(reader->read_annotations(1));  // depth scale not needed without pixels
  test::expect_io_error_naming([&] { reader->read_annotations(2); }, "scene_camera.json");
  FrameStream stream(*reader);
  RgbdFrame f;
  while (stream.next(f)) {
  }
  EXPECT_EQ(stream.skipped(), 2u);
  DatasetParams p;
  p.depth_units_per_m = 10000;
  EXPECT_NO_THROW(open_dataset(scene, p)->read(1));

  // Ground truth with a non-rotation, and a missing mask.
  json gt = json::parse(std::ifstream(scene + "/scene_gt.json"));
  gt["0"][1]["cam_R_m2c"] = {2, 0, 0, 0, 1, 0, 0, 0, 1};
  test::write_text(scene + "/scene_gt.json", gt.dump());
  std::filesystem::remove(scene + "/mask_visib/000001_000002.png");
  auto reader2 = open_dataset(scene, p);
  test::expect_io_error_naming([&] { reader2->read(0); }, "scene_gt.json");
  test::expect_io_error_naming([&] { reader2->read(1); }, "000001_000002.png");

  // Unparseable JSON fails at open, naming the file.
  test::write_text(scene + "/scene_gt_info.json", "{\"0\": [");
  test::expect_io_error_naming([&] { open_dataset(scene, p); }, "scene_gt_info.json");
}

}  // namespace
}  // namespace orpe
