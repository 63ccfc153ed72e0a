#include "orpe/synth/generator.h"

#include <fmt/format.h>
#include <omp.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <climits>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <numeric>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <set>

#include "orpe/core/atomic_file.h"
#include "orpe/core/error.h"
#include "orpe/core/params_io.h"
#include "orpe/io/image_io.h"
#include "orpe/render/mesh_io.h"
#include "orpe/render/rasterizer.h"
#include "orpe/synth/appearance_symmetry.h"
#include "orpe/synth/bop_writer.h"
#include "orpe/synth/frame_info.h"
#include "orpe/synth/trajectory.h"

namespace orpe {

namespace synth {
namespace fs = std::filesystem;
namespace {

constexpr double kDepthScaleMm = 0.1;  // BOP depth_scale: raw units of 0.1 mm
constexpr double kDepthUnitsPerM = 1000.0 / kDepthScaleMm;
constexpr double kMaxStorableDepthM = 65535.0 / kDepthUnitsPerM;

std::vector<std::string> split_list(const std::string& s) {
  std::vector<std::string> out;
  size_t start = 0;
  while (start <= s.size()) {
    size_t end = s.find(',', start);
    if (end == std::string::npos) end = s.size();
    std::string item = s.substr(start, end - start);
    item.erase(0, item.find_first_not_of(" \t"));
    item.erase(item.find_last_not_of(" \t") + 1);
    if (!item.empty()) out.push_back(item);
    start = end + 1;
  }
  return out;
}

bool is_mesh_file(const fs::path& p) {
  std::string e = p.extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return std::tolower(c); });
  return e == ".obj" || e == ".ply";
}

/// Expands files and folders: a folder holds mesh files, or sub-folders with textured_simple.obj
/// (YCB).
std::vector<std::string> expand_model_paths(const std::string& list) {
  std::vector<std::string> files;
  for (const auto& item : split_list(list)) {
    if (!fs::exists(item)) throw IoError(item, "model file or folder not found");
    if (fs::is_directory(item)) {
      std::vector<std::string> found;
      for (const auto& e : fs::directory_iterator(item)) {
        if (e.is_directory()) {
          for (const char* name : {"textured_simple.obj", "textured.obj"})
            if (fs::exists(e.path() / name)) {
              found.push_back((e.path() / name).string());
              break;
            }
        } else if (is_mesh_file(e.path())) {
          found.push_back(e.path().string());
        }
      }
      std::sort(found.begin(), found.end());
      if (found.empty())
        throw IoError(item,
                      "folder contains no .obj/.ply models (nor <class>/textured_simple.obj)");
      files.insert(files.end(), found.begin(), found.end());
    } else {
      files.push_back(item);
    }
  }
  return files;
}

/// synth.symmetries=appearance: each type keeps only the symmetries its print keeps (a printed box
/// or a labelled can is then not symmetric); the scene itself is unchanged.
void use_appearance_symmetries(std::vector<ObjectModel>& types) {
  for (ObjectModel& m : types) {
    const ObjectSymmetries kept = appearance_symmetries(m);
    spdlog::debug("synth: {} keeps {}/{} discrete and {}/{} continuous symmetries (appearance)",
                  m.name, kept.discrete.size(), m.symmetries.discrete.size(),
                  kept.continuous.size(), m.symmetries.continuous.size());
    m.symmetries = kept;
  }
}

/// Per-frame random stream: depends on the seed and the frame only.
std::mt19937_64 frame_rng(int seed, int frame, int stream) {
  std::seed_seq seq{static_cast<std::uint32_t>(seed), static_cast<std::uint32_t>(frame),
                    static_cast<std::uint32_t>(stream), 0x5eedu};
  return std::mt19937_64(seq);
}

Rgb8 instance_colour(int k) {
  const double h = std::fmod(k * 137.508, 360.0) / 60.0;
  const double x = 1 - std::abs(std::fmod(h, 2) - 1);
  double r = 0, g = 0, b = 0;
  if (h < 1)
    r = 1, g = x;
  else if (h < 2)
    r = x, g = 1;
  else if (h < 3)
    g = 1, b = x;
  else if (h < 4)
    g = x, b = 1;
  else if (h < 5)
    r = x, b = 1;
  else
    r = 1, b = x;
  auto q = [](double t) { return static_cast<std::uint8_t>(40 + 215 * t); };
  return {q(r), q(g), q(b)};
}

std::vector<double> row_major_4x4(const SE3& T) {
  const Mat4 M = T.matrix();
  std::vector<double> rm;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) rm.push_back(M(r, c));
  return rm;
}

