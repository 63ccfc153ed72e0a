// `orpe colour`: colour models from annotated recordings (a LabelFusion-style workflow): every
// frame of a dataset with ground-truth object poses projects each annotated object's model samples
// into the image and averages the grey levels seen there (pose/colour_score.h,
// ModelColourAccumulator). Writes one `<class name>.colour` per class into --out, for `orpe run
// --set pipeline.model_colour_dir=DIR` on *other* recordings of the same objects.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <iostream>
#include <map>
#include <memory>
#include <set>
#include <vector>

#include "command.h"
#include "orpe/core/atomic_file.h"
#include "orpe/core/error.h"
#include "orpe/core/frame_masks.h"
#include "orpe/core/staged_dir.h"
#include "orpe/io/dataset.h"
#include "orpe/pipeline/object_models.h"
#include "orpe/pose/colour_score.h"
#include "orpe/pose/object_model.h"

namespace orpe::cli {
namespace {

constexpr const char* kIndexFile = "colours.txt";  ///< marks a folder `orpe colour` wrote

struct ColourCommand {
  ConfigOptions options;
  std::vector<std::string> datasets;
  std::string out;
  int every = 1;
  double min_visible_fraction = 0.2;
  bool overwrite = false;
};

/// Per class name: the views of one dataset added to `acc` (models from that dataset).
void accumulate(const std::string& dataset, const ColourCommand& c, const OrpeConfig& config,
                std::map<std::string, std::unique_ptr<ModelColourAccumulator>>& acc) {
  const auto reader = open_dataset(dataset, config.dataset);
  ObjectModelLibrary models(reader->info());
  int annotated_frames = 0;
  for (size_t i = 0; i < reader->size(); i += static_cast<size_t>(c.every)) {
    const RgbdFrame f = reader->read(i);
    annotated_frames += !f.objects_gt.empty();
    for (size_t k = 0; k < f.objects_gt.size(); ++k) {
      const ObjectGroundTruth& g = f.objects_gt[k];
      if (g.visible_fraction >= 0 && g.visible_fraction < c.min_visible_fraction) continue;
      if (!models.has(g.class_id)) continue;
      auto& a = acc[models.class_name(g.class_id)];
      if (!a) a = std::make_unique<ModelColourAccumulator>(models.get(g.class_id));
      a->add_view(g.T_cam_obj, f.color, f.depth, ground_truth_mask(f, k), f.intrinsics);
    }
  }
  if (annotated_frames == 0)
    throw IoError(dataset, "no frame has object poses: `orpe colour` needs an annotated recording");
}

void run_colour(const ColourCommand& c) {
  const OrpeConfig config = resolve_config(c.options);
  // Whole or nothing, as a run's outputs (core/staged_dir.h): an existing --out is replaced only
  // with
  // --overwrite, and only when it holds an earlier `orpe colour` output (its index file).
  StagedDir staged(c.out, c.overwrite, kIndexFile);
  std::map<std::string, std::unique_ptr<ModelColourAccumulator>> acc;  // by class name
  std::string sources;
  for (const std::string& d : c.datasets) {
    accumulate(d, c, config, acc);
    sources += (sources.empty() ? "" : ", ") + d;
  }
  std::string index =
      "# orpe colour: class views samples known_fraction (sources: " + sources + ")\n";
  std::cout << fmt::format("{:<28} {:>6} {:>9} {:>8}\n", "class", "views", "samples", "known %");
  for (const auto& [name, a] : acc) {
    const auto colour = a->result(fmt::format("annotated: {} ({} views)", sources, a->views()));
    const double known = colour->size() ? 100.0 * colour->num_known() / colour->size() : 0.0;
    std::cout << fmt::format("{:<28} {:>6} {:>9} {:>8.1f}\n", name, a->views(), colour->size(),
                             known);
    if (colour->num_known() == 0) {
      spdlog::warn("{}: no sample was seen; no colour file written", name);
      continue;
    }
    write_model_colour(staged.dir() + "/" + name + ".colour", *colour);
    index += fmt::format("{} {} {} {:.4f}\n", name, a->views(), colour->size(), known / 100.0);
  }
  write_file_atomic(staged.dir() + "/" + kIndexFile, [&](std::ostream& os) { os << index; });
  staged.commit();
  std::cout << "colour models in " << c.out << " (use: --set pipeline.model_colour_dir=" << c.out
            << ")\n";
}

CommandRegistrar reg(45, [](CLI::App& root) {
  auto c = std::make_shared<ColourCommand>();
  CLI::App* app = root.add_subcommand(
      "colour",
      "Colour the object models from an annotated recording (frames with ground-truth object "
      "poses), for pipeline.model_colour_dir on other recordings. See docs/POSE.md, \"Colour\".");
  app->add_option("--dataset", c->datasets,
                  "Annotated dataset (any layout orpe reads); repeat to pool several recordings "
                  "(classes matched by name)")
      ->required();
  app->add_option("--out", c->out, "Folder for the colour files (<class name>.colour)")->required();
  app->add_option("--every", c->every, "Use every N-th frame")->check(CLI::Range(1, 100000));
  app->add_option("--min-visible-fraction", c->min_visible_fraction,
                  "Skip an object less visible than this in a frame (when the dataset says)")
      ->check(CLI::Range(0.0, 1.0));
  app->add_flag("--overwrite", c->overwrite, "Replace the colour files of a non-empty --out");
  add_config_options(*app, c->options);
  app->callback([c] { run_colour(*c); });
});

}  // namespace
}  // namespace orpe::cli
