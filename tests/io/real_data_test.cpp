// Every file of the shared real data loads through the readers; ground truth is consistent.
#include <gtest/gtest.h>

#include <cmath>

#include <map>

#include <fmt/format.h>

#include "io/dataset_fixtures.h"
#include "orpe/io/dataset.h"
#include "orpe/io/model_io.h"
#include "support/test_data.h"

namespace orpe {
namespace {

size_t count_valid_depth(const DepthImage& d) {
  size_t n = 0;
  for (float z : d) n += z > 0;
  return n;
}

TEST(RealSevenScenes, AllFramesLoadThroughBothLayoutsWithTheSameGroundTruth) {
  ORPE_REQUIRE_DATA(data, "7scenes-seq/rgb.txt");
  const std::string dir = data + "/7scenes-seq";
  EXPECT_EQ(detect_dataset_format(dir), "tum");  // the TUM index takes precedence
  DatasetParams tum_params;
  tum_params.format = "tum";
  DatasetParams native_params;
  native_params.format = "7scenes";
  auto tum = open_dataset(dir, tum_params);
  auto native = open_dataset(dir, native_params);
  ASSERT_EQ(tum->size(), 500u);
  ASSERT_EQ(native->size(), 500u);
  // 7-Scenes origin detected: millimetres, not TUM's 5000, and 7-Scenes' intrinsics.
  EXPECT_DOUBLE_EQ(tum->info().depth_units_per_m, 1000.0);
  EXPECT_EQ(tum->info().intrinsics, native->info().intrinsics);
  EXPECT_DOUBLE_EQ(native->info().intrinsics.fx, 585.0);
  EXPECT_EQ(native->info().intrinsics.width, 640);

  FrameStream tum_stream(*tum), native_stream(*native);
  RgbdFrame a, b;
  size_t n = 0;
  double max_dt = 0, max_dR = 0, max_dt_m = 0;
  while (tum_stream.next(a)) {
    ASSERT_TRUE(native_stream.next(b));
    ASSERT_EQ(a.index, b.index);
    max_dt = std::max(max_dt, std::abs(a.timestamp_s - b.timestamp_s));
    ASSERT_EQ(a.depth.width(), 640);
    ASSERT_EQ(a.depth.height(), 480);
    // Same file pair: identical pixels.
    ASSERT_TRUE(std::equal(a.depth.begin(), a.depth.end(), b.depth.begin()));
    ASSERT_TRUE(a.color.at(100, 200) == b.color.at(100, 200));
    // Plausible metric depth for an indoor Kinect: median-ish check via the mean of valid pixels.
    const size_t valid = count_valid_depth(a.depth);
    ASSERT_GT(valid, a.depth.size() / 4) << a.name;
    double sum = 0;
    for (float z : a.depth) sum += z;
    const double mean = sum / valid;
    EXPECT_GT(mean, 0.3) << a.name;
    EXPECT_LT(mean, 5.0) << a.name;
    ASSERT_TRUE(a.T_world_cam_gt && b.T_world_cam_gt) << a.name;
    max_dR = std::max(
        max_dR, rotation_distance_rad(a.T_world_cam_gt->rotation(), b.T_world_cam_gt->rotation()));
    max_dt_m = std::max(max_dt_m,
                        (a.T_world_cam_gt->translation() - b.T_world_cam_gt->translation()).norm());
    ++n;
  }
  EXPECT_FALSE(native_stream.next(b));
  EXPECT_EQ(n, 500u);
  EXPECT_EQ(tum_stream.skipped(), 0u);
  EXPECT_EQ(native_stream.skipped(), 0u);
  EXPECT_LT(max_dt, 1e-5);
  // pose.txt rotations are orthonormal only to ~4e-4 (KinectFusion output); the quaternions of
  // groundtruth.txt and our SVD projection round them differently, by ~2e-5 rad.
  EXPECT_LT(max_dR, 1e-4);
  EXPECT_LT(max_dt_m, 1e-6);
  EXPECT_EQ(tum->ground_truth_trajectory().size(), 500u);
  EXPECT_EQ(native->ground_truth_trajectory().size(), 500u);
}

TEST(RealYcbVideo, AllModelPointSetsLoad) {
  ORPE_REQUIRE_DATA(data, "ycbv/models");
  DatasetParams p;
  p.last_frame = 0;
  auto reader = open_dataset(data + "/ycbv", p);
  const DatasetInfo& info = reader->info();
  ASSERT_EQ(info.model_points_paths.size(), 21u);
  EXPECT_EQ(info.model_mesh_paths.size(), 21u);
  for (const auto& [id, path] : info.model_points_paths) {
    const auto pts = read_model_points(path, info.model_units_per_m);
    // The YCB-Video evaluation point sets: 2,620 points for 002_master_chef_can, 2,621 for the
    // others.
    EXPECT_GE(pts.size(), 2620u) << path;
    EXPECT_LE(pts.size(), 2621u) << path;
    double extent = 0;
    for (const Vec3& x : pts) extent = std::max(extent, x.cwiseAbs().maxCoeff());
    EXPECT_GT(extent, 0.01) << path;  // metres, not millimetres
    EXPECT_LT(extent, 0.4) << path;
  }
}

/// Of the model points whose projection lies on the observed surface (within 1 cm of the measured
/// depth, so not occluded by something in front), how many land on the object's own label (1 px
/// tolerance: labels are rasterised, projections rounded). Returns (points on surface, on label).
std::pair<size_t, size_t> label_agreement(const RgbdFrame& f, size_t k, const SE3& T_cam_obj,
                                          const std::vector<Vec3>& points) {
  size_t visible = 0, on_label = 0;
  const int own = static_cast<int>(k) + 1;
  for (const Vec3& x : points) {
    const Vec3 p_cam = T_cam_obj * x;
    if (p_cam.z() <= 0) continue;
    const Eigen::Vector2d uv = f.intrinsics.project(p_cam);
    const int u = static_cast<int>(std::lround(uv.x())), v = static_cast<int>(std::lround(uv.y()));
    if (!f.depth.in_bounds(u, v)) continue;
    const float z_obs = f.depth.at(u, v);
    if (z_obs <= 0 || std::abs(p_cam.z() - z_obs) > 0.01) continue;
    ++visible;
    bool hit = false;
    for (int dv = -1; dv <= 1 && !hit; ++dv)
      for (int du = -1; du <= 1 && !hit; ++du)
        hit = f.labels_gt.in_bounds(u + du, v + dv) && f.labels_gt.at(u + du, v + dv) == own;
    on_label += hit;
  }
  return {visible, on_label};
}

TEST(RealYcbVideo, AllFramesLoadAndGroundTruthPosesProjectOntoTheirLabels) {
  ORPE_REQUIRE_DATA(data, "ycbv/data");
  const std::string root = data + "/ycbv";
  EXPECT_EQ(detect_dataset_format(root), "ycbv");
  std::map<int, std::vector<Vec3>> model_points;
  size_t frames = 0, objects = 0, objects_checked = 0;
  double worst_fraction = 1.0, true_sum = 0, shifted_sum = 0, max_world_drift_m = 0;
  std::string worst;
  for (const char* video : {"0000", "0001", "0002"}) {
    DatasetParams p;
    p.scene = video;
    auto reader = open_dataset(root, p);
    const DatasetInfo& info = reader->info();
    ASSERT_EQ(reader->size(), 20u) << video;
    EXPECT_EQ(info.scene_id, std::stoi(video));
    EXPECT_DOUBLE_EQ(info.depth_units_per_m, 10000.0);
    EXPECT_NEAR(info.intrinsics.fx, 1066.778, 1e-3);
    EXPECT_EQ(info.intrinsics.width, 640);
    ASSERT_EQ(info.class_names.size(), 21u);
    EXPECT_EQ(info.model_points_paths.size(), 21u);
    EXPECT_EQ(info.symmetric_classes.size(), 5u);
    EXPECT_EQ(reader->ground_truth_trajectory().size(), 20u);
    if (std::string(video) == "0001") test::expect_annotations_match_frames(*reader);
    std::map<int, SE3> first_world_pose;
    for (size_t i = 0; i < reader->size(); ++i) {
      const RgbdFrame f = reader->read(i);
      ++frames;
      ASSERT_EQ(f.depth.width(), 640);
      ASSERT_EQ(f.labels_gt.width(), 640);
      ASSERT_TRUE(f.T_world_cam_gt);
      ASSERT_FALSE(f.objects_gt.empty());
      if (i == 0 && std::string(video) == "0000") {  // README: gelatin_box, mug, foam_brick
        std::vector<int> classes;
        for (const auto& o : f.objects_gt) classes.push_back(o.class_id);
        EXPECT_EQ(classes, (std::vector<int>{8, 14, 21}));
      }
      for (size_t k = 0; k < f.objects_gt.size(); ++k) {
        const ObjectGroundTruth& o = f.objects_gt[k];
        ++objects;
        // Static scene: the object's world pose (T_world_cam from rotation_translation_matrix) must
        // not move between frames.
        const SE3 T_world_obj = *f.T_world_cam_gt * o.T_cam_obj;
        auto [first, inserted] = first_world_pose.emplace(o.class_id, T_world_obj);
        max_world_drift_m = std::max(
            max_world_drift_m, (first->second.translation() - T_world_obj.translation()).norm());
        auto it = model_points.find(o.class_id);
        if (it == model_points.end())
          it = model_points
                   .emplace(o.class_id, read_xyz_points(info.model_points_paths.at(o.class_id)))
                   .first;
        const auto [visible, on_label] = label_agreement(f, k, o.T_cam_obj, it->second);
        if (visible < 100) continue;  // hidden or nearly so: nothing to check
        ++objects_checked;
        const double fraction = static_cast<double>(on_label) / visible;
        if (fraction < worst_fraction) {
          worst_fraction = fraction;
          worst =
              fmt::format("{} class {} ({} of {} points)", f.name, o.class_id, on_label, visible);
        }
        // Control: the same check with the pose shifted 1.5 cm sideways must score clearly worse.
        const SE3 shifted(o.T_cam_obj.rotation(), o.T_cam_obj.translation() + Vec3(0.015, 0, 0));
        const auto [visible_shifted, on_label_shifted] = label_agreement(f, k, shifted, it->second);
        true_sum += fraction;
        shifted_sum +=
            visible_shifted ? static_cast<double>(on_label_shifted) / visible_shifted : 0.0;
      }
    }
  }
  EXPECT_EQ(frames, 60u);
  EXPECT_GT(objects_checked, objects / 2);
  EXPECT_GE(worst_fraction, 0.95) << worst;
  EXPECT_LT(shifted_sum, true_sum - 0.1 * objects_checked);
  EXPECT_LT(max_world_drift_m, 0.005);
  std::cout << "YCB label check: " << objects_checked << " of " << objects
            << " object instances checked, worst on-label fraction " << worst_fraction << " ("
            << worst << "); mean " << true_sum / objects_checked
            << ", with the pose shifted 1.5 cm " << shifted_sum / objects_checked
            << "; world drift of objects " << max_world_drift_m << " m\n";
}

}  // namespace
}  // namespace orpe
