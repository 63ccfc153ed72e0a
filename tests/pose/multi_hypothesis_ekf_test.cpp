// MultiHypothesisPoseEkf: a wrong first mode overtaken by interleaved right views, no flipping
// between two equally supported modes, a bounded number of hypotheses, and M = 1 = PoseEkf.
#include <gtest/gtest.h>

#include <random>

#include "orpe/core/error.h"
#include "orpe/pose/multi_hypothesis_ekf.h"

namespace orpe {
namespace {

SE3 rot_z(double deg, const Vec3& t = Vec3::Zero()) {
  return SE3(so3_exp(Vec3(0, 0, deg * M_PI / 180.0)), t);
}

PoseMeasurement meas(const SE3& T_world_obj, double mu, int frame) {
  PoseMeasurement m;
  m.frame_index = frame;
  m.T_world_cam = SE3();
  m.T_cam_obj = T_world_obj;
  m.mu_m = mu;
  return m;
}

/// T * Exp(noise) with small rotation / translation noise (well inside the gate).
SE3 jitter(const SE3& T, std::mt19937& rng, double sigma_rad = 0.005, double sigma_m = 0.001) {
  std::normal_distribution<double> n(0, 1);
  Vec6 xi;
  for (int k = 0; k < 3; ++k) xi(k) = sigma_m * n(rng);
  for (int k = 3; k < 6; ++k) xi(k) = sigma_rad * n(rng);
  return T * SE3::exp(xi);
}

PoseEkfParams multi(int m = 3, double decay = 0.8, double margin = 1.0) {
  PoseEkfParams p;
  p.hypotheses = m;
  p.hypothesis_evidence_decay = decay;
  p.hypothesis_switch_margin = margin;
  return p;
}

const SE3 kTruth = rot_z(0, Vec3(0.3, 0.1, 0.9));
const SE3 kWrong = rot_z(75, Vec3(0.3, 0.1, 0.9));  // a mug turned about its axis

TEST(MultiHypothesisEkf, InterleavedRightViewsOvertakeAWrongStart) {
  // The YCB mug's pattern: 5 views in a wrong mode, then the right mode in most of the later views
  // but interleaved with wrong ones, so there are never 5 consecutive right views.
  std::vector<bool> right;
  for (int i = 0; i < 5; ++i) right.push_back(false);
  for (int i = 0; i < 15; ++i) right.push_back(i % 5 != 1 && i % 5 != 3);  // 9 right, 6 wrong
  std::mt19937 rng(3);
  std::vector<PoseMeasurement> ms;
  for (size_t i = 0; i < right.size(); ++i)
    ms.push_back(meas(jitter(right[i] ? kTruth : kWrong, rng), 0.002, static_cast<int>(i)));

  PoseEkf single;  // the paper's filter with its consecutive-rejection restart: stuck
  for (const auto& m : ms) single.update(m);
  EXPECT_GT(rotation_distance_rad(single.T_world_obj().rotation(), kTruth.rotation()), 1.0);

  MultiHypothesisPoseEkf mh(multi());
  for (const auto& m : ms) {
    mh.predict();
    mh.update(m);
  }
  EXPECT_LT(rotation_distance_rad(mh.T_world_obj().rotation(), kTruth.rotation()), 0.02);
  EXPECT_LT((mh.T_world_obj().translation() - kTruth.translation()).norm(), 0.005);
  EXPECT_EQ(mh.num_fused(), 9);
  EXPECT_EQ(mh.num_hypotheses(), 2);
  EXPECT_EQ(mh.result().num_reinitialisations, 1);
}

TEST(MultiHypothesisEkf, EquallySupportedModesDoNotFlipTheReport) {
  // A pudding box whose two near-identical poses alternate: the report keeps the first mode.
  for (double decay : {0.5, 0.8, 1.0}) {
    MultiHypothesisPoseEkf mh(multi(3, decay));
    std::mt19937 rng(7);
    int switches = 0;
    for (int i = 0; i < 30; ++i) {
      mh.predict();
      const PoseEkfStep s = mh.update(meas(jitter(i % 2 ? kWrong : kTruth, rng), 0.002, i));
      switches += s.reinitialised;
    }
    EXPECT_EQ(switches, 0) << "decay " << decay;
    EXPECT_LT(rotation_distance_rad(mh.T_world_obj().rotation(), kTruth.rotation()), 0.02)
        << "decay " << decay;
  }
  // Without hysteresis the same sequence flips (the test above can fail).
  MultiHypothesisPoseEkf flippy(multi(3, 0.8, 0.0));
  std::mt19937 rng(7);
  int switches = 0;
  for (int i = 0; i < 30; ++i) {
    flippy.predict();
    switches += flippy.update(meas(jitter(i % 2 ? kWrong : kTruth, rng), 0.002, i)).reinitialised;
  }
  EXPECT_GT(switches, 10);
}

TEST(MultiHypothesisEkf, HypothesisCountIsBoundedAndTheReportedOneSurvives) {
  MultiHypothesisPoseEkf mh(multi(3));
  std::mt19937 rng(11);
  for (int i = 0; i < 6; ++i) mh.update(meas(jitter(kTruth, rng), 0.002, i));
  // Outliers in 11 different modes, 30 degrees apart (outside each other's gate): each starts a
  // hypothesis, at most 3 live at once.
  for (int i = 0; i < 11; ++i) {
    mh.predict();
    mh.update(meas(rot_z(20.0 + 30.0 * i, kTruth.translation()), 0.002, 6 + i));
    EXPECT_LE(mh.num_hypotheses(), 3);
  }
  EXPECT_EQ(mh.num_hypotheses(), 3);
  EXPECT_LT(rotation_distance_rad(mh.T_world_obj().rotation(), kTruth.rotation()), 0.02);
  EXPECT_EQ(mh.result().num_rejected, 11);
  EXPECT_EQ(mh.num_fused(), 6);
}

TEST(MultiHypothesisEkf, DuplicateHypothesesOfOneModeMerge) {
  // Two measurements 7 degrees apart with a tight R start two hypotheses; views in between
  // pull both towards the mode until they pass each other's gate and merge into one.
  MultiHypothesisPoseEkf mh(multi(3, 1.0));
  mh.update(meas(rot_z(-7, kTruth.translation()), 0.0005, 0));
  mh.update(meas(rot_z(7, kTruth.translation()), 0.0005, 1));
  EXPECT_EQ(mh.num_hypotheses(), 2);
  std::mt19937 rng(2);
  for (int i = 0; i < 8; ++i) mh.update(meas(jitter(kTruth, rng, 0.002), 0.002, 2 + i));
  EXPECT_EQ(mh.num_hypotheses(), 1);
  // Pulled from its +-7 degree start towards the mode (the start's tight R still weighs).
  EXPECT_LT(rotation_distance_rad(mh.T_world_obj().rotation(), kTruth.rotation()), 0.06);
}

TEST(MultiHypothesisEkf, OneHypothesisIsThePoseEkf) {
  // M = 1: the same states, steps and restarts as PoseEkf (restart after 4 consistent rejections).
  PoseEkfParams p;
  p.hypotheses = 1;
  p.reinit_after_rejections = 4;
  PoseEkf ekf(p);
  MultiHypothesisPoseEkf mh(p);
  std::mt19937 rng(5);
  for (int i = 0; i < 14; ++i) {
    const PoseMeasurement m = meas(jitter(i < 3 ? kWrong : kTruth, rng), 0.002, i);
    ekf.predict();
    mh.predict();
    const PoseEkfStep a = ekf.update(m);
    const PoseEkfStep b = mh.update(m, 0.5);
    EXPECT_EQ(a.accepted, b.accepted) << i;
    EXPECT_EQ(a.reinitialised, b.reinitialised) << i;
    EXPECT_LT((ekf.T_world_obj().matrix() - mh.T_world_obj().matrix()).norm(), 1e-15) << i;
  }
  EXPECT_EQ(ekf.result().num_reinitialisations, 1);
  EXPECT_EQ(mh.result().num_reinitialisations, 1);
  EXPECT_EQ(mh.num_fused(), ekf.num_fused() - 3) << "views counted since the restart's completion";
  EXPECT_NEAR(mh.mean_score(), 0.5, 1e-12);
}

TEST(MultiHypothesisEkf, InvalidParamsThrow) {
  PoseEkfParams p = multi(0);
  EXPECT_THROW(MultiHypothesisPoseEkf{p}, ConfigError);
  p = multi(3, 0.0);
  EXPECT_THROW(MultiHypothesisPoseEkf{p}, ConfigError);
  p = multi(3, 0.8, -1);
  EXPECT_THROW(MultiHypothesisPoseEkf{p}, ConfigError);
  p = multi(3);
  p.gate_chi2 = 0;
  EXPECT_THROW(MultiHypothesisPoseEkf{p}, ConfigError);
}

}  // namespace
}  // namespace orpe

