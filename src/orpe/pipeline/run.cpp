#include "orpe/pipeline/run.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <sys/resource.h>
#include <cmath>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <ostream>

#include "orpe/core/atomic_file.h"
#include "orpe/core/error.h"
#include "orpe/core/machine_info.h"
#include "orpe/core/staged_dir.h"
#include "orpe/core/version.h"
#include "orpe/eval/trajectory_metrics.h"
#include "orpe/io/bop_results.h"
#include "orpe/io/image_io.h"
#include "orpe/io/json_summary.h"
#include "orpe/io/trajectory_io.h"
#include "orpe/pipeline/frame_log.h"
#include "orpe/semantic/mask_output.h"
#include "orpe/semantic/semantic_output.h"
#include "orpe/slam/map_io.h"

namespace orpe {
namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

/// Every value of the camera file and the models folder the run used (issue #17).
void write_camera_and_models(const DatasetInfo& info, JsonSummary& js) {
  js.set("dataset.depth_units_per_m", info.depth_units_per_m);
  js.set("dataset.intrinsics", std::vector<double>{info.intrinsics.fx, info.intrinsics.fy,
                                                   info.intrinsics.cx, info.intrinsics.cy});
  js.set("dataset.image_size", std::vector<double>{static_cast<double>(info.intrinsics.width),
                                                   static_cast<double>(info.intrinsics.height)});
  if (info.camera) {
    const CameraFileInfo& c = *info.camera;
    js.set("camera.file", c.path);
    js.set("camera.style", c.style);
    js.set("camera.colour_fx_fy_cx_cy",
           std::vector<double>{c.colour.fx, c.colour.fy, c.colour.cx, c.colour.cy});
    js.set("camera.colour_size", std::vector<double>{static_cast<double>(c.colour.width),
                                                     static_cast<double>(c.colour.height)});
    js.set("camera.colour_distortion_k1_k2_p1_p2_k3",
           std::vector<double>(c.colour_distortion.begin(), c.colour_distortion.end()));
    js.set("camera.depth_units_per_m", c.depth_units_per_m);
    js.set("camera.min_depth_m", c.min_depth_m);
    js.set("camera.max_depth_m", c.max_depth_m);
    js.set("camera.registered_depth_camera", c.has_depth_camera);
    if (c.has_depth_camera) {
      js.set("camera.depth_fx_fy_cx_cy",
             std::vector<double>{c.depth.fx, c.depth.fy, c.depth.cx, c.depth.cy});
      js.set("camera.depth_distortion_k1_k2_p1_p2_k3",
             std::vector<double>(c.depth_distortion.begin(), c.depth_distortion.end()));
      const Eigen::Matrix4d T = c.T_colour_depth.matrix();
      js.set("camera.T_colour_depth",
             std::vector<double>(T.data(), T.data() + 16));  // column-major
    }
  }
  if (!info.models_dir.empty()) {
    js.set("models.dir", info.models_dir);
    js.set("models.units_per_m", info.model_units_per_m);
    std::vector<std::string> classes;
    for (const auto& [id, path] : info.model_mesh_paths)
      classes.push_back(
          std::to_string(id) + " " + info.class_names.at(id) + " " + path +
          (info.model_symmetry.count(id) ? " symmetry: " + info.model_symmetry.at(id).text : ""));
    js.set("models.classes", classes);
  }
}

/// How and where the run was made (for `orpe report`): the command line and the machine.
void write_provenance(const RunOptions& options, JsonSummary& js) {
  js.set("provenance.command", options.command_line);
  const MachineInfo m = describe_machine();
  js.set("provenance.machine.hostname", m.hostname);
  js.set("provenance.machine.cpu_model", m.cpu_model);
  js.set("provenance.machine.logical_cpus", static_cast<int>(m.logical_cpus));
  js.set("provenance.machine.os", m.os);
  js.set("provenance.machine.memory_gb", m.memory_gb);
  js.set("provenance.machine.load_1min_at_end", m.load_1min);
  // How OpenMP's idle threads waited (the `orpe` CLI sets passive unless told otherwise).
  const char* wait = std::getenv("OMP_WAIT_POLICY");
  js.set("provenance.omp_wait_policy", std::string(wait != nullptr ? wait : "unset"));
}

nlohmann::json pose_json(const SE3& T) {
  nlohmann::json j;
  const Mat4 M = T.matrix();
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < 4; ++r) rows.push_back({M(r, 0), M(r, 1), M(r, 2), M(r, 3)});
  j["matrix"] = rows;
  const Eigen::Quaterniond q = T.quaternion();
  j["t_m"] = {T.translation().x(), T.translation().y(), T.translation().z()};
  j["q_xyzw"] = {q.x(), q.y(), q.z(), q.w()};
  return j;
}

