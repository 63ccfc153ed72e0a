// Trajectory accuracy of the dense SLAM on the shared 7-Scenes sequence (frames read directly):
// runs SlamSystem over the frames, prints per-frame reports, then ATE RMSE against the frames'
// ground-truth poses (rigid fit, no scale) and mean stage timings.
//
//   build/bin/orpe_bench_slam_ate [--frames N] [--every K] [--preset NAME] [--dir D | --dataset
//   PATH]
//       [--set section.key=value ...] [--gt-reset] [--gt-map] [--gt-offset K] [--trajectory FILE]
//       [--depth-units U] [--color-camera f,tx,ty,du,dv]
// --dataset PATH reads the frames through open_dataset (any format orpe reads, e.g. an `orpe synth`
// scene; `--set dataset.*` applies) instead of the 7-Scenes folder --dir.
// --trajectory FILE writes the estimated poses (TUM; scripts/diagnostics/rpe_axes.py reads it).
// --depth-units U reads the depth at U units per metre instead of 1000 (a depth scale check);
// --color-camera resamples each colour image onto the depth pixels as seen by a colour camera with
// that focal length (px), baseline (m) and principal-point shift (px) (an unregistered-colour
// check; scripts/diagnostics/color_depth_edges.py estimates these from the images).
// --gt-reset (diagnostic): each frame is tracked from the previous frame's ground-truth pose, so
// the errors printed are one-step tracking errors against the map, without accumulated drift.
// --gt-map (diagnostic): every frame is fused at its ground-truth pose
// (SlamSystem::process_at_known_pose) and the tracking estimate from the previous ground-truth pose
// is what is scored: the one-step error of the tracker against a map without drift. --gt-offset K:
// frame i gets the ground truth of frame i + K (a test for a time offset between the depth images
// and the ground truth). --gt-start (diagnostic): each frame is tracked from its own ground-truth
// pose: where the tracker's objective has its minimum, not how it gets there.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <time.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <iostream>
#include <optional>

#include "orpe/core/openmp_waits.h"
#include "orpe/eval/trajectory_metrics.h"
#include "orpe/io/dataset.h"
#include "orpe/io/trajectory_io.h"
#include "orpe/pipeline/config.h"
#include "slam_bench_common.h"

