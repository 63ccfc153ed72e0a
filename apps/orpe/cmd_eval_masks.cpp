// `orpe eval masks`: per-frame IoU of a run's input detections and of the masks projected from its
// map against the dataset's ground-truth masks, per class and overall (eval/mask_run.h). Registered
// as a subcommand of `orpe eval` (created in cmd_eval.cpp, order 70).
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <filesystem>
#include <iostream>
#include <memory>
#include <ostream>
#include <vector>

#include "command.h"
#include "orpe/core/error.h"
#include "orpe/eval/mask_run.h"
#include "orpe/io/dataset.h"

namespace orpe::cli {
namespace {

struct MasksCommand {
  ConfigOptions options;
  std::string dataset, json_path;
  std::vector<std::string> runs;
  bool class_agnostic = false;
  int min_gt_area_px = -1;
};

void run_masks(const MasksCommand& c) {
  const OrpeConfig config = resolve_config(c.options);
  namespace fs = std::filesystem;
  MaskMetricsParams params = config.eval_masks;
  if (c.class_agnostic) params.class_agnostic_matching = true;
  if (c.min_gt_area_px >= 0) params.min_gt_area_px = c.min_gt_area_px;
  std::string why;
  if (!params.IsValid(&why)) throw ConfigError("eval masks: " + why);

  MaskRunEvaluator evaluator(params);
  for (const std::string& run : c.runs) {
    const std::string masks_dir = (fs::path(run) / "masks").string();
    const std::string index_path = (fs::path(masks_dir) / "index.json").string();
    if (!fs::is_regular_file(index_path))
      throw IoError(index_path,
                    "mask index does not exist (run `orpe run --mode semantic --write-masks`)");
    const MaskRunIndex index = read_mask_run_index(index_path);
    // The run's scene unless the configuration names one; the whole sequence (frames are found by
    // their number).
    DatasetParams dp = config.dataset;
    if (dp.format == "auto" && !index.dataset_format.empty()) dp.format = index.dataset_format;
    if (dp.scene.empty()) dp.scene = index.dataset_scene;
    dp.first_frame = 0;
    dp.last_frame = -1;
    dp.stride = 1;
    const auto reader = open_dataset(c.dataset, dp);
    const std::string instances_path = (fs::path(run) / "instances.json").string();
    std::map<int, int> final_classes;
    const bool have_instances = fs::is_regular_file(instances_path);
    if (have_instances)
      final_classes = read_instance_classes(instances_path);
    else
      spdlog::warn("{}: no instance table, instance checks skipped for this run", instances_path);
    evaluator.add_run(*reader, masks_dir, index, have_instances ? &final_classes : nullptr,
                      dp.scene.empty() ? run : dp.scene);
  }
  const MaskRunEvaluation ev = evaluator.result();
  std::cout << ev.report();
  if (c.json_path == "-") {
    std::cout << ev.to_json() << "\n";
  } else if (!c.json_path.empty()) {
    write_text_atomic(c.json_path, ev.to_json());
  }
}

CommandRegistrar reg(72, [](CLI::App& root) {
  CLI::App* eval = root.get_subcommand("eval");  // created by cmd_eval.cpp (order 70)
  auto c = std::make_shared<MasksCommand>();
  CLI::App* m = eval->add_subcommand(
      "masks",
      "Mask IoU of a run's input detections and of the masks projected from its map against the "
      "dataset's ground-truth masks, per class and overall (misses count 0 / matched only)");
  m->add_option("--dataset", c->dataset,
                "Dataset folder with ground-truth masks (YCB-Video label.png, BOP mask_visib)")
      ->required();
  m->add_option("--run", c->runs,
                "Output folder of `orpe run --write-masks` (masks/, instances.json); repeatable: "
                "the runs' frames are pooled (e.g. one run per video)")
      ->required();
  m->add_flag("--class-agnostic", c->class_agnostic,
              "Match masks to objects whatever their classes (mask quality alone); same as --set "
              "eval_masks.class_agnostic_matching=true");
  m->add_option(
      "--min-gt-area", c->min_gt_area_px,
      "Do not score objects with fewer visible pixels (default eval_masks.min_gt_area_px)");
  m->add_option("--json", c->json_path,
                "Also write the figures as JSON to this file ('-' = stdout)");
  add_config_options(*m, c->options);
  add_dataset_options(*m, c->options);
  m->footer(
      "Each run's scene and format come from RUN/masks/index.json (unless --set "
      "dataset.scene=...);\n"
      "frames are found by their number. Instance checks (one instance per object, right class,\n"
      "none spurious) need RUN/instances.json.");
  m->callback([c] { run_masks(*c); });
});

}  // namespace
}  // namespace orpe::cli