double peak_rss_mb() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return ru.ru_maxrss / 1024.0;  // kilobytes on Linux
}

// --render-view: a PNG name, inside the output folder unless absolute.
void check_render_view(const std::string& name) {
  if (name.empty()) return;
  namespace fs = std::filesystem;
  const fs::path p(name);
  std::string ext = p.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext != ".png")
    throw ConfigError("--render-view '" + name + "': the picture is written as PNG; name it *.png");
  if (!p.is_absolute()) {
    for (const auto& part : p)
      if (part == "..")
        throw ConfigError("--render-view '" + name + "': a relative name must stay inside --out");
    return;
  }
  std::error_code ec;
  if (fs::is_directory(p, ec)) throw ConfigError("--render-view '" + name + "' is a folder");
  if (p.has_parent_path() && fs::exists(p.parent_path(), ec) &&
      !fs::is_directory(p.parent_path(), ec))
    throw ConfigError("--render-view '" + name + "': " + p.parent_path().string() +
                      " is not a folder");
}

bool same_frame_size(const RgbdFrame& a, const RgbdFrame& b) {
  return a.depth.width() == b.depth.width() && a.depth.height() == b.depth.height() &&
         a.intrinsics == b.intrinsics;
}

}  // namespace

void write_single_view_csv(const std::string& path,
                           const std::vector<ObjectRpePipeline::SingleViewRecord>& records) {
  write_file_atomic(path, [&](std::ostream& os) {
    os << "frame,instance,class,class_probability,valid,score,mu_m,inlier_fraction,num_points,"
          "R_cam_obj,t_cam_obj_m,R_world_cam,t_world_cam_m,mask_px\n";
    auto pose = [](const SE3& T) {
      const Mat3& R = T.rotation();
      return fmt::format(
          "{:.9f} {:.9f} {:.9f} {:.9f} {:.9f} {:.9f} {:.9f} {:.9f} {:.9f},{:.9f} {:.9f} {:.9f}",
          R(0, 0), R(0, 1), R(0, 2), R(1, 0), R(1, 1), R(1, 2), R(2, 0), R(2, 1), R(2, 2),
          T.translation().x(), T.translation().y(), T.translation().z());
    };
    for (const auto& r : records)
      os << fmt::format("{},{},{},{:.6f},{},{:.6f},{:.6g},{:.4f},{},{},{},{}\n", r.frame_index,
                        r.instance_id, r.class_id, r.class_probability, r.estimate.valid ? 1 : 0,
                        r.estimate.score, r.estimate.mu_m, r.estimate.inlier_fraction,
                        r.estimate.num_points, pose(r.estimate.T_cam_obj), pose(r.T_world_cam),
                        r.mask_px);
  });
}

std::string object_poses_json(const std::vector<ObjectWorldPose>& objects,
                              const PoseVariant& variant) {
  nlohmann::json j;
  j["configuration"] = variant.name;
  j["inputs"] = {{"projected_mask", variant.projected_mask},
                 {"projected_depth", variant.projected_depth},
                 {"projected_color", variant.projected_color},
                 {"ekf", variant.ekf}};
  j["frames"] =
      "world = the SLAM map's frame (the first camera, or the dataset's world when the "
      "first frame has a ground-truth pose and pipeline.init_from_ground_truth is on)";
  j["covariance"] = "6x6, body-frame tangent [rho; phi] of T_world_obj (m^2, rad^2), row-major";
  j["objects"] = nlohmann::json::array();
  for (const auto& o : objects) {
    nlohmann::json r;
    r["instance_id"] = o.instance_id;
    r["class_id"] = o.class_id;
    r["class_name"] = o.class_name;
    r["class_probability"] = o.class_probability;
    r["detections"] = o.detections;
    r["surfels"] = o.surfels;
    r["valid"] = o.valid;
    r["source"] = o.source;
    r["model_symmetry"] = o.model_symmetry;
    r["model_colour"] = o.model_colour;
    r["num_views"] = o.num_views;
    r["num_rejected"] = o.num_rejected;
    r["num_reinitialisations"] = o.num_reinitialisations;
    r["T_world_obj"] = o.valid ? pose_json(o.T_world_obj) : nlohmann::json(nullptr);
    if (o.has_covariance) {
      nlohmann::json cov = nlohmann::json::array();
      for (int a = 0; a < 6; ++a)
        for (int b = 0; b < 6; ++b) cov.push_back(o.covariance(a, b));
      r["covariance"] = cov;
    } else {
      r["covariance"] = nullptr;
    }
    j["objects"].push_back(r);
  }
  return j.dump(2);
}

