#include "orpe/pipeline/frame_log.h"

#include <fmt/format.h>
#include <unistd.h>

#include <fstream>
#include <sstream>

#include "orpe/core/atomic_file.h"
#include "orpe/core/error.h"
#include "orpe/core/parse_number.h"

namespace orpe {
namespace {

constexpr const char* kHeader =
    "frame,timestamp_s,status,keyframe,evaluated,detections,instances,surfels,map_mb,rss_mb,"
    "read_ms,slam_ms,semantic_ms,render_ms,single_view_ms,ekf_ms,total_ms";

std::vector<std::string> split_csv(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream ss(line);
  for (std::string cell; std::getline(ss, cell, ',');) cells.push_back(cell);
  return cells;
}

FrameLogRecord parse_record(const std::vector<std::string>& c, const std::string& path, int line) {
  const std::string where = fmt::format("line {}", line);
  if (c.size() != 17)
    throw IoError(path, fmt::format("{}: {} fields, expected 17", where, c.size()));
  auto num = [&](size_t i) {
    return parse_finite_field(c[i], path, fmt::format("{}, field {}", where, i + 1));
  };
  FrameLogRecord r;
  r.frame = static_cast<int>(num(0));
  r.timestamp_s = num(1);
  r.status = c[2];
  if (r.status != "OK" && r.status != "DEGRADED" && r.status != "LOST")
    throw IoError(path, where + ": status '" + r.status + "' is not OK, DEGRADED or LOST");
  r.keyframe = num(3) != 0, r.evaluated = num(4) != 0;
  r.detections = static_cast<int>(num(5)), r.instances = static_cast<int>(num(6));
  r.surfels = static_cast<size_t>(num(7));
  r.map_mb = num(8), r.rss_mb = num(9), r.read_ms = num(10), r.slam_ms = num(11);
  r.semantic_ms = num(12), r.render_ms = num(13), r.single_view_ms = num(14), r.ekf_ms = num(15);
  r.total_ms = num(16);
  return r;
}

}  // namespace

double resident_memory_mb() {
  std::ifstream is("/proc/self/statm");
  long pages_total = 0, pages_resident = 0;
  if (!(is >> pages_total >> pages_resident)) return 0;
  return static_cast<double>(pages_resident) * static_cast<double>(sysconf(_SC_PAGESIZE)) /
         1048576.0;
}

void FrameLog::add(const PipelineFrameResult& r, double read_ms, size_t surfels, size_t map_bytes) {
  FrameLogRecord f;
  f.frame = r.frame_index;
  f.timestamp_s = r.timestamp_s;
  f.status = slam::to_string(r.slam.status);
  f.keyframe = r.keyframe, f.evaluated = r.evaluated;
  f.detections = r.detections, f.instances = r.instances;
  f.surfels = surfels;
  f.map_mb = static_cast<double>(map_bytes) / 1048576.0;
  f.rss_mb = resident_memory_mb();
  f.read_ms = read_ms, f.slam_ms = r.slam_ms, f.semantic_ms = r.semantic_ms;
  f.render_ms = r.render_ms, f.single_view_ms = r.single_view_ms, f.ekf_ms = r.ekf_ms;
  f.total_ms = r.total_ms;
  records_.push_back(f);
}

void FrameLog::write(const std::string& path) const {
  write_file_atomic(path, [&](std::ostream& os) {
    os << kHeader << "\n";
    for (const auto& r : records_)
      os << fmt::format(
          "{},{:.6f},{},{},{},{},{},{},{:.3f},{:.1f},{:.2f},{:.2f},{:.2f},{:.2f},{:.2f},{:.3f},{:."
          "2f}\n",
          r.frame, r.timestamp_s, r.status, r.keyframe ? 1 : 0, r.evaluated ? 1 : 0, r.detections,
          r.instances, r.surfels, r.map_mb, r.rss_mb, r.read_ms, r.slam_ms, r.semantic_ms,
          r.render_ms, r.single_view_ms, r.ekf_ms, r.total_ms);
  });
}

std::vector<StampedPose> tracked_rows(const std::vector<StampedPose>& trajectory,
                                      const std::vector<FrameLogRecord>& records) {
  if (trajectory.size() != records.size())
    throw std::invalid_argument(fmt::format("tracked_rows: {} trajectory rows for {} frames",
                                            trajectory.size(), records.size()));
  std::vector<StampedPose> out;
  for (size_t i = 0; i < records.size(); ++i)
    if (records[i].status != "LOST") out.push_back(trajectory[i]);
  return out;
}

std::vector<FrameLogRecord> read_frame_log(const std::string& path) {
  std::ifstream is(path);
  if (!is) throw IoError(path, "cannot open the frame log");
  std::string line;
  if (!std::getline(is, line) || line != kHeader)
    throw IoError(path,
                  "line 1: not a frames.csv header (expected '" + std::string(kHeader) + "')");
  std::vector<FrameLogRecord> records;
  for (int n = 2; std::getline(is, line); ++n) {
    if (line.empty()) continue;
    records.push_back(parse_record(split_csv(line), path, n));
  }
  return records;
}

}  // namespace orpe
