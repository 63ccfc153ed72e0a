// CPU time per call of the `densefusion` pose back-end (nets::DenseFusionEstimator: input building,
// PoseNet, 2 refiner passes, mu) on YCB-Video frames with ground-truth masks, beside the `model`
// back-end (ModelRegistrationEstimator, no prior) on the same inputs in the same run. Seeded
// untrained DenseFusion weights (21 classes): the time does not depend on their values.
//   orpe_bench_densefusion_backend_speed [--data DIR (the shared data root)] [--video 0000]
//   [--frames 2]
//       [--points 1000] [--iterations 2]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "bench_args.h"
#include "cpu_time.h"
#include "orpe/core/frame_masks.h"
#include "orpe/io/dataset.h"
#include "orpe/nets/densefusion_estimator.h"
#include "orpe/pose/model_registration.h"

namespace {

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const orpe::bench::BenchArgs args = orpe::bench::parse_bench_args(
        argc, argv, {"--video", "--frames", "--points", "--iterations"});
    const std::string data = args.data + "/ycbv", video = args.get("--video", "0000");
    const int frames = static_cast<int>(args.number("--frames", 2));
    const int points = static_cast<int>(args.number("--points", 1000));
    const int iterations = static_cast<int>(args.number("--iterations", 2));
    orpe::DatasetParams dp;
    dp.format = "ycbv";
    dp.scene = video;
    const auto reader = orpe::open_dataset(data, dp);
    const orpe::DatasetInfo& info = reader->info();
    orpe::PoseBackendParams pp;
    pp.backend = "densefusion";
    pp.densefusion_random_seed = 1;
    pp.densefusion_num_points = points;
    pp.densefusion_iterations = iterations;
    const orpe::nets::DenseFusionEstimator df(pp, info.class_names);
    const orpe::ModelRegistrationEstimator reg{orpe::ModelRegistrationParams{}};
    std::map<int, orpe::ObjectModel> models;
    std::vector<double> df_cpu, df_wall, reg_cpu, reg_wall;
    for (int fi = 0; fi < std::min<int>(frames, int(reader->size())); ++fi) {
      const orpe::RgbdFrame frame = reader->read(fi);
      for (size_t k = 0; k < frame.objects_gt.size(); ++k) {
        const int cls = frame.objects_gt[k].class_id;
        if (!models.count(cls)) {
          orpe::ModelLoadOptions mo;
          mo.units_per_m = info.model_units_per_m;
          models[cls] = orpe::load_object_model(info.model_points_paths.at(cls), mo, cls,
                                                info.class_names.at(cls));
        }
        const orpe::MaskImage mask = orpe::ground_truth_mask(frame, k);
        orpe::SingleViewInput in;
        in.mask = &mask;
        in.depth = &frame.depth;
        in.color = &frame.color;
        in.intrinsics = frame.intrinsics;
        in.intrinsics.width = frame.depth.width();
        in.intrinsics.height = frame.depth.height();
        in.class_id = cls;
        in.model = &models.at(cls);
        for (int side = 0; side < 2; ++side) {
          const double c0 = orpe::bench::process_cpu_s();
          const auto t0 = std::chrono::steady_clock::now();
          const orpe::SingleViewPose sv = side == 0 ? df.estimate(in) : reg.estimate(in);
          const double wall =
              std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                  .count();
          const double cpu = 1e3 * (orpe::bench::process_cpu_s() - c0);
          if (!sv.valid) continue;
          (side == 0 ? df_cpu : reg_cpu).push_back(cpu);
          (side == 0 ? df_wall : reg_wall).push_back(wall);
        }
      }
    }
    std::printf(
        "densefusion back-end (%d points, %d refiner passes): %zu calls, median %.0f ms CPU, %.0f "
        "ms wall per call\nmodel back-end (same inputs): %zu calls, median %.0f ms CPU, %.0f ms "
        "wall per call\nratio densefusion / model: CPU %.2f, wall %.2f\n",
        points, iterations, df_cpu.size(), median(df_cpu), median(df_wall), reg_cpu.size(),
        median(reg_cpu), median(reg_wall), median(df_cpu) / std::max(median(reg_cpu), 1e-9),
        median(df_wall) / std::max(median(reg_wall), 1e-9));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
