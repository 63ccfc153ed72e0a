// Micro-benchmark of the SE(3) maps (used in every tracking iteration and EKF update).
#include <benchmark/benchmark.h>

#include "orpe/core/se3.h"

static void BM_Se3ExpLog(benchmark::State& state) {
  orpe::Vec6 xi;
  xi << 0.1, -0.2, 0.3, 0.4, -0.5, 0.6;
  for (auto _ : state) {
    const orpe::SE3 T = orpe::SE3::exp(xi);
    benchmark::DoNotOptimize(T.log());
  }
}
BENCHMARK(BM_Se3ExpLog);
BENCHMARK_MAIN();
