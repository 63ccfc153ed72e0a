// ObjectPoseFusion: consensus initialisation against a wrong first measurement; with several
// hypotheses, recovery from a wrong consensus (the YCB mug's pattern).
#include <gtest/gtest.h>

#include <random>

#include "orpe/pipeline/object_fusion.h"

namespace orpe {
namespace {

PoseMeasurement measure(int frame, const SE3& T_world_obj, const SE3& T_world_cam,
                        const Vec6& noise) {
  PoseMeasurement m;
  m.frame_index = frame;
  m.T_world_cam = T_world_cam;
  m.T_cam_obj = T_world_cam.inverse() * T_world_obj * SE3::exp(noise);
  m.mu_m = 0.003;
  return m;
}

/// Gaussian se(3) noise: translation sigma (m) in the first three entries, rotation sigma (rad) in
/// the rest.
Vec6 pose_noise(std::mt19937& rng, double translation_sigma_m, double rotation_sigma_rad) {
  std::normal_distribution<double> n(0, 1);
  Vec6 noise;
  for (int i = 0; i < 3; ++i) noise[i] = translation_sigma_m * n(rng);
  for (int i = 3; i < 6; ++i) noise[i] = rotation_sigma_rad * n(rng);
  return noise;
}

struct Outcome {
  double translation_error_m, rotation_error_rad;
  int accepted, rejected;
};

Outcome run(int init_views, bool flipped_first, int hypotheses = PoseEkfParams{}.hypotheses) {
  const SE3 truth(so3_exp(Vec3(0.3, -0.2, 0.1)), Vec3(0.2, 0.1, 0.9));
  PoseEkfParams params;
  params.hypotheses = hypotheses;
  ObjectPoseFusion fusion(params, ObjectSymmetry{}, init_views);
  std::mt19937 rng(4);
  for (int f = 0; f < 12; ++f) {
    const SE3 cam(so3_exp(Vec3(0, 0.02 * f, 0)), Vec3(0.01 * f, 0, 0));
    Vec6 noise = pose_noise(rng, 0.004, 0.02);
    if (f == 0 && flipped_first) noise.tail<3>() = Vec3(M_PI, 0, 0);  // end over end
    // Later outliers scatter (no two agree), so PoseEkf's restart cannot fire.
    if (f % 4 == 3) noise.tail<3>() = Vec3(0, 0.5 + 0.3 * f, 0);
    fusion.add(measure(f, truth, cam, noise), 0.8);
  }
  EXPECT_TRUE(fusion.has_estimate());
  return {(fusion.T_world_obj().translation() - truth.translation()).norm(),
          rotation_distance_rad(fusion.T_world_obj().rotation(), truth.rotation()),
          fusion.accepted(), fusion.rejected()};
}

TEST(ObjectFusion, ConsensusInitialisationIgnoresAWrongFirstMeasurement) {
  const Outcome first = run(1, true, /*hypotheses=*/1);
  EXPECT_GT(first.rotation_error_rad, 2.0) << "started from the flip, one filter keeps it";
  const Outcome first_default = run(1, true);
  EXPECT_LT(first_default.rotation_error_rad, 0.05)
      << "started from the flip, the default's competing hypotheses move to the right mode";
  const Outcome consensus = run(3, true);
  EXPECT_LT(consensus.rotation_error_rad, 0.05);
  EXPECT_LT(consensus.translation_error_m, 0.01);
  EXPECT_GE(consensus.rejected, 3) << "the flip and the scattered outliers";
  EXPECT_GE(consensus.accepted, 7);
}

TEST(ObjectFusion, WithoutOutliersBothStartsAgree) {
  const Outcome a = run(1, false);
  const Outcome b = run(3, false);
  EXPECT_LT(a.rotation_error_rad, 0.05);
  EXPECT_LT(b.rotation_error_rad, 0.05);
  EXPECT_LT(a.translation_error_m, 0.01);
  EXPECT_NEAR(a.translation_error_m, b.translation_error_m, 0.005);
}

TEST(ObjectFusion, NoEstimateWhileCollectingInitialViews) {
  ObjectPoseFusion fusion(PoseEkfParams{}, ObjectSymmetry{}, 3);
  const SE3 truth(Mat3::Identity(), Vec3(0, 0, 1));
  EXPECT_TRUE(fusion.add(measure(0, truth, SE3(), Vec6::Zero()), 0.5).accepted);
  EXPECT_FALSE(fusion.has_estimate());
  fusion.add(measure(1, truth, SE3(), Vec6::Zero()), 0.5);
  EXPECT_FALSE(fusion.has_estimate());
  EXPECT_TRUE(fusion.add(measure(2, truth, SE3(), Vec6::Zero()), 0.5).initialised);
  EXPECT_TRUE(fusion.has_estimate());
  EXPECT_NEAR(fusion.score(), 0.5, 1e-12);
  EXPECT_EQ(fusion.accepted(), 3);

  // An object seen fewer times than init_views gets its estimate at the end of the sequence.
  ObjectPoseFusion few(PoseEkfParams{}, ObjectSymmetry{}, 5);
  few.flush();
  EXPECT_FALSE(few.has_estimate()) << "nothing to start from";
  few.add(measure(0, truth, SE3(), Vec6::Zero()), 0.5);
  few.add(measure(1, truth, SE3(), Vec6::Zero()), 0.5);
  EXPECT_FALSE(few.has_estimate());
  few.flush();
  ASSERT_TRUE(few.has_estimate());
  EXPECT_NEAR((few.T_world_obj().translation() - truth.translation()).norm(), 0, 1e-9);
  EXPECT_EQ(few.accepted(), 2);
}

TEST(ObjectFusion, AMajorityOfTheStartsViewsStartsTheFilterEarly) {
  // init_views 5, majority 3: a flipped view and two agreeing ones are no majority yet; the third
  // agreeing view is, and the filter starts there, in the agreeing mode, without views 5 and 6.
  // Only when every view so far was decisive (its estimator told the modes apart).
  const SE3 truth(so3_exp(Vec3(0.3, -0.2, 0.1)), Vec3(0.2, 0.1, 0.9));
  auto views_to_start = [&](bool majority_stop, bool flipped_second, bool decisive = true) {
    ObjectPoseFusion fusion(PoseEkfParams{}, ObjectSymmetry{}, 5, majority_stop);
    std::mt19937 rng(5);
    for (int f = 0; f < 8; ++f) {
      const SE3 cam(so3_exp(Vec3(0, 0.02 * f, 0)), Vec3(0.01 * f, 0, 0));
      Vec6 noise = pose_noise(rng, 0.002, 0.01);
      if (f == 1 && flipped_second) noise.tail<3>() = Vec3(M_PI, 0, 0);
      if (fusion.add(measure(f, truth, cam, noise), 0.8, decisive || f != 2).initialised) {
        EXPECT_LT(rotation_distance_rad(fusion.T_world_obj().rotation(), truth.rotation()), 0.05);
        EXPECT_EQ(fusion.accepted(), f + 1 - (flipped_second ? 1 : 0));
        return f + 1;
      }
      EXPECT_FALSE(fusion.has_estimate());
    }
    return -1;
  };
  EXPECT_EQ(views_to_start(true, false), 3) << "three agreeing views of five";
  EXPECT_EQ(views_to_start(true, true), 4) << "the flip is no part of the majority";
  EXPECT_EQ(views_to_start(false, false), 5) << "without the stop: all five views";
  EXPECT_EQ(views_to_start(false, true), 5);
  EXPECT_EQ(views_to_start(true, false, /*decisive=*/false), 5)
      << "one view that could not tell the modes apart: all five views vote";

  // Three mutually disagreeing views (each turned elsewhere) are no majority: keep collecting.
  ObjectPoseFusion scatter(PoseEkfParams{}, ObjectSymmetry{}, 5, true);
  for (int f = 0; f < 3; ++f) {
    const Vec6 noise = (Vec6() << 0, 0, 0, 0, 0, 0.8 * f).finished();
    scatter.add(measure(f, truth, SE3(), noise), 0.8);
  }
  EXPECT_FALSE(scatter.has_estimate());
}

TEST(ObjectFusion, HypothesesRecoverFromAWrongConsensusStart) {
  // All of the first 5 views in a wrong mode (turned 75 degrees about the axis), then the right
  // mode in 3 of every 5 views, interleaved: the consensus starts wrong and one filter stays wrong;
  // with 3 hypotheses the report moves to the right mode once it leads, and the score and counts
  // are those of the reported hypothesis.
  const SE3 truth(so3_exp(Vec3(0.3, -0.2, 0.1)), Vec3(0.2, 0.1, 0.9));
  const SE3 wrong = truth * SE3(so3_exp(Vec3(0, 0, 75 * M_PI / 180)), Vec3::Zero());
  auto run_with = [&](int hypotheses) {
    PoseEkfParams p;
    p.hypotheses = hypotheses;
    p.hypothesis_evidence_decay = 0.95;
    ObjectPoseFusion fusion(p, ObjectSymmetry{}, 5);
    std::mt19937 rng(9);
    for (int f = 0; f < 25; ++f) {
      const SE3 cam(so3_exp(Vec3(0, 0.01 * f, 0)), Vec3(0.005 * f, 0, 0));
      const Vec6 noise = pose_noise(rng, 0.002, 0.01);
      const bool right = f >= 5 && f % 5 != 1 && f % 5 != 3;
      fusion.add(measure(f, right ? truth : wrong, cam, noise), right ? 0.9 : 0.6);
    }
    return rotation_distance_rad(fusion.T_world_obj().rotation(), truth.rotation());
  };
  EXPECT_GT(run_with(1), 1.0) << "one filter keeps the wrong consensus";
  EXPECT_LT(run_with(3), 0.03);

  PoseEkfParams p;
  p.hypotheses = 3;
  ObjectPoseFusion fusion(p, ObjectSymmetry{}, 1);
  for (int f = 0; f < 3; ++f) fusion.add(measure(f, wrong, SE3(), Vec6::Zero()), 0.2);
  for (int f = 3; f < 9; ++f) fusion.add(measure(f, truth, SE3(), Vec6::Zero()), 0.8);
  EXPECT_LT(rotation_distance_rad(fusion.T_world_obj().rotation(), truth.rotation()), 1e-6);
  EXPECT_EQ(fusion.accepted(), 6);
  EXPECT_NEAR(fusion.score(), 0.8, 1e-12);
  EXPECT_EQ(fusion.result().num_reinitialisations, 1);
}

}  // namespace
}  // namespace orpe
