// Pose graph optimisation (slam/pose_graph.h), the correction step of loop closure (issue 19).
#include "orpe/slam/pose_graph.h"

#include <gtest/gtest.h>

#include "orpe/pipeline/object_fusion.h"

#include <cmath>
#include <vector>

namespace orpe::slam {
namespace {

// A square loop of 40 poses; odometry measured with a small rotation bias (drift), so the chain
// ends away from its start. A loop edge (last -> first = the true relative pose) pulls it back.
struct Loop {
  std::vector<SE3> truth, drifted;
  std::vector<PoseGraphEdge> odometry;
};

Loop make_loop() {
  Loop L;
  const int n = 40;
  for (int k = 0; k < n; ++k) {
    const double a = 2 * M_PI * k / n;
    L.truth.push_back(SE3(so3_exp(Vec3(0, 0, a)), Vec3(2 * std::cos(a), 2 * std::sin(a), 0)));
  }
  const SE3 bias(so3_exp(Vec3(0.002, -0.001, 0.004)), Vec3(0.003, 0, 0));
  L.drifted.push_back(L.truth[0]);
  for (int k = 1; k < n; ++k) {
    const SE3 Z = L.truth[k - 1].inverse() * L.truth[k] * bias;
    L.odometry.push_back({k - 1, k, Z, 1.0});
    L.drifted.push_back(L.drifted.back() * Z);
  }
  return L;
}

double max_error_m(const std::vector<SE3>& a, const std::vector<SE3>& b) {
  double e = 0;
  for (size_t k = 0; k < a.size(); ++k)
    e = std::max(e, (a[k].translation() - b[k].translation()).norm());
  return e;
}

TEST(PoseGraph, ALoopEdgeRemovesMostOfTheDrift) {
  Loop L = make_loop();
  const double drift = max_error_m(L.drifted, L.truth);
  ASSERT_GT(drift, 0.1);
  // Odometry alone: already consistent, nothing moves.
  std::vector<SE3> only_odo = L.drifted;
  const PoseGraphResult r0 = optimise_pose_graph(only_odo, L.odometry);
  EXPECT_LT(r0.final_cost, 1e-9);
  EXPECT_LT(max_error_m(only_odo, L.drifted), 1e-9);
  // With the loop edge: the end comes back to the start, the whole chain nearer the truth.
  std::vector<PoseGraphEdge> edges = L.odometry;
  const int last = static_cast<int>(L.truth.size()) - 1;
  edges.push_back({0, last, L.truth[0].inverse() * L.truth[last], 1.0});
  std::vector<SE3> T = L.drifted;
  const PoseGraphResult r = optimise_pose_graph(T, edges);
  EXPECT_LT(r.final_cost, 0.01 * r.initial_cost);
  EXPECT_LT(max_error_m(T, L.truth), 0.25 * drift);
  EXPECT_LT((T[last].translation() - L.truth[last].translation()).norm(), 0.02);
  EXPECT_LT(max_error_m({T[0]}, {L.truth[0]}), 1e-12);  // node 0 is fixed
}

TEST(PoseGraph, BadEdgesAreRejected) {
  std::vector<SE3> T(3);
  EXPECT_THROW(optimise_pose_graph(T, {{0, 3, SE3(), 1.0}}), std::invalid_argument);
  EXPECT_THROW(optimise_pose_graph(T, {{1, 1, SE3(), 1.0}}), std::invalid_argument);
}

// What the pipeline does to an object after a loop closure: its world state follows the correction
// C of the frame that saw it, so its pose relative to that frame's corrected camera is unchanged.
TEST(LoopCorrection, AnObjectStateKeepsItsPoseRelativeToTheCorrectedCamera) {
  ObjectPoseFusion fusion(PoseEkfParams{}, ObjectSymmetry{}, 1);
  PoseMeasurement m;
  m.T_world_cam = SE3(so3_exp(Vec3(0.3, -0.2, 1.0)), Vec3(1.0, 0.5, 1.2));
  m.T_cam_obj = SE3(so3_exp(Vec3(0.1, 0.2, 0.3)), Vec3(0.1, -0.05, 1.0));
  m.mu_m = 0.005;
  fusion.add(m, 1.0);
  fusion.flush();
  ASSERT_TRUE(fusion.has_estimate());
  const SE3 C(so3_exp(Vec3(0.0, 0.0, 0.03)), Vec3(0.05, -0.02, 0.01));
  const SE3 corrected_cam = C * m.T_world_cam;
  const SE3 uncorrected = fusion.T_cam_obj(corrected_cam);
  EXPECT_GT((uncorrected.translation() - m.T_cam_obj.translation()).norm(), 0.01)
      << "without the correction the object is off in the corrected camera";
  fusion.apply_world_correction(C);
  const SE3 rel = fusion.T_cam_obj(corrected_cam);
  EXPECT_LT((rel.translation() - m.T_cam_obj.translation()).norm(), 1e-6);
  EXPECT_LT(rotation_distance_rad(rel.rotation(), m.T_cam_obj.rotation()), 1e-6);
}

}  // namespace
}  // namespace orpe::slam
