// `orpe colour`: colour models from annotated recordings (a LabelFusion-style workflow): every
// frame of a dataset with ground-truth object poses projects each annotated object's model samples
// into the image and averages the grey levels seen there (pose/colour_score.h,
// ModelColourAccumulator). Writes one `<class name>.colour` per class into --out, for `orpe run
// --set pipeline.model_colour_dir=DIR` on *other* recordings of the same objects.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <set>
#include <vector>

#include "command.h"
#include "orpe/core/error.h"
#include "orpe/io/dataset.h"
#include "orpe/pipeline/object_models.h"
#include "orpe/pose/colour_score.h"
#include "orpe/pose/object_model.h"

namespace orpe::cli {
namespace {

struct ColourCommand {
  ConfigOptions options;
  std::vector<std::string> datasets;
  std::string out;
  int every = 1;
  double min_visible_fraction = 0.2;
  bool overwrite = false;
};

/// The object's pixels in the frame (labels_gt == k + 1), empty when the frame has no labels.
MaskImage object_mask(const RgbdFrame& f, size_t k) {
  if (f.labels_gt.empty()) return {};
  MaskImage m(f.labels_gt.width(), f.labels_gt.height(), 0);
  for (int v = 0; v < m.height(); ++v)
    for (int u = 0; u < m.width(); ++u)
      m.at(u, v) = f.labels_gt.at(u, v) == static_cast<std::int32_t>(k + 1) ? 1 : 0;
  return m;
}

void check_out_dir(const ColourCommand& c) {
  namespace fs = std::filesystem;
  if (fs::exists(c.out) && !fs::is_directory(c.out))
    throw IoError(c.out, "--out exists and is not a folder");
  if (fs::is_directory(c.out) && !fs::is_empty(c.out) && !c.overwrite)
    throw IoError(c.out, "--out is not empty (give --overwrite to replace its colour files)");
  fs::create_directories(c.out);
}

/// Per class name: the views of one dataset added to `acc` (models from that dataset).
int accumulate(const std::string& dataset, const ColourCommand& c, const OrpeConfig& config,
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
      a->add_view(g.T_cam_obj, f.color, f.depth, object_mask(f, k), f.intrinsics);
    }
  }
  if (annotated_frames == 0)
    throw IoError(dataset, "no frame has object poses: `orpe colour` needs an annotated recording");
  return annotated_frames;
}

void run_colour(const ColourCommand& c) {
  const OrpeConfig config = resolve_config(c.options);
  check_out_dir(c);
  std::map<std::string, std::unique_ptr<ModelColourAccumulator>> acc;  // by class name
  std::string sources;
  for (const std::string& d : c.datasets) {
    accumulate(d, c, config, acc);
    sources += (sources.empty() ? "" : ", ") + d;
  }
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
    write_model_colour(c.out + "/" + name + ".colour", *colour);
  }
  std::cout << "colour models in " << c.out << " (use: --set pipeline.model_colour_dir=" << c.out
            << ")\n";
}

CommandRegistrar reg(45, [](CLI::App& root) {
  auto c = std::make_shared<ColourCommand>();
  CLI::App* app = root.add_subcommand(
      "colour",
      "Colour the object models from an annotated recording (frames with ground-truth object "
      "poses), "
      "for pipeline.model_colour_dir on other recordings. See docs/POSE.md, \"Colour\".");
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
