// `orpe synth`: generates a synthetic RGB-D sequence with exact ground truth in BOP layout.
#include <spdlog/spdlog.h>

#include <iostream>
#include <memory>

#include "command.h"
#include "orpe/core/error.h"
#include "orpe/synth/generator.h"

namespace orpe::cli {
namespace {

struct SynthCommand {
  ConfigOptions options;
  std::string out;
  SynthParams p;  // CLI values; applied over the config only where given
  std::string noise = "on";
  std::vector<std::string> models;
};

CommandRegistrar reg(20, [](CLI::App& root) {
  auto s = std::make_shared<SynthCommand>();
  CLI::App* app = root.add_subcommand(
      "synth",
      "Generate a synthetic RGB-D sequence with exact ground truth (BOP layout): known objects "
      "resting on a floor, "
      "table or shelf, seen by a hand-held structured-light camera. See docs/SYNTH.md.");
  app->add_option("--out", s->out,
                  "Output folder: a BOP dataset, the scene in DIR/test/000000 (created)")
      ->required();
  app->add_option("--seed", s->p.seed,
                  "Random seed; the same seed and options give byte-identical output")
      ->capture_default_str();
  app->add_option("--frames", s->p.frames, "Number of frames (30 Hz)")->capture_default_str();
  app->add_option("--objects", s->p.objects, "Number of object instances")->capture_default_str();
  app->add_option("--scene", s->p.scene,
                  "Environment: floor | table | shelf | room (6 x 6 m, a rack on each wall; needs "
                  "--trajectory loop)")
      ->check(CLI::IsMember({"floor", "table", "shelf", "room"}))
      ->capture_default_str();
  app->add_option("--trajectory", s->p.trajectory,
                  "Camera path: arc (hand-held, around the scene) | loop (a closed circle that "
                  "returns to its start and overlaps it by synth.loop_overlap_deg; in the room it "
                  "looks out at the racks)")
      ->check(CLI::IsMember({"arc", "loop"}))
      ->capture_default_str();
  app->add_option(
         "--models", s->models,
         "OBJ/PLY files or folders (a folder of meshes, or YCB-style <class>/textured_simple.obj); "
         "comma-separated or repeated. Default: the built-in warehouse set")
      ->delimiter(',');
  app->add_option(
         "--model-unit-m", s->p.model_unit_m,
         "Metres per model-file unit (0.001 for millimetres); 0 = guess from the model size")
      ->capture_default_str();
  app->add_flag("--repeat-types", s->p.repeat_types,
                "Allow several instances of one object type (sharing an obj_id); default: one type "
                "per instance");
  app->add_option(
         "--distractors", s->p.distractors,
         "Distractors: plain-coloured boxes and cylinders unlike the objects, placed among "
         "them but not targets (scene_gt_distractors.json, distractor/, "
         "models_distractors/; not in scene_gt.json, masks or models/); 0 = none")
      ->capture_default_str();
  app->add_option("--symmetries", s->p.symmetries,
                  "models_info.json symmetries (what ADD(-S) scores with ADD-S): shape = of the "
                  "geometry | appearance = only those the print keeps too (a box whose front and "
                  "back labels differ is not symmetric)")
      ->check(CLI::IsMember({"shape", "appearance"}))
      ->capture_default_str();
  app->add_option(
         "--noise", s->noise,
         "on: structured-light depth noise + colour noise; off: exact rendered depth and colour")
      ->check(CLI::IsMember({"on", "off"}))
      ->capture_default_str();
  app->add_option("--width", s->p.width, "Image width (pixels)")->capture_default_str();
  app->add_option("--height", s->p.height, "Image height (pixels)")->capture_default_str();
  app->add_option("--fx", s->p.fx, "Focal length x (pixels); 0 = 580 * width / 640")
      ->capture_default_str();
  app->add_option("--fy", s->p.fy, "Focal length y (pixels); 0 = fx")->capture_default_str();
  app->add_option("--cx", s->p.cx, "Principal point x (pixels); 0 = (width - 1) / 2")
      ->capture_default_str();
  app->add_option("--cy", s->p.cy, "Principal point y (pixels); 0 = (height - 1) / 2")
      ->capture_default_str();
  app->add_option("--fps", s->p.fps, "Frame rate (Hz)")->capture_default_str();
  app->add_option("--span-deg", s->p.span_deg,
                  "Azimuth swept around the scene (deg); shelf: at most 110")
      ->capture_default_str();
  app->add_option("--baseline-m", s->p.baseline_m,
                  "If > 0: distance between the first and last camera (m), overriding --span-deg")
      ->capture_default_str();
  app->add_option("--distance-m", s->p.distance_m,
                  "Mean camera distance to the scene (m); 0 = fit the scene in view")
      ->capture_default_str();
  app->add_option("--elevation-deg", s->p.elevation_deg,
                  "Mean camera elevation (deg); 0 = per scene")
      ->capture_default_str();
  app->add_option("--preview-stride", s->p.preview_stride,
                  "Write DIR/preview/NNNNNN.png (RGB | depth | masks) every N frames; 0 = none")
      ->capture_default_str();
  app->add_flag("!--no-masks", s->p.write_masks,
                "Do not write mask/ and mask_visib/ (saves time and files)");
  app->add_option("--threads", s->p.threads, "Threads; 0 = OpenMP default")->capture_default_str();
  add_config_options(*app, s->options);
  app->footer(
      "Every synth parameter (also those without an option here, e.g. depth_noise_scale, shake_m) "
      "can be set\n"
      "with --set synth.KEY=VALUE or a --config file; explicit options win. List them: orpe config "
      "| grep synth.\n"
      "Output: a BOP dataset (bop_toolkit's layout): DIR/camera.json, DIR/models/ (obj_XXXXXX.ply "
      "in mm,\n"
      "obj_XXXXXX_points.xyz in m, models_info.json), DIR/test_targets_bop19.json, "
      "DIR/synth_info.json, and the\n"
      "scene DIR/test/000000/: {rgb,depth,mask,mask_visib,instance,preview}/, scene_camera.json, "
      "scene_gt.json,\n"
      "scene_gt_info.json, groundtruth.txt (TUM). Depth PNGs: depth_scale 0.1 (raw units of 0.1 "
      "mm). orpe run/eval\n"
      "take DIR as --dataset.");
  app->callback([s, app] {
    OrpeConfig config = resolve_config(s->options);
    SynthParams p = config.synth;
    // Explicit command-line options override the config file and --set.
    auto given = [&](const char* name) { return app->count(name) > 0; };
    if (given("--seed")) p.seed = s->p.seed;
    if (given("--frames")) p.frames = s->p.frames;
    if (given("--objects")) p.objects = s->p.objects;
    if (given("--scene")) p.scene = s->p.scene;
    if (given("--trajectory")) p.trajectory = s->p.trajectory;
    if (given("--models")) {
      p.models.clear();
      for (const auto& m : s->models) p.models += (p.models.empty() ? "" : ",") + m;
    }
    if (given("--model-unit-m")) p.model_unit_m = s->p.model_unit_m;
    if (given("--repeat-types")) p.repeat_types = true;
    if (given("--distractors")) p.distractors = s->p.distractors;
    if (given("--symmetries")) p.symmetries = s->p.symmetries;
    if (given("--noise")) p.noise = s->noise == "on";
    if (given("--width")) p.width = s->p.width;
    if (given("--height")) p.height = s->p.height;
    if (given("--fx")) p.fx = s->p.fx;
    if (given("--fy")) p.fy = s->p.fy;
    if (given("--cx")) p.cx = s->p.cx;
    if (given("--cy")) p.cy = s->p.cy;
    if (given("--fps")) p.fps = s->p.fps;
    if (given("--span-deg")) p.span_deg = s->p.span_deg;
    if (given("--baseline-m")) p.baseline_m = s->p.baseline_m;
    if (given("--distance-m")) p.distance_m = s->p.distance_m;
    if (given("--elevation-deg")) p.elevation_deg = s->p.elevation_deg;
    if (given("--preview-stride")) p.preview_stride = s->p.preview_stride;
    if (given("--no-masks")) p.write_masks = false;
    if (given("--threads")) p.threads = s->p.threads;
    std::string why;
    if (!p.IsValid(&why)) throw ConfigError("synth: " + why);
    const synth::SyntheticSceneGenerator gen(p);
    const synth::SynthReport report = gen.write_bop(s->out);
    std::cout << report.report();
  });
});

}  // namespace
}  // namespace orpe::cli
