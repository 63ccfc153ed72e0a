// `orpe run`: runs the system over a dataset. Mode `slam`: dense surfel SLAM (tracking + fusion);
// writes the camera trajectory, the surfel map and a run summary.
#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>

#include "command.h"
#include "orpe/core/error.h"
#include "orpe/eval/trajectory_metrics.h"
#include "orpe/io/dataset.h"
#include "orpe/io/image_io.h"
#include "orpe/io/json_summary.h"
#include "orpe/io/trajectory_io.h"
#include "orpe/slam/map_io.h"
#include "orpe/slam/slam_system.h"

namespace orpe::cli {
namespace {

struct RunCommand {
  ConfigOptions options;
  std::string dataset_path, out, mode = "slam";
  std::string render_view;  // PNG path, relative to --out unless absolute
  double view_back_m = 1.5, view_up_m = 0.6;
  bool gt_initial_pose = true;
  int progress_every = 50;
};

double peak_rss_mb() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return ru.ru_maxrss / 1024.0;  // kilobytes on Linux
}

struct StageStats {
  double sum = 0, max = 0;
  size_t n = 0;
  void add(double v) {
    sum += v;
    max = std::max(max, v);
    ++n;
  }
  double mean() const { return n ? sum / double(n) : 0.0; }
};

void run_slam(const RunCommand& c) {
  const OrpeConfig config = resolve_config(c.options);
  const auto reader = open_dataset(c.dataset_path, config.dataset);
  if (reader->size() == 0) throw IoError(c.dataset_path, "the dataset selection has no frames");
  std::filesystem::create_directories(c.out);
  spdlog::info("orpe run --mode slam: {} ({}), {} frames -> {}", c.dataset_path, reader->info().format,
               reader->size(), c.out);

  slam::SlamSystem system(config.slam_params());
  FrameStream stream(*reader);
  RgbdFrame frame;
  std::vector<StampedPose> trajectory;
  std::map<std::string, StageStats> timing;
  int counts[3] = {0, 0, 0};
  std::vector<double> lost_frames;
  bool first = true;
  const auto t_start = std::chrono::steady_clock::now();
  slam::TrackingStatus previous = slam::TrackingStatus::kOk;
  while (stream.next(frame)) {
    if (first && c.gt_initial_pose && frame.T_world_cam_gt) system.set_initial_pose(*frame.T_world_cam_gt);
    first = false;
    const slam::SlamFrameResult r = system.process(frame);
    trajectory.push_back({frame.timestamp_s, r.T_world_cam});
    ++counts[static_cast<int>(r.status)];
    if (r.status == slam::TrackingStatus::kLost) lost_frames.push_back(frame.index);
    timing["preprocess"].add(r.preprocess_ms);
    timing["predict"].add(r.predict_ms);
    timing["track"].add(r.track_ms);
    timing["fuse"].add(r.fuse_ms);
    timing["total"].add(r.total_ms);
    if (r.status != previous)
      spdlog::warn("frame {}: tracking {} -> {}{}", frame.index, slam::to_string(previous), slam::to_string(r.status),
                   r.reason.empty() ? "" : " (" + r.reason + ")");
    previous = r.status;
    const size_t done = trajectory.size();
    if (c.progress_every > 0 && (done % static_cast<size_t>(c.progress_every) == 0 || done == reader->size())) {
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
      spdlog::info("{:5d}/{} frames  {:5.1f} frames/s  OK {} DEGRADED {} LOST {}  surfels {}", done, reader->size(),
                   done / s, counts[0], counts[1], counts[2], system.map().size());
    }
  }
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  if (trajectory.empty()) throw IoError(c.dataset_path, "no readable frame (every frame was skipped)");

  // Outputs.
  write_tum_trajectory(c.out + "/trajectory.txt", trajectory);
  const float stable = static_cast<float>(config.slam_fusion.stable_confidence);
  const size_t written = slam::write_surfel_ply(c.out + "/map.ply", system.map(), 0.0f);
  size_t stable_surfels = 0;
  for (float conf : system.map().confidence) stable_surfels += conf >= stable;

  JsonSummary s;
  s.set("mode", "slam");
  s.set("dataset.path", c.dataset_path);
  s.set("dataset.format", reader->info().format);
  s.set("frames.selected", reader->size());
  s.set("frames.processed", trajectory.size());
  s.set("frames.skipped", stream.skipped());
  s.set("tracking.ok", counts[0]);
  s.set("tracking.degraded", counts[1]);
  s.set("tracking.lost", counts[2]);
  s.set("tracking.lost_frames", lost_frames);
  for (const auto& [stage, st] : timing) {
    s.set("timing_ms." + stage + ".mean", st.mean());
    s.set("timing_ms." + stage + ".max", st.max);
  }
  s.set("timing.wall_s", wall_s);
  s.set("timing.frames_per_s", trajectory.size() / wall_s);
  s.set("map.surfels", system.map().size());
  s.set("map.stable_surfels", stable_surfels);
  s.set("map.bytes", system.map().bytes());
  s.set("map.ply_surfels", written);
  s.set("memory.peak_rss_mb", peak_rss_mb());
  const auto gt = reader->ground_truth_trajectory();
  if (!gt.empty()) {
    const TrajectoryEvaluation ev = evaluate_trajectory(gt, trajectory, config.eval_trajectory);
    if (!ev.matches.empty()) {
      s.set_json("trajectory_eval", ev.to_json());
      spdlog::info("ATE RMSE {:.4f} m over {} poses (rigid alignment)", ev.ate.translation_m.rmse,
                   ev.matches.size());
    }
  }
  if (!c.render_view.empty()) {
    const std::string png = std::filesystem::path(c.render_view).is_absolute() ? c.render_view
                                                                                : c.out + "/" + c.render_view;
    PinholeIntrinsics K;
    K.width = 640;
    K.height = 480;
    K.fx = K.fy = 420.0;
    K.cx = 319.5;
    K.cy = 239.5;
    const SE3 view =
        slam::overview_pose(system.map(), trajectory.front().T_world_cam, stable, c.view_back_m, c.view_up_m);
    write_color_png(png, slam::render_map_image(system.renderer(), system.map(), view, K, stable));
    s.set("render_view", png);
    spdlog::info("rendered map view -> {}", png);
  }
  s.set_json("config", config_to_json(config));
  s.write(c.out + "/summary.json");
  std::cout << fmt::format(
      "{} frames in {:.1f} s ({:.1f} frames/s): OK {} DEGRADED {} LOST {}; {} surfels ({:.1f} MB); peak RSS "
      "{:.0f} MB\nwrote {}/trajectory.txt, map.ply, summary.json\n",
      trajectory.size(), wall_s, trajectory.size() / wall_s, counts[0], counts[1], counts[2], system.map().size(),
      system.map().bytes() / 1048576.0, peak_rss_mb(), c.out);
}

CommandRegistrar reg(30, [](CLI::App& root) {
  auto c = std::make_shared<RunCommand>();
  CLI::App* app = root.add_subcommand("run", "Run the system over a dataset (mode slam: dense surfel SLAM)");
  add_config_options(*app, c->options);
  app->add_option("--dataset", c->dataset_path, "Dataset folder (TUM, 7-Scenes, YCB-Video, BOP; see docs/DATASETS.md)")
      ->required();
  app->add_option("--out", c->out, "Output folder: trajectory.txt, map.ply, summary.json (created)")->required();
  app->add_option("--mode", c->mode, "What to run: slam")->check(CLI::IsMember({"slam"}))->capture_default_str();
  app->add_option("--render-view", c->render_view,
                  "Also render the final map to this PNG (relative to --out), from behind and above the first camera")
      ->capture_default_str();
  app->add_option("--view-back-m", c->view_back_m, "Render view: distance behind the first camera (m)")
      ->capture_default_str();
  app->add_option("--view-up-m", c->view_up_m, "Render view: height above the first camera (m)")
      ->capture_default_str();
  app->add_option("--gt-initial-pose", c->gt_initial_pose,
                  "Start from the dataset's first ground-truth pose when it has one (else identity)")
      ->capture_default_str();
  app->add_option("--progress-every", c->progress_every, "Progress line every N frames (0 = off)")
      ->capture_default_str();
  app->callback([c] { run_slam(*c); });
});

}  // namespace
}  // namespace orpe::cli
