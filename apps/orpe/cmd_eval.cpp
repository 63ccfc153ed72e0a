// `orpe eval traj|poses`: trajectory (ATE/RPE) and 6D pose (ADD-S / ADD(-S) AUC) evaluation.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <ostream>
#include <set>
#include <vector>

#include "command.h"
#include "orpe/core/error.h"
#include "orpe/eval/bop_pose_metrics.h"
#include "orpe/eval/pose_metrics.h"
#include "orpe/eval/trajectory_metrics.h"
#include "orpe/io/bop_results.h"
#include "orpe/io/dataset.h"
#include "orpe/io/trajectory_io.h"

namespace orpe::cli {
namespace {

struct TrajCommand {
  ConfigOptions options;
  std::string gt_path, est_path, json_path;
  std::optional<int> delta_frames;
  std::optional<double> max_time_difference_s;
  bool scale = false;
  bool consecutive_pairs = false;
};

void run_traj(const TrajCommand& c) {
  OrpeConfig config = resolve_config(c.options);
  TrajectoryMetricsParams params = config.eval_trajectory;
  if (c.delta_frames) params.rpe_delta_frames = *c.delta_frames;
  if (c.max_time_difference_s) params.max_time_difference_s = *c.max_time_difference_s;
  if (c.scale) params.align_scale = true;
  if (c.consecutive_pairs) params.rpe_all_pairs = false;
  std::string why;
  if (!params.IsValid(&why)) throw ConfigError("eval traj: " + why);

  require_file(c.gt_path, "ground-truth trajectory");
  require_file(c.est_path, "estimated trajectory");
  const auto gt = read_tum_trajectory(c.gt_path);
  const auto est = read_tum_trajectory(c.est_path);
  if (gt.empty()) throw IoError(c.gt_path, "no poses in the trajectory file");
  if (est.empty()) throw IoError(c.est_path, "no poses in the trajectory file");
  const TrajectoryEvaluation ev = evaluate_trajectory(gt, est, params);
  if (ev.matches.empty())
    throw IoError(
        c.est_path,
        fmt::format("no timestamp within {} s of a ground-truth timestamp in {} "
                    "(estimate {:.6f}..{:.6f} s, ground truth {:.6f}..{:.6f} s)",
                    params.max_time_difference_s, c.gt_path, est.front().timestamp_s,
                    est.back().timestamp_s, gt.front().timestamp_s, gt.back().timestamp_s));
  if (ev.matches.size() < 2)
    throw IoError(c.est_path, fmt::format("only {} pose associated with {}: a rigid alignment of one pose "
                                          "makes the ATE 0 by construction",
                                          ev.matches.size(), c.gt_path));
  if (ev.rpe.translation_m.count == 0)
    spdlog::warn("RPE: only {} associated poses, none at delta {} frames", ev.matches.size(),
                 params.rpe_delta_frames);
  std::cout << ev.report();
  if (!c.json_path.empty()) write_text_atomic(c.json_path, ev.to_json());
}

struct PosesCommand {
  ConfigOptions options;
  std::string dataset_path, json_path, keyframes_path;
  std::vector<std::string> result_paths;  ///< one run's CSV, or several runs' (merged)
  std::vector<std::string> scenes;
  bool markdown = false;
  bool bop = false;
};

/// The rows of every results file (the runs of a scale-out, docs/SCALING.md). An image may come
/// from one file only: two files with rows for the same scene and image are runs that overlap, an
/// error naming both.
std::vector<PoseResultRow> read_result_files(const std::vector<std::string>& paths) {
  std::vector<PoseResultRow> rows;
  std::map<std::pair<int, int>, size_t> image_file;  // (scene_id, im_id) -> index in paths
  for (size_t f = 0; f < paths.size(); ++f) {
    require_file(paths[f], "results CSV");
    for (auto& r : read_bop_results(paths[f])) {
      const auto [it, fresh] = image_file.emplace(std::pair{r.scene_id, r.im_id}, f);
      if (!fresh && it->second != f)
        throw IoError(paths[f], fmt::format("scene {} image {} also has rows in {}: the results "
                                            "files overlap (the same frames run twice?)",
                                            r.scene_id, r.im_id, paths[it->second]));
      rows.push_back(std::move(r));
    }
  }
  return rows;
}

void run_poses(const PosesCommand& c) {
  OrpeConfig config = resolve_config(c.options);
  std::string why;
  if (!config.eval_pose.IsValid(&why)) throw ConfigError("eval poses: " + why);
  const auto rows = read_result_files(c.result_paths);
  const std::string result_name =
      c.result_paths.size() == 1 ? c.result_paths[0]
                                 : fmt::format("{} results files", c.result_paths.size());
  std::optional<FrameSet> keyframes;
  if (!c.keyframes_path.empty()) {
    require_file(c.keyframes_path, "keyframe list");
    keyframes = read_keyframe_list(c.keyframes_path);
  }
  // Scenes: --scene (repeatable), else the keyframe list's, else the dataset section's.
  std::vector<std::string> scenes = c.scenes;
  if (scenes.empty() && keyframes) {
    const std::string format = config.dataset.format == "auto"
                                   ? detect_dataset_format(c.dataset_path)
                                   : config.dataset.format;
    std::set<int> ids;
    for (const auto& [scene, frame] : *keyframes) ids.insert(scene);
    for (int id : ids)
      scenes.push_back(format == "bop" ? fmt::format("{:06d}", id) : fmt::format("{:04d}", id));
  }
  if (scenes.empty()) scenes.push_back(config.dataset.scene);
  std::vector<std::unique_ptr<DatasetReader>> readers;
  std::vector<const DatasetReader*> reader_ptrs;
  for (const auto& scene : scenes) {
    DatasetParams params = config.dataset;
    params.scene = scene;
    if (!params.IsValid(&why)) throw ConfigError("eval poses: dataset: " + why);
    readers.push_back(open_dataset(c.dataset_path, params));
    reader_ptrs.push_back(readers.back().get());
  }
  const PoseEvaluation ev =
      evaluate_pose_results(reader_ptrs, rows, config.eval_pose, keyframes ? &*keyframes : nullptr);
  if (ev.instances.empty())
    throw IoError(c.dataset_path, keyframes ? "no object ground truth in the listed keyframes of "
                                              "the selected scenes"
                                            : "no object ground truth in the selected frames");
  if (rows.empty())
    spdlog::warn("{}: no result rows; every instance counts as a miss", result_name);
  if (ev.unmatched_rows + ev.other_scene_rows > 0)
    spdlog::info("{}: {} rows without a ground-truth instance, {} rows of other scenes (ignored)",
                 result_name, ev.unmatched_rows, ev.other_scene_rows);
  std::cout << (c.markdown ? ev.markdown() : ev.report());
  std::string json = ev.to_json();
  if (c.bop) {
    if (!config.eval_bop.IsValid(&why)) throw ConfigError("eval poses: eval_bop: " + why);
    const BopPoseEvaluation bop = evaluate_bop_pose_results(reader_ptrs, rows, config.eval_bop,
                                                            keyframes ? &*keyframes : nullptr);
    std::cout << "\n" << bop.report();
    nlohmann::json j = nlohmann::json::parse(json);
    j["bop"] = nlohmann::json::parse(bop.to_json());
    json = j.dump(2);
  }
  if (!c.json_path.empty()) write_text_atomic(c.json_path, json);
}

CommandRegistrar reg(70, [](CLI::App& root) {
  CLI::App* eval =
      root.add_subcommand("eval", "Evaluate trajectories (ATE/RPE) and 6D poses (ADD-S AUC)");
  eval->require_subcommand(1);

  auto traj = std::make_shared<TrajCommand>();
  CLI::App* t = eval->add_subcommand(
      "traj", "ATE and RPE of an estimated TUM trajectory against a ground-truth TUM trajectory");
  t->add_option("GT", traj->gt_path, "Ground-truth trajectory (TUM: t tx ty tz qx qy qz qw)")
      ->required();
  t->add_option("EST", traj->est_path, "Estimated trajectory (TUM format)")->required();
  t->add_option("--delta", traj->delta_frames, "RPE frame delta d (default 1)");
  t->add_option("--max-dt", traj->max_time_difference_s,
                "Association window in seconds (default 0.02, as TUM associate.py)");
  t->add_flag("--scale", traj->scale, "Align with scale (Sim3 Umeyama), for monocular estimates");
  t->add_flag("--consecutive-pairs", traj->consecutive_pairs,
              "RPE over pairs (0,d), (d,2d), ... (evo's default) instead of every (i, i+d)");
  t->add_option("--json", traj->json_path, "Also write the figures as JSON to this file");
  add_config_options(*t, traj->options);
  t->callback([traj] { run_traj(*traj); });

  auto poses = std::make_shared<PosesCommand>();
  CLI::App* p = eval->add_subcommand(
      "poses", "ADD-S and ADD(-S) AUC (YCB-Video toolbox) of a BOP results CSV against a dataset");
  p->add_option("--dataset", poses->dataset_path, "Dataset folder with object ground truth")
      ->required();
  p->add_option("--result", poses->result_paths,
                "Results CSV (BOP: scene_id,im_id,obj_id,score,R,t,time; t in mm); repeat to merge "
                "the runs of several scenes into one table (docs/SCALING.md)")
      ->required();
  p->add_option(
      "--scene", poses->scenes,
      "YCB-Video video / BOP scene, repeatable (default: the keyframe list's scenes, else "
      "dataset.scene)");
  p->add_option("--keyframes", poses->keyframes_path,
                "Evaluate only these frames: YCB-Video keyframe.txt ('0048/000001' per line)");
  p->add_option("--json", poses->json_path, "Also write the figures as JSON to this file");
  p->add_flag("--markdown", poses->markdown, "Print the table as Markdown");
  p->add_flag(
      "--bop", poses->bop,
      "Also the BOP 2019-2023 average recall: VSD, MSSD, MSPD and their mean AR (BOP layout: "
      "models_info.json; bop_toolkit's thresholds; --json adds them under \"bop\")");
  add_config_options(*p, poses->options);
  add_dataset_options(*p, poses->options);
  p->callback([poses] { run_poses(*poses); });
});

}  // namespace
}  // namespace orpe::cli
