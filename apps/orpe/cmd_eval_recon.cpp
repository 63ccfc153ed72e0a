// `orpe eval recon`: reconstruction error of the semantic map's objects against their models at the
// ground-truth poses (pipeline/reconstruction_error.h). Registered as a subcommand of `orpe eval`
// (created in cmd_eval.cpp, order 70) without touching that file.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <filesystem>
#include <iostream>
#include <memory>
#include <ostream>
#include <set>

#include "command.h"
#include "orpe/core/error.h"
#include "orpe/io/dataset.h"
#include "orpe/io/point_cloud_io.h"
#include "orpe/io/trajectory_io.h"
#include "orpe/pipeline/reconstruction_error.h"
#include "orpe/render/mesh_io.h"

namespace orpe::cli {
namespace {

struct ReconCommand {
  ConfigOptions options;
  std::string dataset, run_dir, map_path, trajectory_path, json_path;
  bool register_model = false;
  bool markdown = false;
  double min_confidence = 0;
};

void run_recon(const ReconCommand& c) {
  const OrpeConfig config = resolve_config(c.options);
  namespace fs = std::filesystem;
  const std::string map_path =
      !c.map_path.empty() ? c.map_path : (fs::path(c.run_dir) / "semantic_map.ply").string();
  const std::string traj_path = !c.trajectory_path.empty()
                                    ? c.trajectory_path
                                    : (fs::path(c.run_dir) / "trajectory.txt").string();
  if (c.run_dir.empty() && (c.map_path.empty() || c.trajectory_path.empty()))
    throw ConfigError("eval recon: give --run OUT, or both --map and --trajectory");
  require_file(map_path, "semantic map");
  require_file(traj_path, "trajectory");
  const PointCloudData map = read_semantic_map_ply(map_path);
  const auto trajectory = read_tum_trajectory(traj_path);
  const auto reader = open_dataset(c.dataset, config.dataset);
  const DatasetInfo& info = reader->info();
  auto objects = ground_truth_objects_in_map(*reader, trajectory);
  if (objects.empty())
    throw IoError(c.dataset, "no object ground truth in a frame of the trajectory " + traj_path);
  std::map<int, ModelSurface> surfaces;
  std::map<int, const ModelSurface*> surface_ptrs;
  for (const auto& o : objects) {
    if (surfaces.count(o.class_id)) continue;
    try {
      surfaces.emplace(o.class_id, load_model_surface(info, o.class_id));
      surface_ptrs[o.class_id] = &surfaces.at(o.class_id);
    } catch (const IoError& e) {
      spdlog::warn("class {}: no model surface, skipped: {}", o.class_id, e.what());
    }
  }
  mark_seen_surface(*reader, trajectory, surface_ptrs, &objects);
  ReconstructionErrorParams params;
  params.register_model = c.register_model;
  params.min_confidence = static_cast<float>(c.min_confidence);
  const ReconstructionEvaluation ev =
      evaluate_reconstruction(map, objects, surface_ptrs, info.class_names, params);
  std::cout << (c.markdown ? ev.markdown() : ev.report());
  // A map whose objects have no surfels measures nothing (this printed "MEAN 0.00" before).
  if (ev.objects_measured == 0)
    throw IoError(
        map_path,
        fmt::format(
            "none of the {} ground-truth objects has surfels in the map (instance ids > 0{}): "
            "nothing to measure",
            ev.objects.size(),
            c.min_confidence > 0 ? fmt::format(", confidence >= {}", c.min_confidence) : ""));
  if (!c.json_path.empty()) write_text_atomic(c.json_path, ev.to_json());
}

CommandRegistrar reg(71, [](CLI::App& root) {
  CLI::App* eval = root.get_subcommand("eval");  // created by cmd_eval.cpp (order 70)
  auto c = std::make_shared<ReconCommand>();
  CLI::App* r = eval->add_subcommand(
      "recon",
      "Reconstruction error (mm) of the semantic map's objects: mean distance of each object's "
      "surfels to its model surface at the ground-truth pose, shares of surfels beyond 1 / 2 cm, "
      "and "
      "completeness (share of the model surface the camera saw within 1 cm of a surfel)");
  r->add_option("--dataset", c->dataset, "Dataset folder with object ground truth and models")
      ->required();
  r->add_option("--run", c->run_dir,
                "Output folder of `orpe run` (semantic_map.ply, trajectory.txt)");
  r->add_option("--map", c->map_path, "Semantic map PLY (default RUN/semantic_map.ply)");
  r->add_option("--trajectory", c->trajectory_path,
                "TUM trajectory of the run (default RUN/trajectory.txt)");
  r->add_flag("--register", c->register_model,
              "Also report the error after ICP registration of the model to the surfels");
  r->add_option("--min-confidence", c->min_confidence, "Ignore surfels below this confidence");
  r->add_option("--json", c->json_path, "Also write the figures as JSON to this file");
  r->add_flag("--markdown", c->markdown, "Print the table as Markdown");
  add_config_options(*r, c->options);
  add_dataset_options(*r, c->options);
  r->callback([c] { run_recon(*c); });
});

struct MapCommand {
  std::string map_path, mesh_path, json_path;
  double min_confidence = 0;
};

void run_map(const MapCommand& c) {
  require_file(c.map_path, "map");
  require_file(c.mesh_path, "scene mesh");
  const PointCloudData map = read_point_cloud_ply(c.map_path);
  const ModelSurface surface = ModelSurface::from_mesh(load_mesh(c.mesh_path));
  ReconstructionErrorParams params;
  params.min_confidence = static_cast<float>(c.min_confidence);
  MapSurfaceError e;
  try {
    e = evaluate_map_surface(map, surface, params);
  } catch (const std::invalid_argument& ex) {
    throw IoError(c.map_path, ex.what());
  }
  std::cout << e.report();
  if (!c.json_path.empty()) write_text_atomic(c.json_path, e.to_json());
}

CommandRegistrar reg_map(73, [](CLI::App& root) {
  CLI::App* eval = root.get_subcommand("eval");  // created by cmd_eval.cpp (order 70)
  auto c = std::make_shared<MapCommand>();
  CLI::App* m = eval->add_subcommand(
      "map",
      "Error (mm) of a whole map against the scene's true surface: distance of every surfel to the "
      "mesh (no alignment: both in the world frame), shares beyond 1 / 2 cm (doubled or shifted "
      "surfaces); `orpe synth` writes the mesh as test/000000/scene_mesh.ply");
  m->add_option("map", c->map_path, "Map PLY of `orpe run` (map.ply)")->required();
  m->add_option("mesh", c->mesh_path, "The scene's mesh, metres, world frame (OBJ, PLY, ...)")
      ->required();
  m->add_option("--min-confidence", c->min_confidence, "Ignore surfels below this confidence");
  m->add_option("--json", c->json_path, "Also write the figures as JSON to this file");
  m->callback([c] { run_map(*c); });
});

}  // namespace
}  // namespace orpe::cli
