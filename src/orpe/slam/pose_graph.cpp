#include "orpe/slam/pose_graph.h"

#include <Eigen/SparseCholesky>
#include <stdexcept>

namespace orpe::slam {
namespace {

double cost_of(const std::vector<SE3>& T, const std::vector<PoseGraphEdge>& edges,
               const Vec6& info) {
  double c = 0;
  for (const auto& e : edges) {
    const Vec6 r = (e.T_i_j.inverse() * T[e.i].inverse() * T[e.j]).log();
    c += e.weight * r.cwiseProduct(info).dot(r);
  }
  return c;
}

}  // namespace

PoseGraphResult optimise_pose_graph(std::vector<SE3>& T, const std::vector<PoseGraphEdge>& edges,
                                    const PoseGraphOptions& o) {
  const int n = static_cast<int>(T.size());
  for (const auto& e : edges)
    if (e.i < 0 || e.j < 0 || e.i >= n || e.j >= n || e.i == e.j)
      throw std::invalid_argument("optimise_pose_graph: edge with a bad node index");
  Vec6 info;
  const double it2 = 1.0 / (o.sigma_translation_m * o.sigma_translation_m);
  const double ir2 = 1.0 / (o.sigma_rotation_rad * o.sigma_rotation_rad);
  info << it2, it2, it2, ir2, ir2, ir2;
  PoseGraphResult res;
  res.initial_cost = res.final_cost = cost_of(T, edges, info);
  if (n < 2 || edges.empty()) return res;
  const int m = 6 * (n - 1);  // node 0 fixed
  for (int it = 0; it < o.iterations; ++it) {
    std::vector<Eigen::Triplet<double>> trip;
    trip.reserve(edges.size() * 4 * 36);
    Eigen::VectorXd g = Eigen::VectorXd::Zero(m);
    for (const auto& e : edges) {
      const Vec6 r = (e.T_i_j.inverse() * T[e.i].inverse() * T[e.j]).log();
      const Mat6 A = T[e.j].inverse().adjoint();  // de/dd_j = A, de/dd_i = -A
      const Mat6 W = (e.weight * info).asDiagonal();
      const Mat6 H = A.transpose() * W * A;
      const Vec6 b = A.transpose() * W * r;
      const int bi = 6 * (e.i - 1), bj = 6 * (e.j - 1);
      auto add = [&](int r0, int c0, const Mat6& M) {
        for (int a = 0; a < 6; ++a)
          for (int c = 0; c < 6; ++c) trip.emplace_back(r0 + a, c0 + c, M(a, c));
      };
      if (e.i > 0) add(bi, bi, H), g.segment<6>(bi) -= b;
      if (e.j > 0) add(bj, bj, H), g.segment<6>(bj) += b;
      if (e.i > 0 && e.j > 0) add(bi, bj, -H), add(bj, bi, -H);
    }
    Eigen::SparseMatrix<double> Hs(m, m);
    Hs.setFromTriplets(trip.begin(), trip.end());
    for (int k = 0; k < m; ++k) Hs.coeffRef(k, k) += 1e-9;  // nodes that no edge constrains
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(Hs);
    if (solver.info() != Eigen::Success) break;
    const Eigen::VectorXd d = solver.solve(-g);
    if (solver.info() != Eigen::Success || !d.allFinite()) break;
    for (int k = 1; k < n; ++k) T[k] = SE3::exp(d.segment<6>(6 * (k - 1))) * T[k];
    res.iterations = it + 1;
    if (d.cwiseAbs().maxCoeff() < o.stop_step) break;
  }
  res.final_cost = cost_of(T, edges, info);
  return res;
}

}  // namespace orpe::slam