std::string RunSummary::report() const {
  std::string s = fmt::format(
      "orpe run ({}): {} frames ({} skipped), {} keyframes, {} evaluated; "
      "{} surfels, {} instances\n",
      mode, frames, skipped_frames, stats.keyframes, stats.evaluated_frames, surfels, instances);
  if (stats.lost_frames || stats.degraded_frames)
    s += fmt::format("tracking: {} degraded, {} lost frames\n", stats.degraded_frames,
                     stats.lost_frames);
  for (size_t v = 0; v < variants.size(); ++v)
    s += fmt::format("poses [{}]: {} rows\n", variants[v], pose_rows[v]);
  if (stats.single_view_estimates)
    s += fmt::format(
        "single-view: {} estimates ({} valid, {} reused, {} from the prior, {} prior not fitting, "
        "{} skipped); EKF: {} accepted, {} gated\n",
        stats.single_view_estimates, stats.single_view_valid, stats.single_view_cache_hits,
        stats.single_view_from_prior, stats.single_view_prior_not_fitting,
        stats.single_view_skipped, stats.ekf_accepted, stats.ekf_rejected);
  const double n = std::max(frames, 1);
  s += fmt::format(
      "time per frame: read {:.0f} ms, slam {:.0f} ms, semantic {:.0f} ms, render {:.0f} ms, "
      "single-view {:.0f} ms, ekf {:.1f} ms; wall {:.1f} s\n",
      read_ms / n, stats.slam_ms / n, stats.semantic_ms / n, stats.render_ms / n,
      stats.single_view_ms / n, stats.ekf_ms / n, wall_ms / 1000);
  s += fmt::format("frames/s {:.1f}; map {:.1f} MB; peak RSS {:.0f} MB\n",
                   frames / std::max(wall_ms / 1000, 1e-9), map_bytes / 1048576.0, peak_rss_mb);
  if (interrupted) s += "INTERRUPTED: the outputs hold the frames processed before the signal\n";
  if (no_depth_frames)
    s += fmt::format("{} frames had too little valid depth (not tracked)\n", no_depth_frames);
  if (ate_rmse_m)
    s += fmt::format("camera ATE RMSE {:.4f} m (rigid alignment to the ground truth)\n",
                     *ate_rmse_m);
  if (ate_tracked_rmse_m)
    s += fmt::format("camera ATE RMSE {:.4f} m without the {} LOST frames' rows (held poses)\n",
                     *ate_tracked_rmse_m, lost_rows);
  s += "outputs in " + out_dir + ":";
  for (const auto& f : files) s += " " + f;
  return s + "\n";
}

