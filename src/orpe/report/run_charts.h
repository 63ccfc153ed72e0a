// The charts of `orpe report`, each an SVG (svg_plot.h) made from a run's files.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "orpe/eval/pose_metrics.h"
#include "orpe/eval/trajectory_metrics.h"
#include "orpe/io/dataset.h"
#include "orpe/pipeline/frame_log.h"

namespace orpe::report {

/// Top view of the camera path: the estimate (rigidly aligned to the ground truth as the ATE is,
/// `ev`) against the ground truth, on the two world axes along which the ground truth spreads most.
/// Without ground truth (`gt` empty) the estimate alone, on its own two widest axes.
std::string trajectory_top_view_svg(const std::vector<StampedPose>& gt,
                                    const std::vector<StampedPose>& est,
                                    const TrajectoryEvaluation* ev);

/// Per-axis position error of the aligned estimate (x, y, z and the norm, m) over time (s).
std::string trajectory_error_svg(const std::vector<StampedPose>& gt,
                                 const std::vector<StampedPose>& est,
                                 const TrajectoryEvaluation& ev);

/// Accuracy-threshold curves: the share of ground-truth instances (misses included) whose ADD-S
/// (`add_or_adds` false) or ADD(-S) distance is below a threshold from 0 to `max_m`, one curve per
/// class and one for all instances pooled (black). `colours`: per class (grey for a class not in
/// it).
std::string accuracy_curves_svg(const PoseEvaluation& ev, bool add_or_adds, double max_m,
                                const std::map<int, Rgb8>& colours);

/// Time per stage per frame (ms) over the frames.
std::string stage_time_svg(const std::vector<FrameLogRecord>& frames);
/// Surfels in the map over the frames.
std::string surfel_count_svg(const std::vector<FrameLogRecord>& frames);
/// Map arrays and process resident memory (MB) over the frames.
std::string memory_svg(const std::vector<FrameLogRecord>& frames);
/// Tracking state (OK / DEGRADED / LOST) over the frames.
std::string tracking_state_svg(const std::vector<FrameLogRecord>& frames);

}  // namespace orpe::report
