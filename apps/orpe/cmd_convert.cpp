// `orpe convert`: any dataset orpe reads (TUM, 7-Scenes, YCB-Video, BOP, plain rgb/ + depth/
// folders with a camera file, with --models / --camera overrides) written as a one-scene BOP
// dataset, the layout bop_toolkit and orpe synth use (docs/DATASETS.md, "orpe convert"):
//   OUT/camera.json, OUT/models/ (obj_XXXXXX.ply in mm + models_info.json, when the source has
//   models), OUT/test_targets_bop19.json, OUT/orpe_convert.json (source, frame names, timestamps),
//   OUT/test/000000/{rgb,depth,mask,mask_visib}/, scene_camera.json, scene_gt.json,
//   scene_gt_info.json, groundtruth.txt (TUM, when the source has camera poses).
// Depth keeps the source's quantisation (BOP depth_scale = 1000 / dataset.depth_units_per_m), so
// the depth values read back are the source's. Written whole or not at all (core/staged_dir.h).
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <span>
#include <vector>

#include "command.h"
#include "orpe/core/atomic_file.h"
#include "orpe/core/error.h"
#include "orpe/core/staged_dir.h"
#include "orpe/core/version.h"
#include "orpe/io/dataset.h"
#include "orpe/io/image_io.h"
#include "orpe/pipeline/object_models.h"
#include "orpe/render/mesh_io.h"
#include "orpe/render/rasterizer.h"
#include "orpe/synth/bop_writer.h"
#include "orpe/synth/frame_info.h"