/// synth_info.json "distractors": what each distractor is and where it stands.
nlohmann::ordered_json distractors_json(const SynthScene& scene) {
  nlohmann::ordered_json list = nlohmann::ordered_json::array();
  for (size_t j = 0; j < scene.distractors.size(); ++j) {
    const auto& d = scene.distractors[j];
    const ObjectModel& m = scene.distractor_types[d.type];
    const auto b = m.mesh->bounds();
    const Eigen::Vector3d size = (b.max() - b.min()).cast<double>();
    const Rgb8 c = m.mesh->base_color;
    list.push_back({{"distractor_id", d.type + 1},
                    {"label", static_cast<int>(j) + 1},
                    {"name", m.name},
                    {"size_m", {size.x(), size.y(), size.z()}},
                    {"colour_rgb", {c.r, c.g, c.b}},
                    {"T_world_obj_m", row_major_4x4(d.T_world_obj)}});
  }
  return list;
}

}  // namespace

std::string SynthReport::report() const {
  std::string s = fmt::format(
      "orpe synth: {} frames, {} objects of {} types{}, scene '{}'\n"
      "  camera: arc {:.0f} deg around the scene, largest camera distance {:.2f} m\n"
      "  mean visible fraction {:.2f}, valid depth {:.0f} % of pixels\n"
      "  written to {} (BOP dataset; the scene in {}) in {:.1f} s\n",
      frames, objects, types,
      distractors > 0 ? fmt::format(" and {} distractors", distractors) : std::string(), scene,
      arc_deg, trajectory_extent_m, mean_visib_fract, 100 * mean_valid_depth, out_dir, scene_dir,
      seconds);
  for (const auto& w : warnings) s += "  warning: " + w + "\n";
  return s;
}

SyntheticSceneGenerator::~SyntheticSceneGenerator() = default;

SyntheticSceneGenerator::SyntheticSceneGenerator(const SynthParams& params) : params_(params) {
  std::string why;
  if (!params_.IsValid(&why)) throw ConfigError("synth: " + why);
  set_up_camera();
  // One random stream, drawn in this order: object types, scene layout, camera path.
  std::mt19937_64 rng(static_cast<std::uint64_t>(params_.seed) * 0x9E3779B97F4A7C15ull + 1);
  std::vector<ObjectModel> types;
  std::vector<int> instance_types;
  choose_object_types(rng, &types, &instance_types);
  SceneLayoutParams layout;
  layout.kind = params_.scene;
  layout.stack_probability = params_.stack_probability;
  lay_out_scene(std::move(types), instance_types, layout, rng);
  make_camera_path(rng);
  add_distractors(layout);
  for (const auto& T : T_world_cam_) {
    const Vec3 d = T.translation() - scene_.centre_world;
    arc_azimuths_.push_back(std::atan2(d.y(), d.x()));
  }
}

void SyntheticSceneGenerator::set_up_camera() {
  std::string why;
  K_.width = params_.width;
  K_.height = params_.height;
  K_.fx = params_.fx > 0 ? params_.fx : 580.0 * params_.width / 640.0;
  K_.fy = params_.fy > 0 ? params_.fy : K_.fx;
  K_.cx = params_.cx > 0 ? params_.cx : (params_.width - 1) / 2.0;
  K_.cy = params_.cy > 0 ? params_.cy : (params_.height - 1) / 2.0;
  if (!K_.IsValid(&why)) throw ConfigError("synth: intrinsics: " + why);

  sensor_.enabled = params_.noise;
  sensor_.min_depth_m = params_.depth_min_m;
  sensor_.max_depth_m = params_.depth_max_m;
  sensor_.noise_scale = params_.depth_noise_scale;
}

