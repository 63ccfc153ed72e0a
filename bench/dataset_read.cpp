// Cost of the dataset readers on the shared real data (ORPE_DATA_DIR or ../shared/data next to the
// build's source) and of the point-cloud PLY writer. Benchmarks whose data is absent report an
// error and are skipped.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>
#include <random>

#include "bench_args.h"
#include "orpe/io/dataset.h"
#include "orpe/io/point_cloud_io.h"

namespace {

std::string data_dir() {
  return orpe::bench::shared_data_dir();
}

void read_frames(benchmark::State& state, const std::string& sub, const std::string& format,
                 bool annotations_only) {
  const std::string dir = data_dir() + "/" + sub;
  if (!std::filesystem::exists(dir)) {
    state.SkipWithError(("no data at " + dir + " (set ORPE_DATA_DIR)").c_str());
    return;
  }
  orpe::DatasetParams p;
  p.format = format;
  auto reader = orpe::open_dataset(dir, p);
  size_t i = 0;
  for (auto _ : state) {
    orpe::RgbdFrame f = annotations_only ? reader->read_annotations(i) : reader->read(i);
    benchmark::DoNotOptimize(f.depth.data());
    i = (i + 1) % reader->size();
  }
  state.SetItemsProcessed(state.iterations());
}

void BM_Read7ScenesTumLayout(benchmark::State& s) {
  read_frames(s, "7scenes-seq", "tum", false);
}
void BM_Read7ScenesNative(benchmark::State& s) {
  read_frames(s, "7scenes-seq", "7scenes", false);
}
void BM_ReadYcbVideo(benchmark::State& s) {
  read_frames(s, "ycbv", "ycbv", false);
}
void BM_ReadYcbVideoAnnotations(benchmark::State& s) {
  read_frames(s, "ycbv", "ycbv", true);
}
BENCHMARK(BM_Read7ScenesTumLayout)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Read7ScenesNative)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReadYcbVideo)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReadYcbVideoAnnotations)->Unit(benchmark::kMillisecond);

void BM_WriteSurfelPly(benchmark::State& state) {
  const size_t n = static_cast<size_t>(state.range(0));
  orpe::PointCloudData c;
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(-1, 1);
  for (size_t i = 0; i < n; ++i) {
    c.positions_m.emplace_back(u(rng), u(rng), 2 + u(rng));
    c.normals.push_back(Eigen::Vector3f(u(rng), u(rng), 1).normalized());
    c.colors.push_back({static_cast<uint8_t>(i), 100, 200});
    c.radii_m.push_back(0.003f);
    c.confidences.push_back(1.0f);
    c.instance_ids.push_back(static_cast<int32_t>(i % 7));
    c.class_ids.push_back(static_cast<int32_t>(i % 3));
  }
  const std::string path =
      (std::filesystem::temp_directory_path() / "orpe_bench_surfels.ply").string();
  for (auto _ : state) orpe::write_point_cloud_ply(path, c);
  std::filesystem::remove(path);
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(n));
}
BENCHMARK(BM_WriteSurfelPly)->Arg(1000000)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
