// Micro-benchmark of the model's nearest-point searches (the single-view registration's inner loop,
// docs/POSE.md): the bounded kd-tree search against the hinted search certified from neighbour
// lists (nearest_near, hint = the point found for the query before it moved, as in an ICP
// iteration) and the coarse grid. Model: the surface of a 10 x 15 x 20 cm box sampled every 2.5 mm
// (~22 k points, a YCB-sized model); queries within 3 mm of the surface. Run:
// build/bin/orpe_bench_model_search.
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "orpe/pose/model_search.h"

namespace {

std::vector<Eigen::Vector3f> box_surface(const Eigen::Vector3f& size, float spacing) {
  std::vector<Eigen::Vector3f> pts;
  const Eigen::Vector3f h = 0.5f * size;
  for (int axis = 0; axis < 3; ++axis) {
    const int a = (axis + 1) % 3, b = (axis + 2) % 3;
    const int na = static_cast<int>(size[a] / spacing), nb = static_cast<int>(size[b] / spacing);
    for (int side = -1; side <= 1; side += 2)
      for (int i = 0; i <= na; ++i)
        for (int j = 0; j <= nb; ++j) {
          Eigen::Vector3f p;
          p[axis] = side * h[axis];
          p[a] = -h[a] + i * spacing;
          p[b] = -h[b] + j * spacing;
          pts.push_back(p);
        }
  }
  return pts;
}

struct Fixture {
  std::vector<Eigen::Vector3f> points = box_surface({0.10f, 0.15f, 0.20f}, 0.0025f);
  orpe::ModelSearchIndex index{points};
  std::vector<Eigen::Vector3f> queries;
  std::vector<std::uint32_t> hints;  ///< nearest point of the query before a 1 mm move
  Fixture() {
    std::mt19937 rng(7);
    std::uniform_int_distribution<size_t> any(0, points.size() - 1);
    std::uniform_real_distribution<float> off(-0.003f, 0.003f), move(-0.001f, 0.001f);
    for (int i = 0; i < 4096; ++i) {
      const Eigen::Vector3f q = points[any(rng)] + Eigen::Vector3f(off(rng), off(rng), off(rng));
      queries.push_back(q);
      hints.push_back(index.nearest(q + Eigen::Vector3f(move(rng), move(rng), move(rng)), nullptr));
    }
    float d2 = 0;
    index.nearest_near(queries[0], hints[0], 1e-4f, &d2);  // builds the lists outside the timing
    index.nearest_approx(queries[0], &d2, 0.005f, 0.05f);  // lays out the grid
  }
};

Fixture& fixture() {
  static Fixture f;
  return f;
}

constexpr float kBoundSq = 0.01f * 0.01f;  // the refinement's final association distance, 1 cm

/// Times `search(query, hint, &d2)` over the fixture's queries, round robin.
template <class Search>
void time_queries(benchmark::State& state, Search search) {
  Fixture& f = fixture();
  size_t k = 0;
  for (auto _ : state) {
    float d2 = 0;
    benchmark::DoNotOptimize(search(f.index, f.queries[k], f.hints[k], &d2));
    k = (k + 1) % f.queries.size();
  }
}

void BM_NearestWithinTree(benchmark::State& state) {
  time_queries(state,
               [](const orpe::ModelSearchIndex& index, const Eigen::Vector3f& q, std::uint32_t,
                  float* d2) { return index.nearest_within(q, kBoundSq, d2); });
}
BENCHMARK(BM_NearestWithinTree);

void BM_NearestNearHinted(benchmark::State& state) {
  time_queries(state,
               [](const orpe::ModelSearchIndex& index, const Eigen::Vector3f& q, std::uint32_t hint,
                  float* d2) { return index.nearest_near(q, hint, kBoundSq, d2); });
}
BENCHMARK(BM_NearestNearHinted);

void BM_NearestApproxGrid(benchmark::State& state) {
  time_queries(state,
               [](const orpe::ModelSearchIndex& index, const Eigen::Vector3f& q, std::uint32_t,
                  float* d2) { return index.nearest_approx(q, d2, 0.005f, 0.05f); });
}
BENCHMARK(BM_NearestApproxGrid);

}  // namespace

BENCHMARK_MAIN();
