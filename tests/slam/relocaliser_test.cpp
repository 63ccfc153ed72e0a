// The relocaliser's pieces (issue 19): the rigid fit it verifies candidates with, the candidates'
// verification in tracking rounds, and the parameters. The end-to-end behaviour (a gap of frames, a
// wrong place) is in tests/pipeline/relocalisation_test.cpp.
#include <gtest/gtest.h>

#include <functional>
#include <random>

#include "orpe/slam/relocaliser.h"

namespace orpe::slam {
namespace {

TEST(Relocaliser, FitRigidRecoversAKnownTransform) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 20; ++trial) {
    const SE3 T_a_b(so3_exp(Vec3(u(rng), u(rng), u(rng)) * 1.5), Vec3(u(rng), u(rng), u(rng)));
    std::vector<Vec3> a, b;
    for (int i = 0; i < 3 + trial; ++i) {
      b.emplace_back(u(rng), u(rng), 1 + u(rng));
      a.push_back(T_a_b * b.back());
    }
    const SE3 T = fit_rigid(a, b);
    EXPECT_LT((T.translation() - T_a_b.translation()).norm(), 1e-9);
    EXPECT_LT((T.rotation() - T_a_b.rotation()).norm(), 1e-9);
  }
}

TEST(Relocaliser, ParamsAreChecked) {
  RelocaliserParams p;
  std::string why;
  EXPECT_TRUE(p.IsValid(&why)) << why;
  p.min_inliers = 2;
  EXPECT_FALSE(p.IsValid(&why));
  EXPECT_NE(why.find("min_inliers"), std::string::npos);
  p = RelocaliserParams();
  p.match_ratio = 1.5;
  EXPECT_FALSE(p.IsValid(&why));
}

/// A stand-in for "render the map at T_world_ref and track the frame against it", for a camera at
/// `truth`: each round corrects 90 % of the reference's offset, and the alignment passes the gates
/// only from a reference within 2 cm of the camera (a view rendered farther off has occlusions the
/// camera does not see: the in-front gate). Counts its calls.
struct FakeTracking {
  SE3 truth;
  int calls = 0;
  double fraction_corrected = 0.9;
  AlignmentResult operator()(const SE3& T_world_ref) {
    ++calls;
    AlignmentResult a;
    const SE3 T_ref_true = T_world_ref.inverse() * truth;
    const Vec3 rho = T_ref_true.translation() * fraction_corrected;
    a.T_ref_cam = SE3(Mat3::Identity(), rho);
    if (T_ref_true.translation().norm() > 0.02) {
      a.weak = true;
      a.reason = "0.045 of the overlap lies in front of the map's surfaces";
    }
    return a;
  }
};

// A candidate 6 cm from the camera: the round from it is DEGRADED, the round from its estimate
// (0.6 cm off) is OK. With one round (verify_rounds = 1) the candidate is rejected.
TEST(Relocaliser, VerificationTracksAgainFromTheCorrectedPose) {
  const SE3 truth(so3_exp(Vec3(0.1, -0.2, 0.05)), Vec3(0.3, -0.1, 0.5));
  const SE3 guess = truth * SE3(Mat3::Identity(), Vec3(0.04, -0.03, 0.03));
  const TrackerParams gates;
  FakeTracking fake{truth};
  const TrackingVerification v = verify_by_tracking(guess, 3, gates, std::ref(fake));
  EXPECT_TRUE(v.ok()) << v.alignment.reason;
  EXPECT_EQ(v.rounds, 2);
  EXPECT_EQ(fake.calls, 2);
  EXPECT_LT((v.T_world_cam.translation() - truth.translation()).norm(), 0.001);

  FakeTracking once{truth};
  const TrackingVerification v1 = verify_by_tracking(guess, 1, gates, std::ref(once));
  EXPECT_FALSE(v1.ok());
  EXPECT_EQ(once.calls, 1);
}

// The verification does not search: a candidate that never passes is rejected after
// verify_rounds rounds; a round that does not move the pose ends it; so does an estimate beyond
// the tracker's jump limits of the candidate.
TEST(Relocaliser, VerificationStopsWithoutProgressAndAtTheJumpLimits) {
  const SE3 truth(so3_exp(Vec3(0.1, -0.2, 0.05)), Vec3(0.3, -0.1, 0.5));
  const TrackerParams gates;
  FakeTracking slow{truth};
  slow.fraction_corrected = 0.2;  // 20 cm -> 16 -> 12.8: never within 2 cm in 3 rounds
  const SE3 far = truth * SE3(Mat3::Identity(), Vec3(0.2, 0.0, 0.0));
  TrackingVerification v = verify_by_tracking(far, 3, gates, std::ref(slow));
  EXPECT_FALSE(v.ok());
  EXPECT_EQ(slow.calls, 3);

  FakeTracking stuck{truth};
  stuck.fraction_corrected = 0.0;  // the estimate stays at the reference
  v = verify_by_tracking(far, 5, gates, std::ref(stuck));
  EXPECT_FALSE(v.ok());
  EXPECT_EQ(stuck.calls, 1);

  FakeTracking jumpy{truth};  // 0.9 of a 40 cm offset: beyond max_translation_update_m (0.3 m)
  const SE3 very_far = truth * SE3(Mat3::Identity(), Vec3(0.4, 0.0, 0.0));
  v = verify_by_tracking(very_far, 5, gates, std::ref(jumpy));
  EXPECT_FALSE(v.ok());
  EXPECT_EQ(jumpy.calls, 1);
}

TEST(Relocaliser, NewParamsAreChecked) {
  RelocaliserParams p;
  std::string why;
  p.verify_rounds = 0;
  EXPECT_FALSE(p.IsValid(&why));
  EXPECT_NE(why.find("verify_rounds"), std::string::npos);
}

}  // namespace
}  // namespace orpe::slam
