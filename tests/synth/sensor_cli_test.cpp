// The structured-light sensor model, and the `orpe synth` command line.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <random>

#include "orpe/synth/sensor.h"
#include "support/test_data.h"
#include "synth_test_util.h"

namespace orpe::test {
namespace {

namespace fs = std::filesystem;

PinholeIntrinsics cam(int w, int h) {
  PinholeIntrinsics K;
  K.width = w, K.height = h, K.fx = K.fy = 580.0 * w / 640.0, K.cx = (w - 1) / 2.0,
  K.cy = (h - 1) / 2.0;
  return K;
}

TEST(SynthSensor, NoiseModelFollowsNguyen) {
  // sigma_z(z, 0) = 0.0012 + 0.0019 (z - 0.4)^2
  EXPECT_NEAR(synth::axial_noise_sigma_m(1.0, 0.0), 0.0012 + 0.0019 * 0.36, 1e-12);
  EXPECT_NEAR(synth::axial_noise_sigma_m(3.0, 0.0), 0.0012 + 0.0019 * 6.76, 1e-12);
  EXPECT_GT(synth::axial_noise_sigma_m(1.0, 1.2),
            synth::axial_noise_sigma_m(1.0, 0.3));  // grazing is worse
  synth::DepthSensorParams p;
  EXPECT_NEAR(synth::quantisation_step_m(1.0, 580, p), 1.0 / (580 * 0.075 * 8), 1e-12);
}

TEST(SynthSensor, QuantisedRangeLimitedAndShadowedLikeAStructuredLightCamera) {
  const PinholeIntrinsics K = cam(320, 240);
  // A wall at 2 m, a box face at 1 m in the middle columns.
  DepthImage clean(K.width, K.height, 2.0f);
  Image<Eigen::Vector3f> normals(K.width, K.height, Eigen::Vector3f(0, 0, -1));
  const int u0 = 140, u1 = 180;
  for (int v = 0; v < K.height; ++v)
    for (int u = u0; u < u1; ++u) clean.at(u, v) = 1.0f;
  for (int u = 0; u < 10; ++u)
    for (int v = 0; v < K.height; ++v) clean.at(u, v) = 6.0f;  // beyond the range
  synth::DepthSensorParams p;
  p.dropout = 0;
  p.edge_dropout = 0;
  p.lateral_sigma_px = 0;
  std::mt19937_64 rng(5);
  synth::DepthSensorStats st;
  const DepthImage d = synth::simulate_depth_sensor(clean, normals, K, p, rng, &st);
  const double fb = K.fx * p.baseline_m;
  // Shadow on the left of the box: width f b (1/z_near - 1/z_far) pixels.
  const int shadow_px = static_cast<int>(fb * (1.0 / 1.0 - 1.0 / 2.0));
  const int row = K.height / 2;
  for (int u = u0 - shadow_px + 2; u < u0; ++u) EXPECT_EQ(d.at(u, row), 0.0f) << "u " << u;
  EXPECT_GT(d.at(u0 - shadow_px - 3, row), 0.0f);
  EXPECT_GT(d.at(u1 + 3, row), 0.0f);  // no shadow on the right
  EXPECT_GT(st.shadowed, 0u);
  for (int v = 0; v < K.height; ++v) EXPECT_EQ(d.at(3, v), 0.0f);  // out of range
  // Every valid depth lies on the disparity grid d = f b / z in 1/8 pixel steps.
  int on_grid = 0, valid = 0;
  double err_sum = 0;
  for (int v = 0; v < K.height; ++v)
    for (int u = 0; u < K.width; ++u) {
      const float z = d.at(u, v);
      if (z <= 0) continue;
      ++valid;
      const double steps = fb / z * 8.0;
      on_grid += std::abs(steps - std::round(steps)) < 1e-3;
      err_sum += std::abs(z - clean.at(u, v));
    }
  EXPECT_EQ(on_grid, valid);
  EXPECT_GT(err_sum / valid, 0.0005);  // noisy
  // Off: unchanged.
  p.enabled = false;
  const DepthImage off = synth::simulate_depth_sensor(clean, normals, K, p, rng);
  EXPECT_TRUE(std::equal(off.begin(), off.end(), clean.begin()));
}

TEST(SynthSensor, GrazingSurfacesLoseDepth) {
  const PinholeIntrinsics K = cam(160, 120);
  DepthImage clean(K.width, K.height, 1.5f);
  Image<Eigen::Vector3f> normals(K.width, K.height, Eigen::Vector3f(0, 0, -1));
  // Top half: surfaces seen at 84 degrees incidence (normal turned 84 deg away from the viewing
  // ray).
  for (int v = 0; v < K.height / 2; ++v)
    for (int u = 0; u < K.width; ++u) {
      const Vec3 ray = Vec3((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0).normalized();
      const Vec3 perp = ray.cross(Vec3::UnitY()).normalized();
      const double a = 84.0 * M_PI / 180.0;
      normals.at(u, v) = (-std::cos(a) * ray + std::sin(a) * perp).cast<float>();
    }
  synth::DepthSensorParams p;
  std::mt19937_64 rng(1);
  const DepthImage d = synth::simulate_depth_sensor(clean, normals, K, p, rng);
  int top_valid = 0, bottom_valid = 0;
  for (int v = 0; v < K.height; ++v)
    for (int u = 0; u < K.width; ++u)
      (v < K.height / 2 ? top_valid : bottom_valid) += d.at(u, v) > 0;
  EXPECT_LT(top_valid, 0.05 * K.width * K.height / 2);
  EXPECT_GT(bottom_valid, 0.95 * K.width * K.height / 2);
}

std::string run(const std::string& cmd) {
  std::string out;
  FILE* f = popen((cmd + " 2>&1").c_str(), "r");
  if (!f) return out;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof(buf), f)) > 0) out.append(buf, n);
  const int status = pclose(f);
  out += "\n[exit " + std::to_string(WEXITSTATUS(status)) + "]";
  return out;
}