void SyntheticSceneGenerator::choose_object_types(std::mt19937_64& rng,
                                                  std::vector<ObjectModel>* types_out,
                                                  std::vector<int>* instance_types_out) {
  std::uniform_real_distribution<double> U(0, 1);
  const int K = params_.objects;
  std::vector<ObjectModel>& types = *types_out;
  std::vector<int>& instance_types = *instance_types_out;
  if (params_.models.empty()) {
    std::vector<std::string> classes, pallets;
    for (const auto& n : builtin_class_names())
      (n.find("pallet") != std::string::npos ? pallets : classes).push_back(n);
    std::shuffle(classes.begin(), classes.end(), rng);
    std::shuffle(pallets.begin(), pallets.end(), rng);
    // Pallets only on the floor: one (two when every class is asked for); large, they would dwarf
    // the rest.
    size_t n_pallets = 0;
    if (params_.scene == "floor" && K >= 3)
      n_pallets = K >= static_cast<int>(classes.size() + pallets.size()) ? 2 : 1;
    for (size_t p = 0; p < n_pallets; ++p) {
      instance_types.push_back(static_cast<int>(types.size()));
      types.push_back(make_builtin_object(pallets[p]));
    }
    const int rest = K - static_cast<int>(n_pallets);
    if (params_.repeat_types) {
      // Classes drawn with replacement: several instances share a type (obj_id).
      std::vector<int> type_of_class(classes.size(), -1);
      for (int k = 0; k < rest; ++k) {
        const size_t c = std::min(classes.size() - 1, static_cast<size_t>(U(rng) * classes.size()));
        if (type_of_class[c] < 0) {
          type_of_class[c] = static_cast<int>(types.size());
          types.push_back(make_builtin_object(classes[c]));
        }
        instance_types.push_back(type_of_class[c]);
      }
    } else {
      // Distinct types: every class once, then variants (other print colours and sizes).
      for (int k = 0; k < rest; ++k) {
        instance_types.push_back(static_cast<int>(types.size()));
        types.push_back(
            make_builtin_object(classes[k % classes.size()], k / static_cast<int>(classes.size())));
      }
    }
  } else {
    const auto files = expand_model_paths(params_.models);
    for (const auto& f : files) types.push_back(load_object_model(f, params_.model_unit_m));
    if (params_.repeat_types) {
      for (int k = 0; k < K; ++k)
        instance_types.push_back(static_cast<int>(U(rng) * types.size()) %
                                 static_cast<int>(types.size()));
    } else {
      std::vector<int> idx(types.size());
      std::iota(idx.begin(), idx.end(), 0);
      std::shuffle(idx.begin(), idx.end(), rng);
      if (K > static_cast<int>(idx.size()))
        spdlog::warn(
            "synth: {} objects requested but {} models given: using {} (set repeat_types for "
            "several instances of a model)",
            K, idx.size(), idx.size());
      idx.resize(std::min<size_t>(idx.size(), static_cast<size_t>(K)));
      std::sort(idx.begin(), idx.end());
      instance_types = idx;
    }
  }
}

void SyntheticSceneGenerator::lay_out_scene(std::vector<ObjectModel> types,
                                            const std::vector<int>& instance_types,
                                            const SceneLayoutParams& layout, std::mt19937_64& rng) {
  scene_ = build_scene(std::move(types), instance_types, layout, rng);
  for (const auto& w : scene_.warnings) spdlog::warn("synth: {}", w);
  if (scene_.objects.empty()) throw ConfigError("synth: no object could be placed in the scene");
  // Keep only the types in use, numbered by first appearance (obj_id = type + 1).
  {
    std::vector<int> remap(scene_.types.size(), -1);
    std::vector<ObjectModel> used;
    for (auto& o : scene_.objects) {
      if (remap[o.type] < 0) {
        remap[o.type] = static_cast<int>(used.size());
        used.push_back(scene_.types[o.type]);
      }
      o.type = remap[o.type];
    }
    scene_.types = std::move(used);
  }
  if (params_.symmetries == "appearance") use_appearance_symmetries(scene_.types);
}

