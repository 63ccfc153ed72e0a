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
#include <ctime>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "cpu_time.h"
#include "orpe/nets/maskrcnn.h"

using orpe::bench::process_cpu_s;

int main(int argc, char** argv) {
  std::string model, image_path;
  int repeats = 3, threads = 0;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i], value = argv[i + 1];
    if (flag == "--model")
      model = value;
    else if (flag == "--image")
      image_path = value;
    else if (flag == "--repeats")
      repeats = std::stoi(value);
    else if (flag == "--threads")
      threads = std::stoi(value);
    else {
      std::fprintf(stderr, "unknown flag %s\n", flag.c_str());
      return 2;
    }
  }
  if (model.empty() || image_path.empty() || repeats < 1) {
    std::fprintf(stderr, "usage: %s --model FILE --image PNG [--repeats N] [--threads T]\n",
                 argv[0]);
    return 2;
  }
  try {
    const cv::Mat bgr = cv::imread(image_path, cv::IMREAD_COLOR);
    if (bgr.empty()) throw std::runtime_error(image_path + ": cannot read the image");
    orpe::ColorImage image(bgr.cols, bgr.rows);
    for (int v = 0; v < bgr.rows; ++v)
      for (int u = 0; u < bgr.cols; ++u) {
        const cv::Vec3b p = bgr.at<cv::Vec3b>(v, u);
        image.at(u, v) = {p[2], p[1], p[0]};
      }
    orpe::nets::MaskRcnnOptions options;
    options.threads = threads;
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