namespace orpe::cli {
namespace {

constexpr const char* kMarker = "orpe_convert.json";  ///< marks a folder `orpe convert` wrote

struct ConvertCommand {
  ConfigOptions options;
  std::string dataset;
  std::string out;
  bool overwrite = false;
};

/// The source's model meshes (metres) with the symmetries its metric uses, by class id.
struct SourceModels {
  std::vector<int> ids;
  std::vector<synth::ObjectModel> models;
  std::map<int, size_t> index;  ///< class id -> position in models
};

synth::ObjectSymmetries bop_symmetries(const ObjectModelLibrary& lib, int class_id) {
  synth::ObjectSymmetries out;
  const ObjectSymmetry s = lib.ekf_symmetry(class_id, "dataset");
  out.discrete = s.discrete;
  if (s.continuous) out.continuous.push_back({s.axis_obj, s.axis_point_obj});
  if (lib.get(class_id).symmetric_for_metric && !out.any())
    spdlog::warn(
        "{}: scored as symmetric in the source, but its model has no detected symmetry to write; "
        "the converted dataset scores it with ADD",
        lib.class_name(class_id));
  return out;
}

SourceModels read_models(const DatasetInfo& info) {
  SourceModels sm;
  const ObjectModelLibrary lib(info);
  for (const auto& [id, path] : info.model_mesh_paths) {
    if (std::filesystem::path(path).extension() == ".xyz") continue;  // points only: no mesh
    MeshLoadOptions mo;
    mo.metres_per_unit = 1.0 / info.model_units_per_m;
    mo.warn_missing_texture = false;
    synth::ObjectModel m;
    m.name = lib.class_name(id);
    m.source = path;
    m.mesh = std::make_shared<const TriangleMesh>(load_mesh(path, mo));
    m.symmetries = bop_symmetries(lib, id);
    sm.index[id] = sm.models.size();
    sm.ids.push_back(id);
    sm.models.push_back(std::move(m));
  }
  for (const auto& [id, path] : info.model_points_paths)
    if (!sm.index.count(id))
      spdlog::warn("{}: no mesh in the source (points only: {}); not written to models/",
                   lib.class_name(id), path);
  return sm;
}

/// Visibility of each annotated object as bop_toolkit computes it (synth/frame_info.h):
/// silhouettes rendered from the model meshes, visible pixels from the frame's labels; the visible
/// masks are written to mask_visib/. What the source cannot tell stays -1 (pixel counts and boxes
/// of an object without a mesh; visible counts of a frame without labels, whose visib_fract is
/// the source's own, or -1).
std::vector<synth::ObjectFrameInfo> object_info(const RgbdFrame& f, const SourceModels& sm,
                                                const std::string& scene, int im_id) {
  const int W = f.depth.width(), H = f.depth.height(), n = static_cast<int>(f.objects_gt.size());
  std::vector<RenderItem> items;
  std::vector<int> item_object;
  for (int k = 0; k < n; ++k) {
    const auto it = sm.index.find(f.objects_gt[k].class_id);
    if (it == sm.index.end()) continue;
    items.push_back({sm.models[it->second].mesh.get(), f.objects_gt[k].T_cam_obj, k + 1});
    item_object.push_back(k);
  }
  RenderBuffers buf;
  const RasterizerParams rp;
  if (!items.empty())
    Rasterizer(rp).render(f.intrinsics, std::span<const RenderItem>(items), buf,
                          kRenderSilhouettes);
  std::vector<MaskImage> silhouettes(n, MaskImage(W, H, 0));
  for (size_t j = 0; j < items.size(); ++j)
    silhouettes[item_object[j]] = std::move(buf.silhouettes[j]);
  const bool labelled = !f.labels_gt.empty();
  std::vector<MaskImage> masks_visib;
  std::vector<synth::ObjectFrameInfo> info;
  synth::object_frame_info(labelled ? f.labels_gt : LabelImage(W, H, 0), silhouettes, f.depth,
                           masks_visib, info);
  std::vector<bool> has_mesh(n, false);
  for (size_t j = 0; j < items.size(); ++j) {
    has_mesh[item_object[j]] = true;
    synth::add_silhouette_outside_image(*items[j].mesh, items[j].T_cam_obj, f.intrinsics, rp,
                                        info[item_object[j]]);
  }
  for (int k = 0; k < n; ++k) {
    synth::ObjectFrameInfo& o = info[k];
    if (labelled)
      write_mask_png(scene + "/mask_visib/" + synth::bop_mask_name(im_id, k) + ".png",
                     masks_visib[k]);
    else
      o.px_count_visib = o.px_count_valid = -1, std::fill(o.bbox_visib, o.bbox_visib + 4, -1);
    if (!has_mesh[k]) o.px_count_all = -1, std::fill(o.bbox_obj, o.bbox_obj + 4, -1);
    if (!labelled || !has_mesh[k]) o.visib_fract = f.objects_gt[k].visible_fraction;
  }
  return info;
}

/// Writes the frames; returns their records for the scene's JSON files.
std::vector<synth::BopFrameRecord> write_frames(const DatasetReader& reader, const SourceModels& sm,
                                                const std::string& scene,
                                                nlohmann::ordered_json& names) {
  const DatasetInfo& info = reader.info();
  for (const char* sub : {"rgb", "depth", "mask_visib"})
    std::filesystem::create_directories(scene + "/" + sub);
  std::vector<synth::BopFrameRecord> records;
  for (size_t i = 0; i < reader.size(); ++i) {
    const RgbdFrame f = reader.read(i);
    const PinholeIntrinsics& K0 = info.intrinsics;
    if (f.intrinsics.K() != K0.K() || f.intrinsics.width != K0.width ||
        f.intrinsics.height != K0.height)
      throw IoError(info.root, fmt::format("frame {} ({}) has other intrinsics than the first "
                                           "frame: orpe convert writes one camera per scene",
                                           f.index, f.name));
    const int im_id = static_cast<int>(i);
    const std::string name = synth::bop_image_name(im_id);
    write_color_png(scene + "/rgb/" + name + ".png", f.color);
    write_depth_png(scene + "/depth/" + name + ".png", f.depth, info.depth_units_per_m);
    synth::BopFrameRecord r;
    r.timestamp_s = f.timestamp_s;
    r.has_camera_pose = f.T_world_cam_gt.has_value();
    if (r.has_camera_pose) r.T_world_cam = *f.T_world_cam_gt;
    for (const auto& g : f.objects_gt) {
      r.T_cam_obj.push_back(g.T_cam_obj);
      r.obj_ids.push_back(g.class_id);
    }
    r.info = object_info(f, sm, scene, im_id);
    records.push_back(std::move(r));
    names.push_back(
        {{"im_id", im_id}, {"source", f.name}, {"index", f.index}, {"timestamp_s", f.timestamp_s}});
  }
  return records;
}

void run_convert(const ConvertCommand& c) {
  const OrpeConfig config = resolve_config(c.options);
  const auto reader = open_dataset(c.dataset, config.dataset);
  const DatasetInfo& info = reader->info();
  if (reader->size() == 0) throw IoError(c.dataset, "no frames to convert");
  if (!(info.depth_units_per_m > 0)) throw IoError(c.dataset, "the depth scale is unknown");
  StagedDir staged(c.out, c.overwrite, kMarker);
  const std::string& dir = staged.dir();
  const SourceModels sm = read_models(info);
  if (!sm.models.empty()) {
    std::filesystem::create_directories(dir + "/models");
    synth::write_bop_models(dir + "/models", sm.models, 2620, 1, sm.ids);
  }
  const std::string scene = synth::bop_scene_dir(dir);
  nlohmann::ordered_json frames = nlohmann::ordered_json::array();
  const auto records = write_frames(*reader, sm, scene, frames);
  const double depth_scale_mm = 1000.0 / info.depth_units_per_m;
  synth::write_bop_scene_json(scene, info.intrinsics, depth_scale_mm, records);
  if (records.front().has_camera_pose)
    synth::write_tum_trajectory(scene + "/groundtruth.txt", records);
  synth::write_bop_targets(dir + "/test_targets_bop19.json", synth::kBopSceneId, records,
                           synth::kBopTargetMinVisib);
  const PinholeIntrinsics& K = info.intrinsics;
  const nlohmann::ordered_json cam = {
      {"cx", K.cx},      {"cy", K.cy}, {"depth_scale", depth_scale_mm},
      {"fx", K.fx},      {"fy", K.fy}, {"height", K.height},
      {"width", K.width}};
  write_file_atomic(dir + "/camera.json", [&](std::ostream& os) { os << cam.dump(1) << "\n"; });
  nlohmann::ordered_json meta = {
      {"generator", "orpe convert"},  {"version", ORPE_VERSION_STRING},   {"source", info.root},
      {"source_format", info.format}, {"depth_scale_mm", depth_scale_mm}, {"frames", frames}};
  write_file_atomic(dir + "/" + kMarker, [&](std::ostream& os) { os << meta.dump(1) << "\n"; });
  staged.commit();
  std::cout << fmt::format("{} frames, {} models written to {} (BOP; read it with --dataset {})\n",
                           records.size(), sm.models.size(), c.out, c.out);
}

CommandRegistrar reg(46, [](CLI::App& root) {
  auto c = std::make_shared<ConvertCommand>();
  CLI::App* app = root.add_subcommand(
      "convert",
      "Write a dataset (any layout orpe reads, with --camera / --models) as a one-scene BOP "
      "dataset for bop_toolkit and other tools. See docs/DATASETS.md, \"orpe convert\".");
  app->add_option("--dataset", c->dataset, "Dataset to convert")->required();
  app->add_option("--out", c->out, "BOP dataset folder to write")->required();
  app->add_flag("--overwrite", c->overwrite, "Replace an earlier `orpe convert` output at --out");
  add_config_options(*app, c->options);
  add_dataset_options(*app, c->options);
  app->callback([c] { run_convert(*c); });
});

}  // namespace
}  // namespace orpe::cli
