// Issue #17, "Done when": a YCB-Video clip turned into a plain folder (rgb/, depth/, camera.yaml)
// with a separate models folder of OBJ meshes gives, through `orpe run --dataset DIR --models
// MODELS
// --mode full`, the same poses as the original layout. Both runs read the same detections (the
// files back-end: exact masks written from the clip's label images here), so the only difference is
// the input path: reader, camera file, models folder. SLAM starts at the identity in both (a plain
// folder has no ground-truth pose to start from).
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "orpe/io/dataset.h"
#include "orpe/semantic/segmenter.h"
#include "support/test_data.h"

namespace orpe {
namespace {
namespace fs = std::filesystem;

constexpr int kFrames = 8;  // a short stretch of clip 0000: frames 000001..000008

int run_cli(const std::string& args) {
  const std::string cmd = std::string("OMP_WAIT_POLICY=passive ") + ORPE_CLI_PATH + " -q " + args;
  return std::system(cmd.c_str());
}

/// Exact detections (one per visible ground-truth object) of every selected frame, files format.
void write_label_detections(const DatasetReader& reader, const std::string& dir) {
  for (size_t i = 0; i < reader.size(); ++i) {
    const RgbdFrame f = reader.read(i);
    std::vector<Detection> dets(f.objects_gt.size());
    for (size_t k = 0; k < dets.size(); ++k) {
      dets[k].class_id = f.objects_gt[k].class_id;
      dets[k].score = 1.0f;
      dets[k].probability = ProbabilityImage(f.labels_gt.width(), f.labels_gt.height(), 0.0f);
    }
    for (int v = 0; v < f.labels_gt.height(); ++v)
      for (int u = 0; u < f.labels_gt.width(); ++u)
        if (const int l = f.labels_gt.at(u, v); l > 0) {
          dets[l - 1].probability.at(u, v) = 1.0f;
          dets[l - 1].box.include(u, v);
        }
    std::erase_if(dets, [](const Detection& d) { return d.box.empty(); });
    write_detection_files(dir, f.index, dets);
  }
}

/// The clip as a plain folder: rgb/NNNNNN.png, depth/NNNNNN.png and an ORB-SLAM2-style camera.yaml
/// with the clip's intrinsics and depth factor.
void write_plain_folder(const std::string& clip, const DatasetReader& reader,
                        const std::string& dir) {
  fs::create_directories(dir + "/rgb");
  fs::create_directories(dir + "/depth");
  for (int n = 1; n <= kFrames; ++n) {
    fs::copy_file(fmt::format("{}/{:06d}-color.png", clip, n),
                  fmt::format("{}/rgb/{:06d}.png", dir, n));
    fs::copy_file(fmt::format("{}/{:06d}-depth.png", clip, n),
                  fmt::format("{}/depth/{:06d}.png", dir, n));
  }
  const PinholeIntrinsics k = reader.read_annotations(0).intrinsics;
  std::ofstream(dir + "/camera.yaml") << fmt::format(
      "%YAML:1.0\nCamera.fx: {:.17g}\nCamera.fy: {:.17g}\nCamera.cx: {:.17g}\nCamera.cy: {:.17g}\n"
      "Camera.width: {}\nCamera.height: {}\nDepthMapFactor: {:.17g}\n",
      k.fx, k.fy, k.cx, k.cy, k.width, k.height, reader.info().depth_units_per_m);
}

/// A models folder of OBJ meshes (one folder per object, as YCB ships them: textured_simple.obj
/// with its .mtl and texture, and points.xyz), outside the dataset.
void write_models_folder(const std::string& models, const std::string& dir) {
  for (const auto& obj : fs::directory_iterator(models)) {
    fs::create_directories(dir + "/" + obj.path().filename().string());
    for (const auto& f : fs::directory_iterator(obj.path()))
      fs::copy_file(f.path(), dir + "/" + obj.path().filename().string() + "/" +
                                  f.path().filename().string());
  }
}

/// poses.csv rows (scene_id,im_id,obj_id,score,R,t,time) without the time column.
std::vector<std::vector<double>> read_poses(const std::string& path) {
  std::ifstream is(path);
  EXPECT_TRUE(is.good()) << path;
  std::vector<std::vector<double>> rows;
  std::string line;
  std::getline(is, line);  // header
  while (std::getline(is, line)) {
    std::vector<double> row;
    std::string cell;
    std::stringstream ss(line);
    int col = 0;
    while (std::getline(ss, cell, ',')) {
      if (col++ == 6) break;  // time
      std::stringstream cs(cell);
      for (double x; cs >> x;) row.push_back(x);
    }
    rows.push_back(row);
  }
  return rows;
}

TEST(UserDataEndToEnd, PlainFolderAndModelsFolderGiveTheSamePosesAsTheYcbLayout) {
  ORPE_REQUIRE_DATA(data, "ycbv/data/0000/000008-meta.mat");
  const std::string clip = data + "/ycbv/data/0000";
  const std::string dir = test::scratch_dir("userdata");
  DatasetParams params;
  params.last_frame = kFrames - 1;
  const auto reader = open_dataset(clip, params);
  write_label_detections(*reader, dir + "/detections");
  write_plain_folder(clip, *reader, dir + "/plain");
  write_models_folder(data + "/ycbv/models", dir + "/models");

  const std::string common = fmt::format(
      "--mode full --set dataset.last_frame={} --set segmentation.backend=files "
      "--set pipeline.init_from_ground_truth=false "
      "--set segmentation.files_dir={}/detections",
      kFrames - 1, dir);
  ASSERT_EQ(run_cli(fmt::format("run --dataset {} --out {}/ycb {} > {}/ycb.log 2>&1", clip, dir,
                                common, dir)),
            0)
      << "see " << dir << "/ycb.log";
  ASSERT_EQ(run_cli(fmt::format("run --dataset {}/plain --models {}/models --out {}/plain_run {} > "
                                "{}/plain.log 2>&1",
                                dir, dir, dir, common, dir)),
            0)
      << "see " << dir << "/plain.log";
  const auto a = read_poses(dir + "/ycb/poses.csv");
  const auto b = read_poses(dir + "/plain_run/poses.csv");
  ASSERT_GE(a.size(), 3u) << "the clip shows three objects";
  ASSERT_EQ(a.size(), b.size());
  for (size_t r = 0; r < a.size(); ++r) {
    ASSERT_EQ(a[r].size(), b[r].size());
    EXPECT_EQ(a[r][1], b[r][1]) << "im_id, row " << r;
    EXPECT_EQ(a[r][2], b[r][2]) << "obj_id, row " << r;
    for (size_t c = 4; c < a[r].size(); ++c)  // R (9) and t (3, mm)
      EXPECT_NEAR(a[r][c], b[r][c], c < 13 ? 1e-4 : 0.05) << "row " << r << " column " << c;
  }
}

}  // namespace
}  // namespace orpe
