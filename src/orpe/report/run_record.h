// What `orpe report` reads of a run folder (`orpe run --out OUT`, pipeline/run.h): summary.json,
// trajectory.txt, frames.csv, poses.csv, evaluated_frames.txt, objects.json, instances.json.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "orpe/io/bop_results.h"
#include "orpe/io/dataset.h"
#include "orpe/pipeline/config.h"
#include "orpe/pipeline/frame_log.h"

namespace orpe::report {

struct RunRecord {
  std::string dir;
  nlohmann::json summary;
  std::string mode;                            ///< slam | semantic | full
  std::vector<StampedPose> trajectory;         ///< trajectory.txt
  std::vector<FrameLogRecord> frames;          ///< frames.csv; empty for runs without one
  std::vector<PoseResultRow> poses;            ///< poses.csv (full mode), camera-frame estimates
  std::vector<std::pair<int, int>> evaluated;  ///< evaluated_frames.txt: (scene, frame)
  nlohmann::json objects;                      ///< objects.json; null when absent
  nlohmann::json instances;                    ///< instances.json; null when absent

  std::string file(const std::string& name) const;  ///< dir / name
  bool has(const std::string& name) const;          ///< that file exists
};

/// Reads the run in `dir`. Throws IoError naming the file when summary.json or trajectory.txt is
/// missing or malformed, or another present file is malformed.
RunRecord read_run(const std::string& dir);

/// The run's configuration (summary.json "config"), also written to `config_json_path` (the
/// report's copy, loadable with --config). Throws IoError when summary.json has none.
OrpeConfig run_config(const RunRecord& run, const std::string& config_json_path);

/// The dataset the run read: `override_path` when given, else summary.json's dataset.path.
std::string run_dataset_path(const RunRecord& run, const std::string& override_path);

/// summary.json value at a dotted path ("counts.frames"), or null.
const nlohmann::json& summary_value(const RunRecord& run, const std::string& dotted);

}  // namespace orpe::report
