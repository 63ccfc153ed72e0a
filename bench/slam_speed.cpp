// Speed of the dense SLAM (tracking + fusion per frame) against OpenCV's cv::rgbd::RgbdICPOdometry
// chained frame to frame, on the same 640x480 7-Scenes frames (preloaded: no file I/O is timed).
//
//   build/bin/orpe_bench_slam_speed [--frames N] [--threads T] [--skip-opencv] [--preset NAME]
//   [--trajectory FILE]
//   [--set section.key=value ...]
//
// Prints wall-clock frames/s, CPU time per frame, both ATEs and the speed ratio.
#include <fmt/format.h>
#include <omp.h>
#include <time.h>
#include <fstream>

#include <Eigen/Core>
#include <chrono>
#include <iostream>
#include <opencv2/core.hpp>
#include <opencv2/rgbd/depth.hpp>

#include "orpe/core/openmp_waits.h"
#include "orpe/pipeline/config.h"
#include "slam_bench_common.h"

namespace {

double cpu_seconds() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}
double wall_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

struct Timing {
  double wall_s = 0, cpu_s = 0;
  double ate_m = 0;
};

cv::Mat gray_of(const orpe::ColorImage& c) {
  cv::Mat g(c.height(), c.width(), CV_8UC1);
  for (int v = 0; v < c.height(); ++v)
    for (int u = 0; u < c.width(); ++u) {
      const orpe::Rgb8 p = c.at(u, v);
      g.at<std::uint8_t>(v, u) =
          static_cast<std::uint8_t>(0.299 * p.r + 0.587 * p.g + 0.114 * p.b + 0.5);
    }
  return g;
}
cv::Mat depth_of(const orpe::DepthImage& d) {
  cv::Mat m(d.height(), d.width(), CV_32FC1);
  for (int v = 0; v < d.height(); ++v)
    for (int u = 0; u < d.width(); ++u) {
      const float z = d.at(u, v);
      m.at<float>(v, u) = z > 0 ? z : std::numeric_limits<float>::quiet_NaN();
    }
  return m;
}

/// One line per frame, "x y z" with 17 significant digits (exact doubles). False when the write
/// failed.
bool write_positions(std::ofstream& out, const std::vector<orpe::Vec3>& est) {
  for (const orpe::Vec3& p : est)
    out << fmt::format("{:.17g} {:.17g} {:.17g}\n", p.x(), p.y(), p.z());
  out.flush();
  return static_cast<bool>(out);
}

}  // namespace

