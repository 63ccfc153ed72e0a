// `orpe report --run OUT [--dataset D] [--out DIR]`: one HTML page that shows what a run did, for a
// person to look at (docs/REPORT.md). DIR/index.html, with its pictures in DIR/images/ and the
// run's configuration in DIR/config.json; no script, no network access, any browser.
//
// Sections: summary; the surfel map and the semantic map rendered from viewpoints that frame the
// scene, with the camera path and the instances' class names drawn over them; the camera trajectory
// against the ground truth (top view, per-axis error); per-class ADD-S / ADD(-S) tables and
// accuracy-threshold curves; sampled keyframes with each object's model drawn at its estimated
// pose beside the ground truth; reconstruction error per object; time per stage, map size, memory
// and tracking state over the frames; provenance (command, version, config, dataset, machine).
// Sections that need what the run or the dataset does not have (ground truth, poses, frames.csv)
// say so instead.
#pragma once

#include <string>
#include <vector>

namespace orpe::report {

struct ReportOptions {
  std::string run_dir;      ///< an `orpe run --out` folder
  std::string dataset;      ///< the dataset; empty = summary.json's dataset.path
  std::string out_dir;      ///< empty = RUN/report
  int max_keyframes = 6;    ///< keyframe pictures: at most this many, spread over the run
  int view_width_px = 640;  ///< size of the map pictures (two side by side on a wide screen)
  int view_height_px = 480;
};

struct ReportResult {
  std::string index_html;           ///< the page
  std::vector<std::string> images;  ///< the pictures written, relative to the page's folder
  std::vector<std::string> notes;   ///< what was left out and why (also on the page)
};

/// Writes the report. Throws IoError naming the file when the run folder is not readable as a run
/// (summary.json, trajectory.txt); a dataset that cannot be opened only removes the sections that
/// need it (a note says why).
ReportResult write_run_report(const ReportOptions& options);

}  // namespace orpe::report