int main(int argc, char** argv) {
  orpe::prefer_passive_openmp_waits(argv);  // as the orpe CLI (docs/PIPELINE.md, "Threads")
  using namespace orpe;
  int frames = 500, every = 50;
  std::string dir = bench::seven_scenes_dir();
  std::string dataset_path;  // --dataset PATH: frames through open_dataset instead of --dir
  OrpeConfig config;
  bool gt_reset = false, gt_map = false, gt_start = false;
  int gt_offset = 0;
  std::string trajectory_path;        // --trajectory FILE: the estimated poses, TUM format
  double depth_units_per_m = 1000.0;  // --depth-units U (diagnostic: a depth scale error)
  std::optional<bench::ColorCameraGuess>
      color_camera;  // --color-camera f,tx,ty,du,dv (diagnostic)  //
                     // diagnostic: frame i takes the ground truth of frame i + gt_offset
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--frames" && i + 1 < argc)
      frames = std::atoi(argv[++i]);
    else if (a == "--every" && i + 1 < argc)
      every = std::atoi(argv[++i]);
    else if (a == "--dir" && i + 1 < argc)
      dir = argv[++i];
    else if (a == "--dataset" && i + 1 < argc)
      dataset_path = argv[++i];
    else if (a == "--gt-reset")
      gt_reset = true;
    else if (a == "--gt-map")
      gt_map = true;
    else if (a == "--gt-start")
      gt_start = true;
    else if (a == "--depth-units" && i + 1 < argc)
      depth_units_per_m = std::atof(argv[++i]);
    else if (a == "--color-camera" && i + 1 < argc) {
      bench::ColorCameraGuess c;
      if (std::sscanf(argv[++i], "%lf,%lf,%lf,%lf,%lf", &c.f_px, &c.tx_m, &c.ty_m, &c.du_px,
                      &c.dv_px) != 5 ||
          !(c.f_px > 0)) {
        std::cerr << "--color-camera wants f,tx,ty,du,dv (px, m, m, px, px)\n";
        return 2;
      }
      color_camera = c;
    } else if (a == "--trajectory" && i + 1 < argc)
      trajectory_path = argv[++i];
    else if (a == "--gt-offset" && i + 1 < argc)
      gt_offset = std::atoi(argv[++i]);
    else if ((a == "--set" || a == "--preset") && i + 1 < argc) {
      if (!bench::apply_config_flag(config, a, argv[++i])) return 2;
    } else {
      std::cerr << "unknown argument " << a << "\n";
      return 2;
    }
  }
  try {
    slam::SlamSystem system(config.slam_params());
    std::vector<Vec3> est, gt;
    std::vector<Mat3> gt_rot;
    std::vector<StampedPose> trajectory;
    double sum_total = 0, sum_pre = 0, sum_pred = 0, sum_track = 0, sum_fuse = 0;
    double fz[5] = {0, 0, 0, 0, 0};
    int counts[3] = {0, 0, 0};
    bool first = true;
    std::optional<SE3> previous_gt;
    double cpu_s = 0;
    auto cpu_now = [] {
      timespec ts;
      clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
      return ts.tv_sec + 1e-9 * ts.tv_nsec;
    };
    std::unique_ptr<DatasetReader> reader;
    if (!dataset_path.empty()) {
      reader = open_dataset(dataset_path, config.dataset);
      frames = std::min(frames, static_cast<int>(reader->size()));
    }
    auto load = [&](int i) {
      if (!reader) return bench::load_7scenes_frame(dir, i, depth_units_per_m);
      return reader->read(static_cast<size_t>(i));
    };
    auto load_pose = [&](int j) {
      return reader ? load(j).T_world_cam_gt : bench::load_7scenes_pose(dir, j);
    };
    for (int i = 0; i < frames; ++i) {
      RgbdFrame f = load(i);
      if (color_camera) bench::register_color_to_depth(f, *color_camera);
      if (gt_offset != 0) {
        const int j = std::clamp(i + gt_offset, 0, frames - 1);
        f.T_world_cam_gt = load_pose(j);
      }
      if (first && f.T_world_cam_gt) system.set_initial_pose(*f.T_world_cam_gt);
      first = false;
      if (gt_reset && previous_gt) system.set_initial_pose(*previous_gt);
      if (gt_start && f.T_world_cam_gt) system.set_initial_pose(*f.T_world_cam_gt);
      previous_gt = f.T_world_cam_gt;
      const double c0 = cpu_now();
      slam::SlamFrameResult r = gt_map && f.T_world_cam_gt
                                    ? system.process_at_known_pose(f, *f.T_world_cam_gt)
                                    : system.process(f);
      if (gt_map) r.T_world_cam = r.tracked_T_world_cam;  // score the tracker, not the given pose
      cpu_s += cpu_now() - c0;
      ++counts[static_cast<int>(r.status)];
      sum_total += r.total_ms;
      sum_pre += r.preprocess_ms;
      sum_pred += r.predict_ms;
      sum_track += r.track_ms;
      sum_fuse += r.fuse_ms;
      fz[0] += r.fusion.index_ms;
      fz[1] += r.fusion.associate_ms;
      fz[2] += r.fusion.update_ms;
      fz[3] += r.fusion.clean_ms;
      fz[4] += r.fusion.remove_ms;
      if (every > 0 && (i % every == 0 || r.status != slam::TrackingStatus::kOk)) {
        std::cout << r.report();
        if (f.T_world_cam_gt) {
          const SE3 e = f.T_world_cam_gt->inverse() * r.T_world_cam;
          std::cout << fmt::format(" | gt err {:.3f} m {:.2f} deg", e.translation().norm(),
                                   e.rotation_angle_deg());
        }
        std::cout << std::endl;
      }
      trajectory.push_back({f.timestamp_s, r.T_world_cam});
      if (f.T_world_cam_gt) {
        est.push_back(r.T_world_cam.translation());
        gt.push_back(f.T_world_cam_gt->translation());
        gt_rot.push_back(f.T_world_cam_gt->rotation());
      }
    }
    if (!trajectory_path.empty()) write_tum_trajectory(trajectory_path, trajectory);
    const double ate = bench::ate_rmse(est, gt);
    {
      // Diagnostic: could the ground truth be the pose of another point on the rig (a lever arm t_X
      // in the camera frame)? Alternate a rigid fit est -> gt - R_gt t_X with the linear solve of
      // p_gt - R_A p_est = t_A + R_gt t_X for (t_A, t_X).
      Vec3 t_X = Vec3::Zero();
      double rms = 0;
      for (int iter = 0; iter < 20 && !est.empty(); ++iter) {
        std::vector<Vec3> gt_c(gt.size());
        for (size_t i = 0; i < gt.size(); ++i) gt_c[i] = gt[i] - gt_rot[i] * t_X;
        const SimilarityAlignment rig = align_umeyama(est, gt_c, false);
        Eigen::Matrix<double, 6, 6> A = Eigen::Matrix<double, 6, 6>::Zero();
        Eigen::Matrix<double, 6, 1> b = Eigen::Matrix<double, 6, 1>::Zero();
        for (size_t i = 0; i < gt.size(); ++i) {
          Eigen::Matrix<double, 3, 6> J;
          J << Mat3::Identity(), gt_rot[i];
          A += J.transpose() * J;
          b += J.transpose() * (gt[i] - rig.R * est[i]);
        }
        const Eigen::Matrix<double, 6, 1> x = A.ldlt().solve(b);
        t_X = x.tail<3>();
        double e2 = 0;
        for (size_t i = 0; i < gt.size(); ++i)
          e2 += (rig.R * est[i] + x.head<3>() + gt_rot[i] * t_X - gt[i]).squaredNorm();
        rms = std::sqrt(e2 / double(gt.size()));
      }
      std::cout << fmt::format(
          "lever-arm fit (diagnostic): t_X = ({:.4f}, {:.4f}, {:.4f}) m, ATE {:.4f} m\n", t_X.x(),
          t_X.y(), t_X.z(), rms);
    }
    {
      const SimilarityAlignment sim = align_umeyama(est, gt, true);
      double e2 = 0;
      for (size_t i = 0; i < est.size(); ++i) e2 += (sim.apply(est[i]) - gt[i]).squaredNorm();
      double len_est = 0, len_gt = 0;
      for (size_t i = 1; i < est.size(); ++i) {
        len_est += (est[i] - est[i - 1]).norm();
        len_gt += (gt[i] - gt[i - 1]).norm();
      }
      std::cout << fmt::format(
          "Sim3 alignment: scale {:.4f}, ATE {:.4f} m; path length est {:.3f} m gt {:.3f} m\n",
          sim.scale, std::sqrt(e2 / std::max<size_t>(1, est.size())), len_est, len_gt);
    }
    // Drift without alignment (the first pose is set from ground truth).
    double raw = 0;
    for (size_t i = 0; i < est.size(); ++i) raw += (est[i] - gt[i]).squaredNorm();
    raw = est.empty() ? 0 : std::sqrt(raw / est.size());
    std::cout << fmt::format(
        "frames {} | OK {} DEGRADED {} LOST {} | ATE RMSE {:.4f} m (unaligned {:.4f} m) | surfels "
        "{} ({:.1f} MB)\n"
        "mean ms/frame: total {:.1f} (preprocess {:.1f}, predict {:.1f}, track {:.1f}, fuse "
        "{:.1f}) = {:.1f} "
        "frames/s; CPU time {:.1f} ms/frame\n",
        frames, counts[0], counts[1], counts[2], ate, raw, system.map().size(),
        system.map().bytes() / 1048576.0, sum_total / frames, sum_pre / frames, sum_pred / frames,
        sum_track / frames, sum_fuse / frames, 1000.0 * frames / sum_total,
        1000.0 * cpu_s / frames);
    std::cout << fmt::format(
        "fusion phases ms: index {:.1f} associate {:.1f} update {:.1f} clean {:.1f} remove "
        "{:.1f}\n",
        fz[0] / frames, fz[1] / frames, fz[2] / frames, fz[3] / frames, fz[4] / frames);
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
