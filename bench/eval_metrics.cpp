// Cost of the evaluation metrics: ADD, ADD-S (kd-tree vs brute force) on a YCB-sized model
// (2,620 points, as points.xyz), the VOCap AUC, and ATE/RPE on a long trajectory.
#include <benchmark/benchmark.h>

#include <random>

#include "orpe/eval/pose_metrics.h"
#include "orpe/eval/trajectory_metrics.h"

namespace {

std::vector<orpe::Vec3> model_points(int n) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-0.05, 0.05);
  std::vector<orpe::Vec3> p;
  for (int i = 0; i < n; ++i) p.emplace_back(u(rng), u(rng), 1.5 * u(rng));
  return p;
}

const orpe::SE3 kGt(orpe::so3_exp(orpe::Vec3(0.3, -0.2, 1.0)), orpe::Vec3(0.05, -0.02, 0.8));
const orpe::SE3 kEst =
    kGt * orpe::SE3::exp((orpe::Vec6() << 0.004, -0.003, 0.006, 0.05, 0.02, -0.04).finished());

void BM_Add(benchmark::State& state) {
  const auto pts = model_points(static_cast<int>(state.range(0)));
  for (auto _ : state) benchmark::DoNotOptimize(orpe::add_distance(pts, kGt, kEst));
}
BENCHMARK(BM_Add)->Arg(2620);

void BM_AddsKdTree(benchmark::State& state) {
  const orpe::ModelPoints model(model_points(static_cast<int>(state.range(0))));
  for (auto _ : state) benchmark::DoNotOptimize(orpe::adds_distance(model, kGt, kEst));
}
BENCHMARK(BM_AddsKdTree)->Arg(2620)->Unit(benchmark::kMicrosecond);

void BM_AddsBruteForce(benchmark::State& state) {
  const auto pts = model_points(static_cast<int>(state.range(0)));
  for (auto _ : state) benchmark::DoNotOptimize(orpe::adds_distance_brute_force(pts, kGt, kEst));
}
BENCHMARK(BM_AddsBruteForce)->Arg(2620)->Unit(benchmark::kMillisecond);

void BM_YcbAuc(benchmark::State& state) {
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(0.0, 0.12);
  std::vector<double> d(static_cast<size_t>(state.range(0)));
  for (double& x : d) x = u(rng);
  for (auto _ : state) benchmark::DoNotOptimize(orpe::ycb_auc_percent(d));
}
BENCHMARK(BM_YcbAuc)->Arg(15000)->Unit(benchmark::kMicrosecond);

void BM_TrajectoryEval(benchmark::State& state) {
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0.0, 0.01);
  std::vector<orpe::StampedPose> gt, est;
  orpe::SE3 T;
  for (int i = 0; i < state.range(0); ++i) {
    T = T *
        orpe::SE3::exp((orpe::Vec6() << n(rng), n(rng), n(rng), n(rng), n(rng), n(rng)).finished());
    gt.push_back({i / 30.0, T});
    est.push_back(
        {i / 30.0 + 0.005,
         T * orpe::SE3::exp((orpe::Vec6() << n(rng), n(rng), n(rng), 0, 0, 0).finished())});
  }
  for (auto _ : state) benchmark::DoNotOptimize(orpe::evaluate_trajectory(gt, est, {}));
}
BENCHMARK(BM_TrajectoryEval)->Arg(5000)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
