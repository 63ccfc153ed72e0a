// CPU time per call of the maskrcnn back-end's network (LibTorch, orpe's torchvision operators) on
// one colour image, e.g. a YCB-Video frame:
//   orpe_bench_maskrcnn_speed --model maskrcnn_r50.pt --image
//   ../shared/data/ycbv/data/0000/000001-color.png
//       [--repeats 3] [--threads 2]
// Prints the mean wall and process-CPU ms per call after one warm-up call, and the detections of
// the last call. scripts/nets/maskrcnn_bench.sh runs it beside Python torchvision on the same model
// and image (docs/BENCHMARKS.md).
#include <chrono>
#include <cstdio>
#include <string>

#include "bench_args.h"
#include "cpu_time.h"
#include "orpe/io/image_io.h"
#include "orpe/nets/maskrcnn.h"

using orpe::bench::process_cpu_s;

int main(int argc, char** argv) {
  try {
    // --model and --image required; unknown flags and non-numbers are errors (bench_args.h).
    const orpe::bench::BenchArgs args =
        orpe::bench::parse_bench_args(argc, argv, {"--model", "--image", "--repeats", "--threads"});
    const std::string model = args.get("--model", ""), image_path = args.get("--image", "");
    const double repeats_arg = args.number("--repeats", 3),
                 threads_arg = args.number("--threads", 0);
    if (model.empty() || image_path.empty() || repeats_arg < 1 || threads_arg < 0 ||
        repeats_arg != static_cast<int>(repeats_arg) ||
        threads_arg != static_cast<int>(threads_arg)) {
      std::fprintf(stderr,
                   "usage: %s --model FILE --image PNG [--repeats N >= 1] [--threads T >= 0]\n",
                   argv[0]);
      return 2;
    }
    const int repeats = static_cast<int>(repeats_arg);
    const orpe::ColorImage image = orpe::read_color_image(image_path);
    orpe::nets::MaskRcnnOptions options;
    options.threads = static_cast<int>(threads_arg);
    const orpe::nets::MaskRcnnNetwork net(model, options);
    orpe::nets::MaskRcnnOutput out = net.run(image);  // warm-up (graph optimisation)
    const auto t0 = std::chrono::steady_clock::now();
    const double c0 = process_cpu_s();
    for (int r = 0; r < repeats; ++r) out = net.run(image);
    const double wall_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    const double cpu_ms = 1e3 * (process_cpu_s() - c0);
    std::printf(
        "maskrcnn_speed: %dx%d, %d calls: wall %.0f ms/call, cpu %.0f ms/call, %zu detections\n",
        image.width(), image.height(), repeats, wall_ms / repeats, cpu_ms / repeats,
        out.scores.size());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