namespace orpe {
namespace {

TEST(MultiHypothesisEkf, ColourConfirmedViewsWinTheCompetitionOfModes) {
  // A box flipped by geometry in every other view (equal support: the first, wrong, mode stays
  // reported); the right views carry colour evidence (a colour lead of 0.25 at gain 4 = weight 2).
  auto run = [](double gain) {
    PoseEkfParams p = multi(3, 0.8);
    p.colour_evidence_gain = gain;
    MultiHypothesisPoseEkf mh(p);
    std::mt19937 rng(11);
    for (int i = 0; i < 20; ++i) {
      const bool right = i % 2 == 1;
      PoseMeasurement m = meas(jitter(right ? kTruth : kWrong, rng), 0.002, i);
      if (right) m.mode_weight = mode_weight_from_colour(0.25, p.colour_evidence_gain);
      mh.predict();
      mh.update(m);
    }
    return rotation_distance_rad(mh.T_world_obj().rotation(), kTruth.rotation());
  };
  EXPECT_LT(run(4.0), 0.02);  // colour decides
  EXPECT_GT(run(0.0), 1.0);   // colour ignored: the first mode is kept
  EXPECT_DOUBLE_EQ(mode_weight_from_colour(-0.3, 4.0), 1.0);  // a negative lead is no evidence
}

}  // namespace
}  // namespace orpe