namespace {

/// The run's arguments checked, in the order their errors are reported (before any output).
void check_run_request(const OrpeConfig& config, const RunOptions& options) {
  if (options.mode != "slam" && options.mode != "semantic" && options.mode != "full")
    throw ConfigError("run: unknown mode '" + options.mode + "' (slam | semantic | full)");
  if (options.out_dir.empty()) throw ConfigError("run: no output folder");
  std::string why;
  if (!config.IsValid(&why)) throw ConfigError("invalid configuration: " + why);
}

/// The pipeline's parameters for the run's mode and pose variants.
ObjectRpeParams run_params(const OrpeConfig& config, const RunOptions& options) {
  ObjectRpeParams params = ObjectRpeParams::from_config(config);
  params.semantic_mapping = options.mode != "slam";
  params.variants.clear();
  if (options.mode == "full") {
    if (options.ablations.empty()) {
      params.variants.push_back(PoseVariant::from(config.pipeline));
    } else {
      for (const auto& name : options.ablations)
        params.variants.push_back(PoseVariant::named(name));
    }
  }
  return params;
}

/// The dataset and the output options that can only be checked once it is open.
void check_dataset_and_outputs(const DatasetReader& reader, const RunOptions& options) {
  if (reader.size() == 0)
    throw IoError(options.dataset_path,
                  "no frames selected (check dataset.first_frame/last_frame)");
  if (options.mode == "full" && reader.info().model_points_paths.empty())
    throw IoError(options.dataset_path,
                  "the dataset has no object models (full mode estimates object poses)");
  check_render_view(options.render_view);
  // NaN passes every "> 0" test and used to render a blank picture.
  for (const auto& [flag, v] :
       {std::pair{"--view-back-m", options.view_back_m}, {"--view-up-m", options.view_up_m}})
    if (!(std::isfinite(v) && v >= 0))
      throw ConfigError(fmt::format(
          "{} {}: must be a finite distance >= 0 (m; 0 = frame automatically)", flag, v));
}

using ProgressFn = std::function<void(const std::string&)>;

/// What the frame loop leaves for the outputs and the summary.
struct FrameLoop {
  FrameLog frame_log;
  std::vector<std::string> skipped;  ///< every frame left out, with why (unreadable, size)
};

/// Every frame of `reader` through the pipeline (until the end or a stop request), then the
/// keyframes still waiting for their segmentation and the pipeline's finalisation. Fills the
/// frame counts of `summary`; throws when no frame could be used.
FrameLoop run_frames(ObjectRpePipeline& pipeline, const DatasetReader& reader,
                     const OrpeConfig& config, const RunOptions& options, MaskRecorder* masks,
                     const ProgressFn& progress, RunSummary& summary) {
  FrameLoop loop;
  std::vector<std::string> wrong_size;  // frames left out: their size differs from the first's
  FrameStream stream(reader);
  RgbdFrame frame, first_frame;
  const int every = config.pipeline.progress_every_n_frames;
  const size_t total = reader.size();
  auto record_masks = [&](const PipelineFrameResult& r) {
    if (masks && r.keyframe)
      masks->record(*pipeline.segmented_frame(), pipeline.segmented_T_world_cam(),
                    pipeline.slam().map(), *pipeline.semantic());
  };
  while (true) {
    if (options.stop_requested && options.stop_requested()) {
      summary.interrupted = true;
      spdlog::warn("interrupted after {} frames: writing their outputs (marked interrupted)",
                   summary.frames);
      break;
    }
    const auto t_read = Clock::now();
    if (!stream.next(frame)) break;
    const double read_ms = ms_since(t_read);
    summary.read_ms += read_ms;
    if (summary.frames == 0) {
      first_frame.depth = frame.depth;
      first_frame.intrinsics = frame.intrinsics;
    } else if (!same_frame_size(frame, first_frame)) {
      const std::string msg =
          fmt::format("frame {} ('{}'): {}x{} or intrinsics differ from the first frame's {}x{}",
                      frame.index, frame.name, frame.depth.width(), frame.depth.height(),
                      first_frame.depth.width(), first_frame.depth.height());
      spdlog::warn("skipping {}", msg);
      wrong_size.push_back(msg);
      continue;
    }
    const PipelineFrameResult& r = pipeline.process(frame);
    loop.frame_log.add(r, read_ms, pipeline.slam().map().size(), pipeline.slam().map().bytes());
    ++summary.frames;
    summary.no_depth_frames += r.slam.no_depth;
    spdlog::debug("{}", r.slam.report());
    record_masks(r);
    if (every > 0 && (summary.frames % every == 0 || summary.frames == static_cast<int>(total)))
      progress(fmt::format("[{:4d}/{}] {}", summary.frames, total, r.report()));
  }
  summary.wrong_size_frames = static_cast<int>(wrong_size.size());
  summary.skipped_frames = static_cast<int>(stream.skipped() + wrong_size.size());
  for (const auto& [pos, msg] : stream.skipped_frames()) loop.skipped.push_back(msg);
  loop.skipped.insert(loop.skipped.end(), wrong_size.begin(), wrong_size.end());
  if (summary.frames == 0 && summary.interrupted)
    throw Interrupted("interrupted before the first frame was processed; nothing written");
  if (summary.frames == 0)
    throw IoError(options.dataset_path, "no readable frame (every selected frame failed to load)");
  if (summary.no_depth_frames == summary.frames)
    throw IoError(
        options.dataset_path,
        fmt::format("no frame had usable depth ({} frames; depth read at {} units per metre, "
                    "valid between slam_preprocess.min_depth_m and max_depth_m): check "
                    "dataset.depth_units_per_m and the depth images",
                    summary.frames, reader.info().depth_units_per_m));
  // Keyframes still waiting for their segmentation delay (pipeline.segmentation_delay_frames).
  while (pipeline.flush_one()) record_masks(pipeline.last_result());
  pipeline.finalize();
  return loop;
}

/// The per-variant pose files: poses.csv (and poses_final.csv with the EKF), single_view.csv,
/// objects.json; the first variant at the top, every variant under ablation/NAME/ in an ablation.
void write_pose_outputs(const ObjectRpePipeline& pipeline, const RunOptions& options,
                        const DatasetInfo& info, const std::string& out, RunSummary& summary) {
  namespace fs = std::filesystem;
  auto path = [&](const std::string& name) { return (fs::path(out) / name).string(); };
  if (pipeline.num_variants() > 0) {
    // The evaluated frames as a YCB-Video keyframe list (`orpe eval poses --keyframes`), so that
    // frames without pose estimates on purpose are not scored as misses.
    write_file_atomic(path("evaluated_frames.txt"), [&](std::ostream& os) {
      for (int f : pipeline.evaluated_frames())
        os << fmt::format("{:04d}/{:06d}\n", info.scene_id, f);
    });
    summary.files.push_back("evaluated_frames.txt");
  }
  for (size_t v = 0; v < pipeline.num_variants(); ++v) {
    const PoseVariant& variant = pipeline.variant(v);
    summary.pose_rows.push_back(pipeline.pose_rows(v).size());
    std::vector<std::string> dirs;
    if (v == 0) dirs.push_back("");
    if (!options.ablations.empty()) dirs.push_back("ablation/" + variant.name + "/");
    for (const auto& dir : dirs) {
      write_bop_results(path(dir + "poses.csv"), pipeline.pose_rows(v));
      summary.files.push_back(dir + "poses.csv");
      if (variant.ekf) {
        write_bop_results(path(dir + "poses_final.csv"), pipeline.final_pose_rows(v));
        summary.files.push_back(dir + "poses_final.csv");
      }
      write_single_view_csv(path(dir + "single_view.csv"), pipeline.single_view_records(v));
      summary.files.push_back(dir + "single_view.csv");
      const std::string objects = object_poses_json(pipeline.object_poses(v), variant);
      write_file_atomic(path(dir + "objects.json"),
                        [&](std::ostream& os) { os << objects << "\n"; });
      summary.files.push_back(dir + "objects.json");
    }
  }
}

/// --render-view: a picture of the map from a fixed 640x480 viewer camera.
void write_render_view(const ObjectRpePipeline& pipeline, const RunOptions& options,
                       const std::string& out, float min_conf, RunSummary& summary) {
  namespace fs = std::filesystem;
  const std::string render_png = fs::path(options.render_view).is_absolute()
                                     ? options.render_view
                                     : (fs::path(out) / options.render_view).string();
  PinholeIntrinsics K;  // a fixed 640x480 viewer camera, whatever the dataset's
  K.width = 640;
  K.height = 480;
  K.fx = K.fy = 420.0;
  K.cx = 319.5;
  K.cy = 239.5;
  const auto& traj = pipeline.trajectory();
  const auto& map = pipeline.slam().map();
  const SE3& first = traj.front().T_world_cam;
  // Framed on the objects (else the map), seen from the first camera's side; a fixed offset only
  // when one is asked for, or for a map too small to have a box.
  const Eigen::AlignedBox3d box = slam::map_focus_box(map, min_conf);
  const bool fixed = options.view_back_m > 0 || options.view_up_m > 0 || box.isEmpty();
  const SE3 view = fixed ? slam::overview_pose(map, first, min_conf,
                                               options.view_back_m > 0 ? options.view_back_m : 1.5,
                                               options.view_up_m > 0 ? options.view_up_m : 0.6)
                         : slam::framing_pose(box, first, K);
  slam::MapRenderer viewer;
  write_color_png(render_png, slam::render_map_image(viewer, map, view, K, min_conf));
  summary.files.push_back(fs::path(options.render_view).is_absolute()
                              ? options.render_view
                              : fs::path(render_png).lexically_relative(out).string());
}

/// Every output file of the run but summary.json, each written atomically into `out`.
void write_run_outputs(const ObjectRpePipeline& pipeline, const OrpeConfig& config,
                       const RunOptions& options, const DatasetInfo& info, const FrameLoop& loop,
                       MaskRecorder* masks, const std::string& out, RunSummary& summary) {
  namespace fs = std::filesystem;
  auto path = [&](const std::string& name) { return (fs::path(out) / name).string(); };
  write_tum_trajectory(path("trajectory.txt"), pipeline.trajectory());
  summary.files.push_back("trajectory.txt");
  loop.frame_log.write(path("frames.csv"));
  summary.files.push_back("frames.csv");
  const float min_conf = static_cast<float>(config.pipeline.output_min_confidence);
  slam::write_surfel_ply(path("map.ply"), pipeline.slam().map(), min_conf);
  summary.files.push_back("map.ply");
  summary.surfels = pipeline.slam().map().size();
  if (const SemanticMapper* semantic = pipeline.semantic()) {
    write_semantic_outputs(out, pipeline.slam().map(), semantic->fusion().instances(),
                           info.class_names, min_conf);
    summary.files.insert(summary.files.end(),
                         {"semantic_map.ply", "semantic_map_instances.ply", "instances.json"});
    summary.instances = static_cast<int>(semantic->fusion().instances().size());
  }
  if (masks) {
    const std::string scene = !config.dataset.scene.empty() ? config.dataset.scene
                              : info.format == "bop"        ? fmt::format("{:06d}", info.scene_id)
                              : info.format == "ycbv"       ? fmt::format("{:04d}", info.scene_id)
                                                            : std::string();
    masks->finish(options.dataset_path, info.format, scene);
    summary.files.push_back("masks/index.json");
  }
  write_pose_outputs(pipeline, options, info, out, summary);
  if (!options.render_view.empty()) write_render_view(pipeline, options, out, min_conf, summary);
}

/// summary.json's dataset, camera and variant fields.
void summarise_inputs(const ObjectRpePipeline& pipeline, const RunOptions& options,
                      const DatasetInfo& info, size_t selected, const FrameLoop& loop,
                      const RunSummary& summary, JsonSummary& js) {
  js.set("orpe_version", std::string(kVersion));
  js.set("mode", options.mode);
  js.set("complete", !summary.interrupted);
  js.set("interrupted", summary.interrupted);
  write_provenance(options, js);
  js.set("dataset.path", options.dataset_path);
  js.set("dataset.format", info.format);
  js.set("dataset.scene_id", info.scene_id);
  js.set("dataset.frames_selected", static_cast<int>(selected));
  js.set("dataset.frames_processed", summary.frames);
  js.set("dataset.frames_skipped", summary.skipped_frames);
  js.set("dataset.skipped_messages", loop.skipped);
  js.set("dataset.frames_wrong_size", summary.wrong_size_frames);
  write_camera_and_models(info, js);
  js.set("single_view_estimator",
         pipeline.single_view_estimator() ? pipeline.single_view_estimator()->name() : "none");
  // The mask threshold in pixels at this camera's size (pipeline.min_pose_mask_px 0 = auto).
  js.set("single_view_min_mask_px", pipeline.params().pipeline.min_pose_mask_px_for(
                                        info.intrinsics.width, info.intrinsics.height));
  js.set("variants", summary.variants);
  for (size_t v = 0; v < pipeline.num_variants(); ++v) {
    const PoseVariant& variant = pipeline.variant(v);
    const std::string key = "variant." + variant.name;
    js.set(key + ".projected_mask", variant.projected_mask);
    js.set(key + ".projected_depth", variant.projected_depth);
    js.set(key + ".projected_color", variant.projected_color);
    js.set(key + ".ekf", variant.ekf);
    js.set(key + ".pose_rows", summary.pose_rows[v]);
    js.set(key + ".directory",
           options.ablations.empty() ? std::string(".") : "ablation/" + variant.name);
  }
}

/// summary.json's trajectory_eval_tracked: the camera ATE without the rows of LOST frames (their
/// held poses), next to trajectory_eval's over every row; only when some frame was LOST.
void summarise_tracked_ate(const std::vector<StampedPose>& gt,
                           const std::vector<StampedPose>& trajectory,
                           const std::vector<FrameLogRecord>& records, const OrpeConfig& config,
                           RunSummary& summary, JsonSummary& js) {
  if (records.size() != trajectory.size()) return;  // an interrupted run's partial frame
  const std::vector<StampedPose> tracked = tracked_rows(trajectory, records);
  summary.lost_rows = static_cast<int>(trajectory.size() - tracked.size());
  if (summary.lost_rows == 0 || tracked.empty()) return;
  const TrajectoryEvaluation ev = evaluate_trajectory(gt, tracked, config.eval_trajectory);
  if (ev.matches.empty()) return;
  nlohmann::json j = nlohmann::json::parse(ev.to_json());
  j["lost_rows_left_out"] = summary.lost_rows;
  js.set_json("trajectory_eval_tracked", j.dump());
  summary.ate_tracked_rmse_m = ev.ate.translation_m.rmse;
}

/// summary.json's counts, tracking events and memory.
void summarise_counts(const ObjectRpePipeline& pipeline, RunSummary& summary, JsonSummary& js) {
  const PipelineStats& st = summary.stats;
  js.set("counts.frames", st.frames);
  js.set("counts.keyframes", st.keyframes);
  js.set("counts.evaluated_frames", st.evaluated_frames);
  js.set("counts.tracking_degraded", st.degraded_frames);
  js.set("counts.tracking_lost", st.lost_frames);
  js.set("counts.relocalisations", static_cast<int>(st.relocalised_frames.size()));
  auto frame_pairs = [&](const std::vector<std::pair<int, int>>& pairs, const std::string& frames,
                         const std::string& keyframes) {
    std::vector<double> f, k;  // frame indices (JSON numbers)
    for (auto [a, b] : pairs) f.push_back(a), k.push_back(b);
    js.set(frames, f);
    js.set(keyframes, k);
  };
  frame_pairs(st.relocalised_frames, "tracking.relocalised_frames",
              "tracking.relocalised_against_keyframes");
  js.set("tracking.keyframes_stored", static_cast<int>(pipeline.slam().keyframes()));
  js.set("counts.loop_closures", static_cast<int>(st.loop_closures.size()));
  frame_pairs(st.loop_closures, "tracking.loop_closure_frames", "tracking.loop_closure_keyframes");
  js.set("counts.no_depth_frames", summary.no_depth_frames);
  js.set("counts.detections", st.detections);
  js.set("counts.instances", summary.instances);
  js.set("counts.surfels", summary.surfels);
  summary.map_bytes = pipeline.slam().map().bytes();
  js.set("memory.map_bytes", summary.map_bytes);
  summary.peak_rss_mb = peak_rss_mb();
  js.set("memory.peak_rss_mb", summary.peak_rss_mb);
}

/// summary.json's single-view counts and the time per stage.
void summarise_timing(const RunSummary& summary, JsonSummary& js) {
  const PipelineStats& st = summary.stats;
  js.set("counts.single_view_estimates", st.single_view_estimates);
  js.set("counts.single_view_valid", st.single_view_valid);
  js.set("counts.single_view_reused", st.single_view_cache_hits);
  js.set("counts.single_view_from_prior", st.single_view_from_prior);
  js.set("counts.single_view_prior_not_fitting", st.single_view_prior_not_fitting);
  js.set("counts.single_view_skipped", st.single_view_skipped);
  js.set("counts.ekf_accepted", st.ekf_accepted);
  js.set("counts.ekf_rejected", st.ekf_rejected);
  js.set("counts.colour_views_learned", st.colour_views_learned);
  js.set("counts.projected_scene_reused", st.projected_scene_reused);
  const double n = std::max(summary.frames, 1);
  js.set("timing_ms.total.read", summary.read_ms);
  js.set("timing_ms.total.slam", st.slam_ms);
  js.set("timing_ms.total.semantic", st.semantic_ms);
  js.set("timing_ms.total.semantic_segment", st.semantic_segment_ms);
  js.set("timing_ms.total.semantic_render", st.semantic_render_ms);
  js.set("timing_ms.total.semantic_associate", st.semantic_associate_ms);
  js.set("timing_ms.total.semantic_update", st.semantic_update_ms);
  js.set("timing_ms.total.semantic_guards", st.semantic_guards_ms);
  js.set("timing_ms.total.render_views", st.render_ms);
  js.set("timing_ms.total.single_view", st.single_view_ms);
  js.set("timing_ms.total.ekf", st.ekf_ms);
  js.set("timing_ms.total.pipeline", st.total_ms);
  js.set("timing_ms.total.output", summary.output_ms);
  js.set("timing_ms.total.segmentation_wait", st.segmentation_wait_ms);
  js.set("timing_ms.total.model_loading", st.model_loading_ms);
  js.set("timing_ms.total.wall", summary.wall_ms);
  js.set("timing_ms.per_frame.read", summary.read_ms / n);
  js.set("timing_ms.per_frame.slam", st.slam_ms / n);
  js.set("timing_ms.per_frame.semantic", st.semantic_ms / n);
  js.set("timing_ms.per_frame.render_views", st.render_ms / n);
  js.set("timing_ms.per_frame.single_view", st.single_view_ms / n);
  js.set("timing_ms.per_frame.ekf", st.ekf_ms / n);
  js.set("timing_ms.per_frame.pipeline", st.total_ms / n);
  js.set("timing_ms.per_evaluated_frame.single_view",
         st.evaluated_frames ? st.single_view_ms / st.evaluated_frames : 0.0);
  if (st.single_view_estimates)
    js.set("timing_ms.per_single_view_estimate", st.single_view_ms / st.single_view_estimates);
}

}  // namespace