int main(int argc, char** argv) {
  orpe::prefer_passive_openmp_waits(argv);  // as the orpe CLI (docs/PIPELINE.md, "Threads")
  using namespace orpe;
  int frames = 100, threads = 0;
  bool skip_opencv = false;
  std::string trajectory_path;  // --trajectory FILE: orpe's positions, to compare runs bit for bit
  OrpeConfig config;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--frames" && i + 1 < argc)
      frames = std::atoi(argv[++i]);
    else if (a == "--threads" && i + 1 < argc)
      threads = std::atoi(argv[++i]);
    else if (a == "--skip-opencv")
      skip_opencv = true;
    else if (a == "--trajectory" && i + 1 < argc)
      trajectory_path = argv[++i];
    else if ((a == "--set" || a == "--preset") && i + 1 < argc) {
      if (!bench::apply_config_flag(config, a, argv[++i])) return 2;
    } else {
      std::cerr << "unknown argument " << a << "\n";
      return 2;
    }
  }
  if (threads > 0) omp_set_num_threads(threads);
  try {
    std::ofstream trajectory;  // opened before the run: a bad path fails now, not after it
    if (!trajectory_path.empty()) {
      trajectory.open(trajectory_path);
      if (!trajectory) {
        std::cerr << "error: --trajectory " << trajectory_path << ": cannot open for writing\n";
        return 2;
      }
    }
    const std::string dir = bench::seven_scenes_dir();
    std::vector<RgbdFrame> seq;
    for (int i = 0; i < frames; ++i) seq.push_back(bench::load_7scenes_frame(dir, i));
    std::cout << fmt::format("{} frames of {} ({}x{}), OpenMP threads {}\n", frames, dir,
                             seq[0].intrinsics.width, seq[0].intrinsics.height,
                             omp_get_max_threads());

    // ---- orpe SLAM ----
    Timing ours;
    {
      slam::SlamSystem system(config.slam_params());
      system.set_initial_pose(*seq[0].T_world_cam_gt);
      std::vector<Vec3> est, gt;
      const double w0 = wall_seconds(), c0 = cpu_seconds();
      for (const RgbdFrame& f : seq) {
        const slam::SlamFrameResult r = system.process(f);
        est.push_back(r.T_world_cam.translation());
        gt.push_back(f.T_world_cam_gt->translation());
      }
      ours.wall_s = wall_seconds() - w0;
      ours.cpu_s = cpu_seconds() - c0;
      ours.ate_m = bench::ate_rmse(est, gt);
      if (trajectory.is_open() && !write_positions(trajectory, est)) {
        std::cerr << "error: --trajectory " << trajectory_path << ": write failed\n";
        return 2;
      }
      std::cout << fmt::format(
          "orpe SlamSystem:          {:6.1f} frames/s  ({:5.1f} ms/frame wall, {:5.1f} ms CPU)  "
          "ATE {:.4f} m  surfels {}\n",
          frames / ours.wall_s, 1e3 * ours.wall_s / frames, 1e3 * ours.cpu_s / frames, ours.ate_m,
          system.map().size());
    }

    // ---- OpenCV RgbdICPOdometry, frame to frame ----
    if (!skip_opencv) {
      Timing cvt;
      const PinholeIntrinsics& K = seq[0].intrinsics;
      cv::Mat Kcv = (cv::Mat_<float>(3, 3) << K.fx, 0, K.cx, 0, K.fy, K.cy, 0, 0, 1);
      cv::rgbd::RgbdICPOdometry odom(Kcv);
      std::vector<cv::Mat> gray, depth;
      for (const RgbdFrame& f : seq) {
        gray.push_back(gray_of(f.color));
        depth.push_back(depth_of(f.depth));
      }
      SE3 T = *seq[0].T_world_cam_gt;
      std::vector<Vec3> est{T.translation()}, gt{seq[0].T_world_cam_gt->translation()};
      const double w0 = wall_seconds(), c0 = cpu_seconds();
      for (int i = 1; i < frames; ++i) {
        cv::Mat Rt;
        const bool ok =
            odom.compute(gray[i - 1], depth[i - 1], cv::Mat(), gray[i], depth[i], cv::Mat(), Rt);
        if (ok) {
          Mat4 M;
          for (int r = 0; r < 4; ++r)
            for (int c = 0; c < 4; ++c) M(r, c) = Rt.at<double>(r, c);
          T = T *
              SE3::from_matrix(M).inverse();  // Rt maps the source (i-1) into the destination (i)
        }
        est.push_back(T.translation());
        gt.push_back(seq[i].T_world_cam_gt->translation());
      }
      cvt.wall_s = wall_seconds() - w0;
      cvt.cpu_s = cpu_seconds() - c0;
      cvt.ate_m = bench::ate_rmse(est, gt);
      std::cout << fmt::format(
          "OpenCV RgbdICPOdometry:   {:6.1f} frames/s  ({:5.1f} ms/frame wall, {:5.1f} ms CPU)  "
          "ATE {:.4f} m\n",
          (frames - 1) / cvt.wall_s, 1e3 * cvt.wall_s / (frames - 1),
          1e3 * cvt.cpu_s / (frames - 1), cvt.ate_m);
      std::cout << fmt::format("speed ratio orpe / OpenCV: {:.2f} (wall), {:.2f} (CPU)\n",
                               (frames / ours.wall_s) / ((frames - 1) / cvt.wall_s),
                               (cvt.cpu_s / (frames - 1)) / (ours.cpu_s / frames));
    }
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