TEST(SynthCli, HelpDocumentsEveryOption) {
  const std::string help = run(std::string(ORPE_CLI_PATH) + " synth --help");
  for (const char* opt : {"--out",
                          "--seed",
                          "--frames",
                          "--objects",
                          "--scene",
                          "--models",
                          "--model-unit-m",
                          "--repeat-types",
                          "--distractors",
                          "--noise",
                          "--width",
                          "--height",
                          "--fx",
                          "--fy",
                          "--cx",
                          "--cy",
                          "--fps",
                          "--span-deg",
                          "--baseline-m",
                          "--distance-m",
                          "--elevation-deg",
                          "--preview-stride",
                          "--no-masks",
                          "--threads",
                          "--config",
                          "--set"})
    EXPECT_NE(help.find(opt), std::string::npos) << opt;
  EXPECT_NE(help.find("depth_scale 0.1"), std::string::npos);
}

TEST(SynthCli, WritesABopSceneAndRejectsBadOptions) {
  const std::string dir = scratch_dir("cli");
  const std::string out =
      run(std::string(ORPE_CLI_PATH) + " synth --out " + dir +
          " --seed 2 --frames 2 --objects 4 --scene table --width 160 --height 120 --noise off"
          " --preview-stride 1 --set synth.model_points=500");
  EXPECT_NE(out.find("[exit 0]"), std::string::npos) << out;
  // A BOP dataset: models and cameras at its root, the scene in test/000000 (bop_toolkit's layout).
  for (const char* f :
       {"camera.json", "models/models_info.json", "models/obj_000001.ply",
        "models/obj_000004_points.xyz", "synth_info.json", "test_targets_bop19.json"})
    EXPECT_TRUE(fs::exists(dir + "/" + f)) << f;
  for (const char* f :
       {"scene_camera.json", "scene_gt.json", "scene_gt_info.json", "groundtruth.txt",
        "rgb/000001.png", "depth/000001.png", "mask/000001_000000.png",
        "mask_visib/000001_000003.png", "instance/000000.png", "preview/000001.png"})
    EXPECT_TRUE(fs::exists(dir + "/test/000000/" + f)) << f;
  const auto camera = read_json(dir + "/camera.json");
  EXPECT_EQ(camera["width"], 160);
  EXPECT_DOUBLE_EQ(camera["depth_scale"].get<double>(), 0.1);
  // test_targets_bop19.json: the instances at least 10 % visible, counted per image and object.
  const auto targets = read_json(dir + "/test_targets_bop19.json");
  const auto gt_info = read_json(dir + "/test/000000/scene_gt_info.json");
  size_t visible = 0;
  for (const auto& [im, list] : gt_info.items())
    for (const auto& e : list) visible += e["visib_fract"].get<double>() >= 0.1;
  size_t counted = 0;
  for (const auto& t : targets) {
    EXPECT_EQ(t["scene_id"], 0);
    counted += t["inst_count"].get<size_t>();
  }
  EXPECT_EQ(counted, visible);
  EXPECT_GT(visible, 0u);
  EXPECT_EQ(read_xyz(dir + "/models/obj_000001_points.xyz").size(), 500u);
  const auto info = read_json(dir + "/synth_info.json");
  EXPECT_EQ(info["params"]["scene"], "table");
  EXPECT_EQ(info["params"]["noise"], false);
  const std::string bad = run(std::string(ORPE_CLI_PATH) + " synth --out " + dir + " --scene moon");
  EXPECT_EQ(bad.find("[exit 0]"), std::string::npos);
  const std::string bad2 =
      run(std::string(ORPE_CLI_PATH) + " synth --out " + dir + " --set synth.frames=0");
  EXPECT_NE(bad2.find("frames"), std::string::npos) << bad2;
  EXPECT_EQ(bad2.find("[exit 0]"), std::string::npos);
}

TEST(SynthCli, YcbModelsAsUserMeshes) {
  ORPE_REQUIRE_DATA(data, "ycbv/models/011_banana/textured_simple.obj");
  const std::string dir = scratch_dir("ycb");
  const std::string models = data + "/ycbv/models/011_banana/textured_simple.obj," + data +
                             "/ycbv/models/005_tomato_soup_can/textured_simple.obj," + data +
                             "/ycbv/models/003_cracker_box/textured_simple.obj";
  const std::string out =
      run(std::string(ORPE_CLI_PATH) + " synth --out " + dir + " --models " + models +
          " --frames 1 --width 160 --height 120 --set synth.model_points=300");
  ASSERT_NE(out.find("[exit 0]"), std::string::npos) << out;
  const auto info = read_json(dir + "/synth_info.json");
  ASSERT_EQ(info["objects"].size(), 3u);
  const auto mi = read_json(dir + "/models/models_info.json");
  // The cracker box is about 0.16 x 0.21 x 0.07 m: its diameter in mm.
  bool found = false;
  for (const auto& o : info["objects"])
    if (o["name"] == "003_cracker_box") {
      found = true;
      const double d = mi[std::to_string(o["obj_id"].get<int>())]["diameter"].get<double>();
      EXPECT_GT(d, 250);
      EXPECT_LT(d, 300);
    }
  EXPECT_TRUE(found);
  EXPECT_TRUE(fs::exists(dir + "/models/obj_000001.png") ||
              fs::exists(dir + "/models/obj_000002.png") ||
              fs::exists(dir + "/models/obj_000003.png"));  // the banana's texture
}

}  // namespace
}  // namespace orpe::test
