// `orpe report --run OUT [--dataset D] [--out DIR]`: an HTML page of a run
// (src/orpe/report/report.h, docs/REPORT.md).
#include <iostream>
#include <memory>

#include "command.h"
#include "orpe/report/report.h"

namespace orpe::cli {
namespace {

CommandRegistrar reg(75, [](CLI::App& root) {
  auto o = std::make_shared<report::ReportOptions>();
  CLI::App* app = root.add_subcommand(
      "report",
      "Write an HTML page of a run for a person to look at: map renders, models drawn at the "
      "estimated poses beside the ground truth, trajectory / accuracy / time / memory charts, "
      "tables, provenance (docs/REPORT.md)");
  app->add_option("--run", o->run_dir, "Output folder of `orpe run`")
      ->required()
      ->check(CLI::ExistingDirectory);
  app->add_option("--dataset", o->dataset,
                  "The dataset the run read (default: summary.json's dataset.path), for the ground "
                  "truth and the keyframe images");
  app->add_option("--out", o->out_dir,
                  "Report folder (default RUN/report): index.html, images/, config.json");
  app->add_option("--keyframes", o->max_keyframes,
                  "Keyframe pictures: at most this many, spread over the run")
      ->check(CLI::Range(0, 1000))
      ->capture_default_str();
  app->callback([o] {
    const report::ReportResult r = report::write_run_report(*o);
    std::cout << "report: " << r.index_html << " (" << r.images.size() << " pictures";
    if (!r.notes.empty()) std::cout << ", " << r.notes.size() << " notes";
    std::cout << ")\n";
  });
});

}  // namespace
}  // namespace orpe::cli
