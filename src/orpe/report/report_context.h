// Internal to src/orpe/report: what the sections of the page share while it is written.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "orpe/eval/pose_metrics.h"
#include "orpe/io/dataset.h"
#include "orpe/report/report.h"
#include "orpe/report/run_record.h"

namespace orpe::report {

struct ReportContext {
  ReportOptions options;
  std::string out_dir;
  RunRecord run;
  OrpeConfig config;
  std::unique_ptr<DatasetReader> reader;  ///< null when the dataset could not be opened
  std::vector<RgbdFrame> annotations;     ///< reader->read_annotations(i) for every frame
  std::unique_ptr<PoseEvaluation> poses;  ///< poses.csv scored on the evaluated frames
  /// One colour per class of the run (estimated, ground truth, objects), well apart: the i-th
  /// class id in increasing order takes series_colour(i).
  std::map<int, Rgb8> class_colours;
  ReportResult result;

  /// Writes `image` to images/NAME and returns its path relative to the page.
  std::string save_image(const std::string& name, const ColorImage& image);
  void note(const std::string& text);  ///< a warning on stderr and on the page
  /// Class name of a class id (the dataset's, else from objects.json, else the id).
  std::string class_name(int class_id) const;
  Rgb8 class_colour(int class_id) const;
};

// The sections, each returning its HTML body.
std::string summary_section(ReportContext& c);
std::string maps_section(ReportContext& c);
std::string trajectory_section(ReportContext& c);
std::string pose_section(ReportContext& c);
std::string keyframe_section(ReportContext& c);
std::string reconstruction_section(ReportContext& c);
std::string timeline_section(ReportContext& c);
std::string provenance_section(ReportContext& c);

/// "<p class=note>TEXT</p>" (escaped).
std::string note_html(const std::string& text);
/// fmt "{:.Nf}" of a JSON number, "-" for null / missing.
std::string json_number(const nlohmann::json& v, int decimals);

}  // namespace orpe::report