void SyntheticSceneGenerator::make_camera_path(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> U(0, 1);
  TrajectoryParams tp;
  tp.frames = params_.frames;
  tp.fps = params_.fps;
  tp.span_deg = params_.scene == "shelf" ? std::min(params_.span_deg, 110.0) : params_.span_deg;
  tp.baseline_m = params_.baseline_m;
  tp.elevation_deg =
      params_.elevation_deg > 0 ? params_.elevation_deg : scene_.default_elevation_deg;
  tp.shake_m = params_.shake_m;
  tp.shake_deg = params_.shake_deg;
  const double half_fov = std::atan(std::min((K_.width / 2.0) / K_.fx, (K_.height / 2.0) / K_.fy));
  tp.distance_m = params_.distance_m > 0 ? params_.distance_m
                                         : std::clamp(0.7 * scene_.radius_m / std::tan(half_fov),
                                                      params_.depth_min_m + 0.35, 3.0);
  tp.azimuth_centre_rad = params_.scene == "shelf" ? scene_.view_azimuth_rad : 2 * M_PI * U(rng);
  tp.min_height_m = 0.25;
  if (params_.trajectory == "loop") {
    LoopParams lp;
    lp.frames = params_.frames;
    lp.fps = params_.fps;
    lp.overlap_deg = params_.loop_overlap_deg;
    lp.outward = params_.scene == "room";
    lp.radius_m = params_.loop_radius_m > 0 ? params_.loop_radius_m
                  : lp.outward              ? 0.9
                                            : tp.distance_m;
    lp.elevation_deg = tp.elevation_deg;
    lp.shake_m = params_.shake_m;
    lp.shake_deg = params_.shake_deg;
    const Vec3 centre = lp.outward ? Vec3::Zero() : scene_.centre_world;
    T_world_cam_ = make_loop_trajectory(lp, centre, rng);
  } else {
    T_world_cam_ = make_handheld_trajectory(tp, scene_.centre_world, rng);
  }
}

void SyntheticSceneGenerator::add_distractors(const SceneLayoutParams& layout) {
  if (params_.distractors <= 0) return;
  // Their own random stream: with or without distractors, the objects and the camera path are the
  // same.
  std::mt19937_64 rng(static_cast<std::uint64_t>(params_.seed) * 0xD1B54A32D192ED03ull + 0xd15);
  std::vector<ObjectModel> types;
  for (int j = 0; j < params_.distractors; ++j)
    types.push_back(make_distractor_object(scene_.types, j, rng));
  const size_t warned = scene_.warnings.size();
  place_distractors(scene_, std::move(types), layout, rng);
  for (size_t w = warned; w < scene_.warnings.size(); ++w)
    spdlog::warn("synth: {}", scene_.warnings[w]);
}

