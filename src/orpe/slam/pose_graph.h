// A pose graph over keyframe poses (loop closure, issue 19): nodes T_world_node, edges with a
// measured relative pose Z_ij ~ T_i^-1 T_j and an information weight, optimised by Gauss-Newton on
// SE(3) (Eigen's sparse Cholesky), with the first node held fixed (the world frame stays put).
//
// Residual of edge (i, j): e_ij = log(Z_ij^-1 T_i^-1 T_j) in [rho; phi] (m, rad). Update: the
// left perturbation T <- exp(d) T of the tracker; to first order
//   e_ij(d) = e_ij + Ad(T_j^-1) (d_j - d_i)
// (the right Jacobian J_r^-1(e) is taken as the identity: the residuals are a few cm / degrees, and
// each iteration relinearises). Cost: sum_ij e_ij^T W_ij e_ij with W_ij = w_ij diag(1/s_t^2 x3,
// 1/s_r^2 x3).
#pragma once

#include <vector>

#include "orpe/core/se3.h"

namespace orpe::slam {

struct PoseGraphEdge {
  int i = 0, j = 0;     ///< node indices
  SE3 T_i_j;            ///< measured T_i^-1 T_j
  double weight = 1.0;  ///< scales the information (loop edges vs odometry)
};

struct PoseGraphOptions {
  int iterations = 20;
  double sigma_translation_m = 0.01;  ///< s_t: per-edge translation uncertainty (m)
  double sigma_rotation_rad = 0.01;   ///< s_r: per-edge rotation uncertainty (rad)
  double stop_step = 1e-7;            ///< stop when the largest update component is below this
};

struct PoseGraphResult {
  int iterations = 0;
  double initial_cost = 0, final_cost = 0;
};

/// Optimises `T_world_node` in place (node 0 fixed). Edges with indices out of range throw
/// std::invalid_argument.
PoseGraphResult optimise_pose_graph(std::vector<SE3>& T_world_node,
                                    const std::vector<PoseGraphEdge>& edges,
                                    const PoseGraphOptions& options = {});

}  // namespace orpe::slam