RunSummary run_object_rpe(const OrpeConfig& config, const RunOptions& options) {
  const auto t_start = Clock::now();
  check_run_request(config, options);
  const ObjectRpeParams params = run_params(config, options);
  const auto reader = open_dataset(options.dataset_path, config.dataset);
  const DatasetInfo& info = reader->info();
  // Every output place and name is checked before the first frame; outputs go to a staging folder.
  check_dataset_and_outputs(*reader, options);
  StagedDir staged(options.out_dir, options.overwrite, "summary.json");

  ObjectRpePipeline pipeline(params, info);
  RunSummary summary;
  summary.out_dir = options.out_dir;
  summary.mode = options.mode;
  for (size_t v = 0; v < pipeline.num_variants(); ++v)
    summary.variants.push_back(pipeline.variant(v).name);
  const ProgressFn progress = [&](const std::string& line) {
    if (options.progress)
      options.progress(line);
    else
      spdlog::info("{}", line);
  };
  progress(fmt::format("{} ({}, scene {}): {} frames, mode {}{}", options.dataset_path, info.format,
                       info.scene_id, reader->size(), options.mode,
                       summary.variants.empty()
                           ? std::string()
                           : fmt::format(", poses: {}", fmt::join(summary.variants, ", "))));
  std::unique_ptr<MaskRecorder> masks;
  if (options.write_masks) {
    if (!pipeline.semantic()) throw ConfigError("run: --write-masks needs --mode semantic or full");
    masks = std::make_unique<MaskRecorder>((std::filesystem::path(staged.dir()) / "masks").string(),
                                           static_cast<float>(config.segmentation.mask_threshold));
  }
  const FrameLoop loop =
      run_frames(pipeline, *reader, config, options, masks.get(), progress, summary);

  // Outputs, each atomic.
  const auto t_out = Clock::now();
  const std::string out = staged.dir();
  write_run_outputs(pipeline, config, options, info, loop, masks.get(), out, summary);
  summary.stats = pipeline.stats();
  summary.output_ms = ms_since(t_out);
  summary.wall_ms = ms_since(t_start);

  JsonSummary js;
  summarise_inputs(pipeline, options, info, reader->size(), loop, summary, js);
  summarise_counts(pipeline, summary, js);
  const auto gt = reader->ground_truth_trajectory();
  if (!gt.empty()) {
    const TrajectoryEvaluation ev =
        evaluate_trajectory(gt, pipeline.trajectory(), config.eval_trajectory);
    if (!ev.matches.empty()) {
      js.set_json("trajectory_eval", ev.to_json());
      summary.ate_rmse_m = ev.ate.translation_m.rmse;
    }
    summarise_tracked_ate(gt, pipeline.trajectory(), loop.frame_log.records(), config, summary, js);
  }
  summarise_timing(summary, js);
  js.set_json("config", config_to_json(config));
  summary.files.push_back("summary.json");
  js.set("files", summary.files);
  js.write((std::filesystem::path(out) / "summary.json").string());
  staged.commit();
  return summary;
}

}  // namespace orpe
