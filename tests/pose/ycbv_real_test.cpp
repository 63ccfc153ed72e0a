// The model-based estimator and the EKF on real YCB-Video frames with ground-truth masks (skipped
// without the shared data). The full figures are in docs/RESULTS.md (bench/pose_ycbv.cpp).
#include <gtest/gtest.h>

#include "orpe/core/frame_masks.h"
#include "orpe/eval/pose_metrics.h"
#include "orpe/io/dataset.h"
#include "orpe/pose/model_registration.h"
#include "orpe/pose/pose_ekf.h"
#include "support/test_data.h"

namespace orpe {
namespace {

TEST(YcbvRealPose, EveryObjectOfOneFramePerVideoWithinOneCentimetreAdds) {
  ORPE_REQUIRE_DATA(data, "ycbv/data/0002/000001-meta.mat");
  const ModelRegistrationEstimator estimator;
  int objects = 0;
  for (const std::string video : {"0000", "0001", "0002"}) {
    DatasetParams dp;
    dp.format = "ycbv";
    dp.scene = video;
    dp.first_frame = 10;
    dp.last_frame = 10;
    const auto reader = open_dataset(data + "/ycbv", dp);
    ASSERT_EQ(reader->size(), 1u);
    const RgbdFrame frame = reader->read(0);
    ASSERT_FALSE(frame.labels_gt.empty());
    for (size_t k = 0; k < frame.objects_gt.size(); ++k) {
      const ObjectGroundTruth& gt = frame.objects_gt[k];
      const DatasetInfo& info = reader->info();
      ModelLoadOptions mo;
      mo.mesh_path = info.model_mesh_paths.at(gt.class_id);
      const ObjectModel model =
          load_object_model(info.model_points_paths.at(gt.class_id), mo, gt.class_id);
      std::vector<Vec3> pts;
      for (const auto& p : model.points) pts.push_back(p.cast<double>());
      const ModelPoints eval(pts);
      const MaskImage mask = ground_truth_mask(frame, k);
      SingleViewInput in;
      in.mask = &mask;
      in.depth = &frame.depth;
      in.color = &frame.color;
      in.intrinsics = frame.intrinsics;
      in.class_id = gt.class_id;
      in.model = &model;
      const SingleViewPose est = estimator.estimate(in);
      ASSERT_TRUE(est.valid) << frame.name << " class " << gt.class_id << ": " << est.reason;
      const double adds = adds_distance(eval, gt.T_cam_obj, est.T_cam_obj);
      EXPECT_LT(adds, 0.01) << frame.name << " " << info.class_names.at(gt.class_id) << ": "
                            << est.report();
      EXPECT_GT(est.mu_m, 0.0005);
      EXPECT_LT(est.mu_m, 0.006);
      ++objects;
    }
  }
  EXPECT_EQ(objects, 13);
}

TEST(YcbvRealPose, EkfOverFramesStaysOnTheObject) {
  ORPE_REQUIRE_DATA(data, "ycbv/data/0001/000001-meta.mat");
  DatasetParams dp;
  dp.format = "ycbv";
  dp.scene = "0001";
  dp.stride = 4;  // 5 frames
  const auto reader = open_dataset(data + "/ycbv", dp);
  const DatasetInfo& info = reader->info();
  const ModelRegistrationEstimator estimator;
  const int cls = 1;  // 002_master_chef_can: a can, continuous symmetry
  ModelLoadOptions mo;
  mo.mesh_path = info.model_mesh_paths.at(cls);
  const ObjectModel model = load_object_model(info.model_points_paths.at(cls), mo, cls);
  ASSERT_EQ(model.symmetry.kind(), SymmetryKind::kContinuous);
  std::vector<Vec3> pts;
  for (const auto& p : model.points) pts.push_back(p.cast<double>());
  const ModelPoints eval(pts);
  PoseEkf ekf({}, model.symmetry);
  for (size_t i = 0; i < reader->size(); ++i) {
    const RgbdFrame frame = reader->read(i);
    ASSERT_TRUE(frame.T_world_cam_gt.has_value());
    int label = 0;
    for (size_t k = 0; k < frame.objects_gt.size(); ++k)
      if (frame.objects_gt[k].class_id == cls) label = static_cast<int>(k) + 1;
    ASSERT_GT(label, 0);
    MaskImage mask(frame.labels_gt.width(), frame.labels_gt.height(), 0);
    for (size_t j = 0; j < mask.size(); ++j) mask[j] = frame.labels_gt[j] == label;
    SingleViewInput in;
    in.mask = &mask;
    in.depth = &frame.depth;
    in.intrinsics = frame.intrinsics;
    in.model = &model;
    const SingleViewPose est = estimator.estimate(in);
    ASSERT_TRUE(est.valid) << est.reason;
    const PoseEkfStep step =
        ekf.update({frame.index, *frame.T_world_cam_gt, est.T_cam_obj, est.mu_m});
    EXPECT_TRUE(step.accepted) << "frame " << frame.index << " d2 " << step.mahalanobis_sq;
    const SE3& gt = frame.objects_gt[static_cast<size_t>(label - 1)].T_cam_obj;
    EXPECT_LT(adds_distance(eval, gt, step.T_cam_obj_fused), 0.01) << "frame " << frame.index;
  }
  EXPECT_EQ(ekf.result().num_fused, static_cast<int>(reader->size()));
}

}  // namespace
}  // namespace orpe
