// CPU time per call of DenseFusion in LibTorch (seeded weights: the time does not depend on them):
// PoseNet on a 120 x 160 crop with 1000 points, and one PoseRefineNet pass (pose() with 1 iteration
// minus 0 iterations).
//   orpe_bench_densefusion_speed [--repeats 5]
// scripts/nets/densefusion_fixtures.py bench times the reference implementation on the same sizes.
#include <chrono>
#include <cstdio>
#include <ctime>
#include <random>
#include <string>

#include "cpu_time.h"
#include "orpe/nets/densefusion.h"

using orpe::bench::process_cpu_s;

int main(int argc, char** argv) {
  const int repeats = argc > 2 && std::string(argv[1]) == "--repeats" ? std::stoi(argv[2]) : 5;
  try {
    orpe::nets::DenseFusionSpec spec;
    spec.random_seed = 1;
    const orpe::nets::DenseFusionNetwork net(spec);
    const int h = 120, w = 160, n = spec.num_points;
    std::mt19937 rng(3);
    std::normal_distribution<float> g(0, 1);
    std::vector<float> crop(3 * h * w), cloud(3 * n);
    for (float& v : crop) v = g(rng);
    for (int i = 0; i < n; ++i)
      for (int k = 0; k < 3; ++k) cloud[3 * i + k] = 0.05f * g(rng) + (k == 2 ? 0.8f : 0.0f);
    std::vector<std::int64_t> choose(n);
    for (int i = 0; i < n; ++i) choose[i] = (i * 7919) % (h * w);
    auto pts = net.estimate(crop, h, w, cloud, choose, 0);  // warm-up
    double c0 = process_cpu_s();
    for (int r = 0; r < repeats; ++r) pts = net.estimate(crop, h, w, cloud, choose, 0);
    const double posenet_ms = 1e3 * (process_cpu_s() - c0) / repeats;
    c0 = process_cpu_s();
    for (int r = 0; r < repeats; ++r) net.pose(pts, cloud, 0, 0);
    const double pick_ms = 1e3 * (process_cpu_s() - c0) / repeats;
    c0 = process_cpu_s();
    for (int r = 0; r < repeats; ++r) net.pose(pts, cloud, 0, 1);
    const double refine_ms = 1e3 * (process_cpu_s() - c0) / repeats - pick_ms;
    std::printf(
        "densefusion_speed: PoseNet %.0f ms CPU/call (120x160, %d points), refiner pass %.1f ms\n",
        posenet_ms, n, refine_ms);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
