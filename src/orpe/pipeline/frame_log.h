// OUT/frames.csv of `orpe run`: one line per processed frame, so that what happens over time (time
// per stage, map size, memory, tracking state) can be plotted (`orpe report`, docs/REPORT.md).
//
//   frame,timestamp_s,status,keyframe,evaluated,detections,instances,surfels,map_mb,rss_mb,
//   read_ms,slam_ms,semantic_ms,render_ms,single_view_ms,ekf_ms,total_ms
//
// status: OK | DEGRADED | LOST (slam::TrackingStatus); keyframe / evaluated: 0 or 1 (this call
// fused a keyframe's detections / estimated poses); map_mb: the surfel arrays (SurfelMap::bytes)
// after the frame; rss_mb: the process's resident memory after the frame (/proc/self/statm); times:
// wall milliseconds of this frame's call (read = decoding the frame's files).
#pragma once

#include <string>
#include <vector>

#include "orpe/pipeline/object_rpe.h"

namespace orpe {

struct FrameLogRecord {
  int frame = 0;
  double timestamp_s = 0;
  std::string status = "OK";
  bool keyframe = false, evaluated = false;
  int detections = 0, instances = 0;
  size_t surfels = 0;
  double map_mb = 0, rss_mb = 0;
  double read_ms = 0, slam_ms = 0, semantic_ms = 0, render_ms = 0, single_view_ms = 0, ekf_ms = 0,
         total_ms = 0;
};

/// The records of a run, in processing order.
class FrameLog {
 public:
  /// Appends the record of one processed frame (`map_bytes`: SurfelMap::bytes after it).
  void add(const PipelineFrameResult& r, double read_ms, size_t surfels, size_t map_bytes);
  const std::vector<FrameLogRecord>& records() const { return records_; }
  /// Writes frames.csv atomically. Throws IoError.
  void write(const std::string& path) const;

 private:
  std::vector<FrameLogRecord> records_;
};

/// Reads a frames.csv. Throws IoError naming the file and line for a malformed line.
std::vector<FrameLogRecord> read_frame_log(const std::string& path);

/// The rows of `trajectory` (one per processed frame, in the log's order) whose frame was not LOST.
/// A LOST frame's row holds the last good pose (docs/SLAM.md), which says nothing about where the
/// camera was; summary.json scores the trajectory with and without those rows. Throws
/// std::invalid_argument when the two differ in length.
std::vector<StampedPose> tracked_rows(const std::vector<StampedPose>& trajectory,
                                      const std::vector<FrameLogRecord>& records);

/// Resident memory of this process now (MB), from /proc/self/statm; 0 when unavailable.
double resident_memory_mb();

}  // namespace orpe
