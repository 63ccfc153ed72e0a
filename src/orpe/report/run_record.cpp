#include "orpe/report/run_record.h"

#include <fmt/format.h>

#include <filesystem>
#include <fstream>

#include "orpe/core/atomic_file.h"
#include "orpe/core/error.h"
#include "orpe/core/parse_number.h"
#include "orpe/io/trajectory_io.h"

namespace orpe::report {
namespace {

nlohmann::json read_json_file(const std::string& path) {
  std::ifstream is(path);
  if (!is) throw IoError(path, "cannot open");
  try {
    return nlohmann::json::parse(is);
  } catch (const nlohmann::json::exception& e) {
    throw IoError(path, std::string("not valid JSON: ") + e.what());
  }
}

/// evaluated_frames.txt: "SSSS/FFFFFF" per line.
std::vector<std::pair<int, int>> read_evaluated_frames(const std::string& path) {
  std::ifstream is(path);
  if (!is) throw IoError(path, "cannot open");
  std::vector<std::pair<int, int>> frames;
  std::string line;
  for (int n = 1; std::getline(is, line); ++n) {
    if (line.empty()) continue;
    const size_t slash = line.find('/');
    if (slash == std::string::npos)
      throw IoError(path, fmt::format("line {}: '{}' is not scene/frame", n, line));
    const std::string where = fmt::format("line {}", n);
    frames.emplace_back(parse_int_field(line.substr(0, slash), path, where),
                        parse_int_field(line.substr(slash + 1), path, where));
  }
  return frames;
}

}  // namespace

std::string RunRecord::file(const std::string& name) const {
  return (std::filesystem::path(dir) / name).string();
}

bool RunRecord::has(const std::string& name) const {
  std::error_code ec;
  return std::filesystem::is_regular_file(file(name), ec);
}

RunRecord read_run(const std::string& dir) {
  RunRecord run;
  run.dir = dir;
  if (!std::filesystem::is_directory(dir))
    throw IoError(dir, "not a folder (an `orpe run --out` folder)");
  if (!run.has("summary.json"))
    throw IoError(run.file("summary.json"), "missing: not an `orpe run` output folder");
  run.summary = read_json_file(run.file("summary.json"));
  run.mode = run.summary.value("mode", std::string("slam"));
  run.trajectory = read_tum_trajectory(run.file("trajectory.txt"));
  if (run.has("frames.csv")) run.frames = read_frame_log(run.file("frames.csv"));
  if (run.has("poses.csv")) run.poses = read_bop_results(run.file("poses.csv"));
  if (run.has("evaluated_frames.txt"))
    run.evaluated = read_evaluated_frames(run.file("evaluated_frames.txt"));
  if (run.has("objects.json")) run.objects = read_json_file(run.file("objects.json"));
  if (run.has("instances.json")) run.instances = read_json_file(run.file("instances.json"));
  return run;
}

OrpeConfig run_config(const RunRecord& run, const std::string& config_json_path) {
  const auto it = run.summary.find("config");
  if (it == run.summary.end() || !it->is_object())
    throw IoError(run.file("summary.json"), "has no \"config\" object");
  const std::string text = it->dump(2);
  write_file_atomic(config_json_path, [&](std::ostream& os) { os << text << "\n"; });
  OrpeConfig config;
  load_config_file(config, config_json_path);
  return config;
}

std::string run_dataset_path(const RunRecord& run, const std::string& override_path) {
  if (!override_path.empty()) return override_path;
  const nlohmann::json& p = summary_value(run, "dataset.path");
  return p.is_string() ? p.get<std::string>() : std::string();
}

const nlohmann::json& summary_value(const RunRecord& run, const std::string& dotted) {
  static const nlohmann::json kNull;
  const nlohmann::json* j = &run.summary;
  size_t start = 0;
  while (start <= dotted.size()) {
    const size_t dot = std::min(dotted.find('.', start), dotted.size());
    const std::string key = dotted.substr(start, dot - start);
    if (!j->is_object() || !j->contains(key)) return kNull;
    j = &(*j)[key];
    start = dot + 1;
  }
  return *j;
}

}  // namespace orpe::report
