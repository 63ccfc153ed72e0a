// Rasteriser throughput: a ~100k-triangle scene (textured boxes, spheres, a floor) at 640x480.
// Args: threads. Run: build/bin/orpe_bench_render_speed --benchmark_min_time=2
#include <benchmark/benchmark.h>

#include <memory>
#include <random>
#include <vector>

#include "orpe/render/primitives.h"
#include "orpe/render/rasterizer.h"

namespace {

struct Scene {
  std::vector<orpe::TriangleMesh> meshes;
  std::vector<orpe::RenderItem> items;
  orpe::PinholeIntrinsics K;
  size_t triangles = 0;
};

const Scene& scene() {
  static const Scene s = [] {
    Scene sc;
    auto tex = std::make_shared<orpe::ColorImage>(256, 256);
    for (int y = 0; y < 256; ++y)
      for (int x = 0; x < 256; ++x)
        tex->at(x, y) = {static_cast<std::uint8_t>(x), static_cast<std::uint8_t>(y),
                         static_cast<std::uint8_t>((x ^ y) & 0xff)};
    sc.meshes.reserve(16);
    // 6 spheres x ~12.4k triangles, 4 textured boxes x ~6.5k, a floor: ~100k triangles.
    for (int i = 0; i < 6; ++i) sc.meshes.push_back(orpe::make_sphere(0.12f, 100, 63));
    for (int i = 0; i < 4; ++i) {
      sc.meshes.push_back(orpe::make_box(Eigen::Vector3f(0.3f, 0.25f, 0.2f), 0.0125f));
      sc.meshes.back().texture = tex;
    }
    sc.meshes.push_back(orpe::make_quad(6.0f, 6.0f, 8, 8, 6, 6));
    sc.meshes.back().texture = tex;
    std::mt19937 rng(1);
    std::uniform_real_distribution<double> U(-0.5, 0.5);
    // Camera looking down at 45 degrees onto objects spread over ~1 m, 1.6 m away.
    const orpe::Vec3 eye(0, -1.15, 1.15), target(0, 0, 0.1);
    const orpe::Vec3 z_c = (target - eye).normalized();
    const orpe::Vec3 x_c = z_c.cross(orpe::Vec3::UnitZ()).normalized();
    orpe::Mat3 R_world_cam;
    R_world_cam << x_c, z_c.cross(x_c), z_c;
    const orpe::SE3 T_cam_world = orpe::SE3(R_world_cam, eye).inverse();
    for (size_t i = 0; i < sc.meshes.size(); ++i) {
      orpe::SE3 T_world_obj;
      if (i + 1 < sc.meshes.size()) {
        T_world_obj =
            orpe::SE3(Eigen::AngleAxisd(U(rng) * 6, orpe::Vec3::UnitZ()).toRotationMatrix(),
                      orpe::Vec3(U(rng), U(rng), 0.12));
      }
      sc.items.push_back({&sc.meshes[i], T_cam_world * T_world_obj, static_cast<int>(i + 1)});
      sc.triangles += sc.meshes[i].num_triangles();
    }
    return sc;
  }();
  return s;
}

void run(benchmark::State& state, unsigned outputs) {
  const Scene& sc = scene();
  orpe::RasterizerParams p;
  p.threads = static_cast<int>(state.range(0));
  orpe::Rasterizer r(p);
  orpe::RenderBuffers out;
  for (auto _ : state) {
    r.render(sc.K, sc.items, out, outputs);
    benchmark::DoNotOptimize(out.depth.data());
  }
  state.counters["triangles"] = static_cast<double>(sc.triangles);
  state.counters["covered_px"] = static_cast<double>(out.stats.pixels_covered);
}

void BM_RenderFull(benchmark::State& state) {
  run(state, orpe::kRenderDepth | orpe::kRenderIds | orpe::kRenderColor | orpe::kRenderNormals);
}
void BM_RenderDepthIds(benchmark::State& state) {
  run(state, orpe::kRenderDepth | orpe::kRenderIds);
}
void BM_RenderFullWithSilhouettes(benchmark::State& state) {
  run(state, orpe::kRenderDepth | orpe::kRenderIds | orpe::kRenderColor | orpe::kRenderNormals |
                 orpe::kRenderSilhouettes);
}

}  // namespace

BENCHMARK(BM_RenderFull)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_RenderDepthIds)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_RenderFullWithSilhouettes)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_MAIN();