SynthFrame SyntheticSceneGenerator::render_frame(int i, int render_threads) const {
  if (i < 0 || i >= num_frames())
    throw std::out_of_range("render_frame: frame " + std::to_string(i) + " out of range");
  SynthFrame f;
  f.index = i;
  f.timestamp_s = i / params_.fps;
  f.T_world_cam = T_world_cam_[i];
  const SE3 T_cam_world = f.T_world_cam.inverse();

  std::vector<RenderItem> items;
  for (const auto& part : scene_.environment)
    items.push_back({part.mesh.get(), T_cam_world * part.T_world_part, 0});
  const size_t first_object = items.size();
  const int n = static_cast<int>(scene_.objects.size());
  for (int k = 0; k < n; ++k) {
    const auto& o = scene_.objects[k];
    f.T_cam_obj.push_back(T_cam_world * o.T_world_obj);
    items.push_back({scene_.types[o.type].mesh.get(), f.T_cam_obj.back(), k + 1});
  }
  const int nd = static_cast<int>(scene_.distractors.size());
  for (int j = 0; j < nd; ++j) {
    const auto& d = scene_.distractors[j];
    f.T_cam_distractor.push_back(T_cam_world * d.T_world_obj);
    items.push_back(
        {scene_.distractor_types[d.type].mesh.get(), f.T_cam_distractor.back(), n + 1 + j});
  }
  // Light fixed in the world (from above, slightly to one side), brightness drifting slowly.
  const Vec3 light_world = Vec3(0.35, -0.45, 1.0).normalized();
  const double t = f.timestamp_s;
  const double phase = (params_.seed % 997) * 0.37;
  const double gain =
      1.0 + params_.illumination_variation * (0.7 * std::sin(2 * M_PI * 0.07 * t + phase) +
                                              0.3 * std::sin(2 * M_PI * 0.23 * t + 2 * phase));
  Light light;
  light.direction_cam = (T_cam_world.rotation() * light_world).cast<float>();
  light.ambient = static_cast<float>(0.45 * gain);
  light.diffuse = static_cast<float>(0.65 * gain);

  RasterizerParams rp;
  rp.near_m = 0.02;
  rp.far_m = 50.0;
  rp.threads = render_threads;
  Rasterizer rast(rp);
  RenderBuffers buf;
  rast.render(K_, items, buf,
              kRenderDepth | kRenderIds | kRenderColor | kRenderNormals | kRenderSilhouettes,
              &light);

  const int W = K_.width, H = K_.height;
  f.depth_clean = std::move(buf.depth);
  for (auto& z : f.depth_clean)
    if (z > kMaxStorableDepthM) z = 0.0f;  // beyond what the 16-bit depth PNG holds
  f.instances = std::move(buf.ids);
  f.rgb = std::move(buf.color);
  std::mt19937_64 rng = frame_rng(params_.seed, i, 1);
  f.normals = std::move(buf.normals);
  if (params_.noise) {
    f.depth = simulate_depth_sensor(f.depth_clean, f.normals, K_, sensor_, rng);
    apply_color_noise(f.rgb, 1.0, params_.color_noise_sigma, rng);
  } else {
    f.depth = f.depth_clean;
  }
  f.masks.resize(n);
  for (int k = 0; k < n; ++k) f.masks[k] = std::move(buf.silhouettes[first_object + k]);
  object_frame_info(f.instances, f.masks, f.depth, f.masks_visib, f.info);
  for (int k = 0; k < n; ++k)
    add_silhouette_outside_image(*scene_.types[scene_.objects[k].type].mesh, f.T_cam_obj[k], K_, rp,
                                 f.info[k]);
  if (nd > 0) {
    // Distractors leave the instance image (they are background to everything reading it).
    f.distractor_labels = LabelImage(W, H, 0);
    for (size_t p = 0; p < f.instances.size(); ++p)
      if (f.instances[p] > n) f.distractor_labels[p] = f.instances[p] - n, f.instances[p] = 0;
    const std::vector<MaskImage> silhouettes(
        std::make_move_iterator(buf.silhouettes.begin() + first_object + n),
        std::make_move_iterator(buf.silhouettes.begin() + first_object + n + nd));
    std::vector<MaskImage> visible;
    object_frame_info(f.distractor_labels, silhouettes, f.depth, visible, f.distractor_info);
    for (int j = 0; j < nd; ++j)
      add_silhouette_outside_image(*scene_.distractor_types[scene_.distractors[j].type].mesh,
                                   f.T_cam_distractor[j], K_, rp, f.distractor_info[j]);
  }
  return f;
}

SynthReport SyntheticSceneGenerator::write_bop(const std::string& dir) const {
  const auto t0 = std::chrono::steady_clock::now();
  // A BOP dataset: models/, camera.json and the targets at its root, the scene in test/000000.
  const std::string scene = bop_scene_dir(dir);
  std::error_code ec;
  fs::create_directories(scene, ec);
  if (ec) throw IoError(dir, "cannot create output folder: " + ec.message());
  const int nd = static_cast<int>(scene_.distractors.size());
  write_bop_models(dir + "/models", scene_.types, params_.model_points,
                   static_cast<std::uint64_t>(params_.seed));
  if (nd > 0)
    write_bop_models(dir + "/models_distractors", scene_.distractor_types, params_.model_points,
                     static_cast<std::uint64_t>(params_.seed));

  std::vector<BopFrameRecord> records(num_frames());
  std::vector<FrameSummary> stats(num_frames());
  const int threads = params_.threads > 0 ? params_.threads : omp_get_max_threads();
  std::string first_error;
  bool failed = false;
  const double max_preview_depth =
      std::min(params_.noise ? params_.depth_max_m : kMaxStorableDepthM,
               3.0 * (T_world_cam_[0].translation() - scene_.centre_world).norm());
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
  for (int i = 0; i < num_frames(); ++i) {
    bool skip;
#pragma omp atomic read
    skip = failed;
    if (skip) continue;
    try {
      write_frame_files(i, scene, max_preview_depth, records[i], stats[i]);
    } catch (const std::exception& e) {
#pragma omp critical(synth_error)
      {
        if (first_error.empty()) first_error = e.what();
#pragma omp atomic write
        failed = true;
      }
    }
  }
  if (failed) throw IoError(scene, "writing the synthetic sequence failed: " + first_error);

  write_bop_scene_json(scene, K_, kDepthScaleMm, records);
  if (nd > 0) write_distractor_json(scene, records);
  write_tum_trajectory(scene + "/groundtruth.txt", records);
  // The scene's true surface in the world frame (metres), for `orpe eval map`.
  PlyWriteOptions mesh_options;
  mesh_options.units_per_metre = 1.0;
  mesh_options.write_normals = false;
  mesh_options.write_colors = false;
  mesh_options.binary = true;
  write_ply(scene + "/scene_mesh.ply", scene_mesh_world(scene_), mesh_options);
  write_bop_targets(dir + "/test_targets_bop19.json", kBopSceneId, records, kBopTargetMinVisib);
  // BOP's dataset-level camera file, and what this scene is made of.
  nlohmann::ordered_json cam = {{"cx", K_.cx},      {"cy", K_.cy}, {"depth_scale", kDepthScaleMm},
                                {"fx", K_.fx},      {"fy", K_.fy}, {"height", K_.height},
                                {"width", K_.width}};
  write_file_atomic(dir + "/camera.json", [&](std::ostream& os) { os << cam.dump(1) << "\n"; });
  write_synth_info(dir);
  SynthReport rep = report(dir, scene, stats);
  rep.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return rep;
}

void SyntheticSceneGenerator::write_frame_files(int i, const std::string& scene,
                                                double max_preview_depth, BopFrameRecord& r,
                                                FrameSummary& st) const {
  const int n = static_cast<int>(scene_.objects.size());
  const int nd = static_cast<int>(scene_.distractors.size());
  const SynthFrame f = render_frame(i, 1);
  const std::string name = bop_image_name(i);
  write_color_png(scene + "/rgb/" + name + ".png", f.rgb);
  write_depth_png(scene + "/depth/" + name + ".png", f.depth, kDepthUnitsPerM);
  write_label_png(scene + "/instance/" + name + ".png", f.instances, n < 255);
  if (nd > 0)
    write_label_png(scene + "/distractor/" + name + ".png", f.distractor_labels, nd < 255);
  if (params_.write_masks)
    for (int k = 0; k < n; ++k) {
      write_mask_png(scene + "/mask/" + bop_mask_name(i, k) + ".png", f.masks[k]);
      write_mask_png(scene + "/mask_visib/" + bop_mask_name(i, k) + ".png", f.masks_visib[k]);
    }
  if (params_.preview_stride > 0 && i % params_.preview_stride == 0)
    write_color_png(scene + "/preview/" + name + ".png", make_preview(f, max_preview_depth));
  r.timestamp_s = f.timestamp_s;
  r.T_world_cam = f.T_world_cam;
  r.T_cam_obj = f.T_cam_obj;
  for (const auto& o : scene_.objects) r.obj_ids.push_back(o.type + 1);
  r.info = f.info;
  r.T_cam_distractor = f.T_cam_distractor;
  r.distractor_info = f.distractor_info;
  size_t valid = 0;
  for (float z : f.depth) valid += z > 0;
  st.valid_depth_fraction = static_cast<double>(valid) / f.depth.size();
  for (const auto& inf : f.info)
    if (inf.px_count_all > 0) st.visib_sum += inf.visib_fract, ++st.visib_count;
}

void SyntheticSceneGenerator::write_synth_info(const std::string& dir) const {
  const int n = static_cast<int>(scene_.objects.size());
  const int nd = static_cast<int>(scene_.distractors.size());
  nlohmann::ordered_json info;
  info["generator"] = "orpe synth";
  info["params"] = params_to_json(params_);
  info["params"].erase("threads");  // an execution setting: the output does not depend on it
  // Absent = 0: scenes without distractors stay byte-identical to those made before the option.
  if (params_.distractors == 0) info["params"].erase("distractors");
  // Likewise the loop's parameters for the default arc.
  if (params_.trajectory == "arc")
    for (const char* k : {"trajectory", "loop_overlap_deg", "loop_radius_m"})
      info["params"].erase(k);
  info["scene"] = scene_.kind;
  info["depth_scale"] = kDepthScaleMm;
  info["depth_units_per_m"] = kDepthUnitsPerM;
  info["objects"] = nlohmann::ordered_json::array();
  for (int k = 0; k < n; ++k) {
    const auto& o = scene_.objects[k];
    const std::vector<double> rm = row_major_4x4(o.T_world_obj);
    info["objects"].push_back({{"gt_index", k},
                               {"instance_label", k + 1},
                               {"obj_id", o.type + 1},
                               {"name", scene_.types[o.type].name},
                               {"source", scene_.types[o.type].source},
                               {"T_world_obj_m", rm}});
  }
  if (nd > 0) info["distractors"] = distractors_json(scene_);
  info["warnings"] = scene_.warnings;
  write_file_atomic(dir + "/synth_info.json",
                    [&](std::ostream& os) { os << info.dump(1) << "\n"; });
}

SynthReport SyntheticSceneGenerator::report(const std::string& dir, const std::string& scene,
                                            const std::vector<FrameSummary>& stats) const {
  SynthReport rep;
  rep.out_dir = dir;
  rep.scene_dir = scene;
  rep.frames = num_frames();
  rep.objects = static_cast<int>(scene_.objects.size());
  rep.types = static_cast<int>(scene_.types.size());
  rep.distractors = static_cast<int>(scene_.distractors.size());
  rep.scene = scene_.kind;
  rep.trajectory_extent_m = trajectory_extent_m(T_world_cam_);
  double lo = 0, hi = 0, acc = 0;
  for (size_t i = 1; i < arc_azimuths_.size(); ++i) {
    double d = arc_azimuths_[i] - arc_azimuths_[i - 1];
    d = std::remainder(d, 2 * M_PI);
    acc += d;
    lo = std::min(lo, acc), hi = std::max(hi, acc);
  }
  rep.arc_deg = (hi - lo) * 180.0 / M_PI;
  double vs = 0, valid = 0;
  int vc = 0;
  for (const FrameSummary& st : stats)
    vs += st.visib_sum, vc += st.visib_count, valid += st.valid_depth_fraction;
  rep.mean_visib_fract = vc > 0 ? vs / vc : 0.0;
  rep.mean_valid_depth = valid / std::max(1, num_frames());
  rep.warnings = scene_.warnings;
  return rep;
}

RgbdFrame to_rgbd_frame(const SynthFrame& f, const SyntheticSceneGenerator& g) {
  RgbdFrame r;
  r.index = f.index;
  r.timestamp_s = f.timestamp_s;
  r.name = bop_image_name(f.index);
  r.intrinsics = g.intrinsics();
  r.color = f.rgb;
  r.depth = f.depth;
  r.T_world_cam_gt = f.T_world_cam;
  for (size_t k = 0; k < f.T_cam_obj.size(); ++k) {
    ObjectGroundTruth o;
    o.class_id = g.scene().objects[k].type + 1;
    o.instance_id = static_cast<int>(k) + 1;
    o.T_cam_obj = f.T_cam_obj[k];
    o.visible_fraction = f.info[k].visib_fract;
    r.objects_gt.push_back(o);
  }
  r.labels_gt = f.instances;
  return r;
}

ColorImage make_preview(const SynthFrame& f, double max_depth_m) {
  const int W = f.rgb.width(), H = f.rgb.height();
  cv::Mat rgb(H, W, CV_8UC3), depth8(H, W, CV_8UC1), overlay(H, W, CV_8UC3);
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      const Rgb8 c = f.rgb.at(u, v);
      rgb.at<cv::Vec3b>(v, u) = {c.r, c.g, c.b};
      const float z = f.depth.at(u, v);
      depth8.at<uchar>(v, u) =
          z > 0 ? cv::saturate_cast<uchar>(255.0 * (1.0 - std::min(1.0, z / max_depth_m))) : 0;
    }
  cv::Mat depth_col;
  cv::applyColorMap(depth8, depth_col, cv::COLORMAP_TURBO);  // BGR
  cv::cvtColor(depth_col, depth_col, cv::COLOR_BGR2RGB);
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      if (f.depth.at(u, v) <= 0) depth_col.at<cv::Vec3b>(v, u) = {0, 0, 0};
      const int id = f.instances.at(u, v);
      cv::Vec3b px = rgb.at<cv::Vec3b>(v, u);
      if (id > 0) {
        const Rgb8 c = instance_colour(id - 1);
        px = {static_cast<uchar>((px[0] + c.r) / 2), static_cast<uchar>((px[1] + c.g) / 2),
              static_cast<uchar>((px[2] + c.b) / 2)};
      } else {
        px = {static_cast<uchar>(px[0] / 2), static_cast<uchar>(px[1] / 2),
              static_cast<uchar>(px[2] / 2)};
      }
      overlay.at<cv::Vec3b>(v, u) = px;
    }
  // Outlines of the visible masks.
  for (size_t k = 0; k < f.masks_visib.size(); ++k) {
    cv::Mat m(H, W, CV_8UC1, const_cast<std::uint8_t*>(f.masks_visib[k].data()));
    std::vector<std::vector<cv::Point>> contours;
    cv::findContours(m.clone(), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_SIMPLE);
    cv::drawContours(overlay, contours, -1, cv::Scalar(255, 255, 255), 1);
  }
  // Distractors (not targets): outlined in red, not tinted.
  if (!f.distractor_labels.empty()) {
    cv::Mat m(H, W, CV_8UC1);
    for (int v = 0; v < H; ++v)
      for (int u = 0; u < W; ++u) m.at<uchar>(v, u) = f.distractor_labels.at(u, v) > 0 ? 255 : 0;
    std::vector<std::vector<cv::Point>> contours;
    cv::findContours(m, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_SIMPLE);
    cv::drawContours(overlay, contours, -1, cv::Scalar(255, 40, 40), 1);
  }
  cv::Mat all;
  cv::hconcat(std::vector<cv::Mat>{rgb, depth_col, overlay}, all);
  ColorImage out(all.cols, all.rows);
  for (int v = 0; v < all.rows; ++v)
    for (int u = 0; u < all.cols; ++u) {
      const cv::Vec3b p = all.at<cv::Vec3b>(v, u);
      out.at(u, v) = {p[0], p[1], p[2]};
    }
  return out;
}

}  // namespace synth
}  // namespace orpe
