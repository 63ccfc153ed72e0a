// BOP scene layout (https://github.com/thodan/bop_toolkit/blob/master/docs/bop_datasets_format.md):
// <scene>/scene_camera.json, scene_gt.json, scene_gt_info.json, rgb/ (or gray/), depth/,
// mask_visib/, with models in <scene>/models, <scene>/../models or <scene>/../../models
// (obj_XXXXXX.ply, mm). Opens a scene folder, a folder of scene folders, or a dataset root with
// split folders (<root>/test/<scene>, as orpe synth writes).
#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <map>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>

#include "orpe/core/error.h"
#include "orpe/core/parse_number.h"
#include "orpe/io/dataset_common.h"
#include "orpe/io/image_io.h"

namespace orpe::detail {
namespace fs = std::filesystem;
using nlohmann::json;
namespace {

constexpr double kFrameRateHz = 30.0;  // nominal; BOP images have no timestamps
constexpr double kMmPerM = 1000.0;
constexpr int kInstanceStride =
    1000;  // instance_id = obj_id + 1000 * (earlier instances of obj_id)

json parse_json_file(const std::string& path) {
  std::ifstream is(path);
  if (!is) throw IoError(path, "cannot open JSON file");
  try {
    return json::parse(is);
  } catch (const json::exception& e) {
    throw IoError(path, std::string("malformed JSON: ") + e.what());
  }
}

/// `n` finite numbers from j[key]; throws std::runtime_error (turned into a per-image IoError).
std::vector<double> numbers(const json& j, const char* key, size_t n) {
  if (!j.contains(key)) throw std::runtime_error(fmt::format("no '{}'", key));
  const json& a = j.at(key);
  if (!a.is_array() || a.size() != n)
    throw std::runtime_error(fmt::format("'{}' must be {} numbers", key, n));
  std::vector<double> v;
  for (const json& x : a) {
    if (!x.is_number()) throw std::runtime_error(fmt::format("'{}' must be {} numbers", key, n));
    v.push_back(x.get<double>());
    if (!std::isfinite(v.back()))
      throw std::runtime_error(fmt::format("'{}' has a non-finite value", key));
  }
  return v;
}

Vec3 vec3(const std::vector<double>& v) {
  return Vec3(v[0], v[1], v[2]);
}

/// The message of an IoError without its "path: " prefix (re-thrown later with the image id).
std::string problem_of(const IoError& e) {
  const std::string what = e.what();
  const std::string prefix = e.path() + ": ";
  return what.rfind(prefix, 0) == 0 ? what.substr(prefix.size()) : what;
}

Mat3 row_major_3x3(const std::vector<double>& v) {
  Mat3 M;
  M << v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8];
  return M;
}

struct BopCamera {
  PinholeIntrinsics K;
  std::optional<double> depth_scale_mm;  // raw * depth_scale = mm
  std::optional<SE3> T_world_cam;
  std::string error;  // non-empty: this image's entry is malformed
};

struct BopImage {
  int im_id = 0;
  BopCamera camera;
  std::vector<ObjectGroundTruth> objects;
  std::string gt_error;
};

bool is_digits(const std::string& s) {
  return !s.empty() &&
         std::all_of(s.begin(), s.end(), [](unsigned char c) { return std::isdigit(c); });
}

std::vector<std::string> scene_folders(const fs::path& root) {
  std::vector<std::string> out;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(root, ec))
    if (e.is_directory() && fs::exists(e.path() / "scene_camera.json"))
      out.push_back(e.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}

/// The folder holding the scene folders: `root` itself, or (a BOP dataset root) its split folder
/// that has scene folders: test/, then val/, train/, then any other sub-folder in name order.
fs::path scenes_parent(const fs::path& root) {
  if (!scene_folders(root).empty()) return root;
  std::vector<std::string> splits;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(root, ec))
    if (e.is_directory()) splits.push_back(e.path().filename().string());
  auto rank = [](const std::string& s) {
    return s == "test" ? 0 : s == "val" ? 1 : s == "train" ? 2 : 3;
  };
  std::sort(splits.begin(), splits.end(), [&](const std::string& a, const std::string& b) {
    return std::make_pair(rank(a), a) < std::make_pair(rank(b), b);
  });
  for (const auto& s : splits)
    if (!scene_folders(root / s).empty()) return root / s;
  return {};
}

/// First existing file among stem + each extension.
std::string first_existing(const fs::path& dir, const std::string& stem,
                           std::initializer_list<const char*> exts) {
  for (const char* ext : exts)
    if (fs::exists(dir / (stem + ext))) return (dir / (stem + ext)).string();
  return (dir / (stem + *exts.begin())).string();  // reported as missing when read
}

class BopReader final : public SelectedFramesReader {
 public:
  BopReader(const std::string& path, const DatasetParams& params) {
    params_ = params;
    if (fs::exists(fs::path(path) / "scene_camera.json")) {
      scene_dir_ = path;
      if (!params.scene.empty() && !same_scene(params.scene, scene_dir_.filename().string()))
        throw ConfigError(fmt::format("dataset.scene = '{}' but {} is the scene folder {}",
                                      params.scene, path, scene_dir_.filename().string()));
    } else {
      const fs::path parent = scenes_parent(path);
      const auto scenes = parent.empty() ? std::vector<std::string>() : scene_folders(parent);
      if (scenes.empty())
        throw IoError(path, "no scene folders with scene_camera.json (here or in a split folder)");
      std::string pick = scenes.front();
      if (!params.scene.empty()) {
        auto it = std::find_if(scenes.begin(), scenes.end(),
                               [&](const std::string& s) { return same_scene(params.scene, s); });
        if (it == scenes.end())
          throw ConfigError(fmt::format("dataset.scene = '{}' is not a scene of {} (has: {})",
                                        params.scene, path, fmt::join(scenes, ", ")));
        pick = *it;
      }
      scene_dir_ = parent / pick;
    }
    const std::string scene_name = scene_dir_.filename().string();
    info_.format = "bop";
    info_.root = path;
    info_.scene_id = is_digits(scene_name) ? parse_int_field(scene_name, scene_dir_.string(),
                                                             "scene folder name (the scene id)", 0)
                                           : 0;

    load_cameras();
    load_ground_truth();
    selected_ = select_frames(images_.size(), params, scene_dir_.string());
    load_models();

    const BopImage& first = images_[selected_.front()];
    info_.intrinsics = with_image_size(apply_intrinsics_overrides(first.camera.K, params),
                                       {color_path(first.im_id)});
    info_.depth_units_per_m = params.depth_units_per_m > 0  ? params.depth_units_per_m
                              : first.camera.depth_scale_mm ? kMmPerM / *first.camera.depth_scale_mm
                                                            : 0.0;
  }

  RgbdFrame read_annotations(size_t i) const override {
    const BopImage& im = images_[position(i)];
    if (!im.camera.error.empty())
      throw IoError((scene_dir_ / "scene_camera.json").string(),
                    fmt::format("image {}: {}", im.im_id, im.camera.error));
    if (!im.gt_error.empty())
      throw IoError((scene_dir_ / "scene_gt.json").string(),
                    fmt::format("image {}: {}", im.im_id, im.gt_error));
    RgbdFrame f;
    f.index = im.im_id;
    f.timestamp_s = im.im_id / kFrameRateHz;
    f.name = fmt::format("{}/{:06d}", scene_dir_.filename().string(), im.im_id);
    f.intrinsics = apply_intrinsics_overrides(im.camera.K, params_);
    f.intrinsics.width = info_.intrinsics.width;
    f.intrinsics.height = info_.intrinsics.height;
    f.T_world_cam_gt = im.camera.T_world_cam;
    f.objects_gt = im.objects;
    return f;
  }

  RgbdFrame read(size_t i) const override {
    RgbdFrame f = read_annotations(i);
    const BopImage& im = images_[position(i)];
    double units = params_.depth_units_per_m;
    if (units <= 0) {
      if (!im.camera.depth_scale_mm)
        throw IoError(
            (scene_dir_ / "scene_camera.json").string(),
            fmt::format("image {}: no 'depth_scale'; set dataset.depth_units_per_m", im.im_id));
      units = kMmPerM / *im.camera.depth_scale_mm;
    }
    const std::string depth_path =
        first_existing(scene_dir_ / "depth", fmt::format("{:06d}", im.im_id), {".png", ".tif"});
    load_color_and_depth(color_path(im.im_id), depth_path, units, params_, f);
    const fs::path mask_dir = scene_dir_ / "mask_visib";
    if (!f.objects_gt.empty() && fs::is_directory(mask_dir)) {
      f.labels_gt = LabelImage(f.depth.width(), f.depth.height(), 0);
      for (size_t k = 0; k < f.objects_gt.size(); ++k) {
        const std::string mask_path =
            (mask_dir / fmt::format("{:06d}_{:06d}.png", im.im_id, k)).string();
        const LabelImage mask = load_labels_matching(mask_path, f);
        for (size_t p = 0; p < mask.size(); ++p)
          if (mask[p] > 0) f.labels_gt[p] = static_cast<int32_t>(k) + 1;
      }
    }
    return f;
  }

  std::vector<StampedPose> ground_truth_trajectory() const override {
    std::vector<StampedPose> out;
    for (size_t p : selected_)
      if (images_[p].camera.T_world_cam)
        out.push_back({images_[p].im_id / kFrameRateHz, *images_[p].camera.T_world_cam});
    return out;
  }

 private:
  static bool same_scene(const std::string& wanted, const std::string& folder) {
    if (wanted == folder) return true;
    long long a = 0, b = 0;
    return is_digits(wanted) && is_digits(folder) &&
           parse_integer(wanted, 0, LLONG_MAX, &a, nullptr) &&
           parse_integer(folder, 0, LLONG_MAX, &b, nullptr) && a == b;
  }

  std::string color_path(int im_id) const {
    const std::string stem = fmt::format("{:06d}", im_id);
    if (!fs::is_directory(scene_dir_ / "rgb") && fs::is_directory(scene_dir_ / "gray"))
      return first_existing(scene_dir_ / "gray", stem, {".png", ".tif", ".jpg"});
    return first_existing(scene_dir_ / "rgb", stem, {".png", ".jpg"});
  }

  void load_cameras() {
    const std::string file = (scene_dir_ / "scene_camera.json").string();
    const json cams = parse_json_file(file);
    if (!cams.is_object()) throw IoError(file, "expected an object {\"im_id\": {...}}");
    for (const auto& [key, cam] : cams.items()) {
      if (!is_digits(key)) throw IoError(file, fmt::format("key '{}' is not an image id", key));
      BopImage im;
      im.im_id = parse_int_field(key, file, fmt::format("key '{}'", key), 0);
      try {
        const auto K = numbers(cam, "cam_K", 9);
        if (!(K[0] > 0) || !(K[4] > 0))
          throw std::runtime_error("cam_K has non-positive focal lengths");
        im.camera.K.fx = K[0];
        im.camera.K.cx = K[2];
        im.camera.K.fy = K[4];
        im.camera.K.cy = K[5];
        if (cam.contains("depth_scale")) {
          const json& s = cam.at("depth_scale");
          if (!s.is_number() || !(s.get<double>() > 0) || !std::isfinite(s.get<double>()))
            throw std::runtime_error("'depth_scale' must be a positive number (mm per raw unit)");
          im.camera.depth_scale_mm = s.get<double>();
        }
        if (cam.contains("cam_R_w2c") || cam.contains("cam_t_w2c")) {
          const SE3 T_cam_world =
              checked_pose(row_major_3x3(numbers(cam, "cam_R_w2c", 9)),
                           vec3(numbers(cam, "cam_t_w2c", 3)) / kMmPerM, file, "cam_R_w2c");
          im.camera.T_world_cam = T_cam_world.inverse();
        }
      } catch (const IoError& e) {
        im.camera.error = problem_of(e);
      } catch (const std::exception& e) {
        im.camera.error = e.what();
      }
      images_.push_back(im);
    }
    std::sort(images_.begin(), images_.end(),
              [](const BopImage& a, const BopImage& b) { return a.im_id < b.im_id; });
  }

  void load_ground_truth() {
    const fs::path gt_file = scene_dir_ / "scene_gt.json";
    if (!fs::exists(gt_file)) return;  // e.g. BOP test images without public ground truth
    const json gt = parse_json_file(gt_file.string());
    json gt_info;
    const fs::path info_file = scene_dir_ / "scene_gt_info.json";
    if (fs::exists(info_file)) gt_info = parse_json_file(info_file.string());
    for (BopImage& im : images_) {
      const std::string key = std::to_string(im.im_id);
      if (!gt.contains(key)) continue;
      try {
        const json& list = gt.at(key);
        if (!list.is_array()) throw std::runtime_error("expected a list of objects");
        const json* infos =
            gt_info.is_object() && gt_info.contains(key) ? &gt_info.at(key) : nullptr;
        std::map<int, int> seen;
        for (size_t k = 0; k < list.size(); ++k) {
          const json& o = list[k];
          if (!o.contains("obj_id") || !o.at("obj_id").is_number_integer() ||
              o.at("obj_id").get<int>() < 1)
            throw std::runtime_error(fmt::format("object {}: 'obj_id' must be an integer >= 1", k));
          ObjectGroundTruth g;
          g.class_id = o.at("obj_id").get<int>();
          g.instance_id = g.class_id + kInstanceStride * seen[g.class_id]++;
          g.T_cam_obj = checked_pose(row_major_3x3(numbers(o, "cam_R_m2c", 9)),
                                     vec3(numbers(o, "cam_t_m2c", 3)) / kMmPerM, gt_file.string(),
                                     fmt::format("object {} cam_R_m2c", k));
          if (infos && infos->is_array() && k < infos->size() &&
              (*infos)[k].contains("visib_fract") && (*infos)[k].at("visib_fract").is_number())
            g.visible_fraction = std::clamp((*infos)[k].at("visib_fract").get<double>(), 0.0, 1.0);
          im.objects.push_back(g);
        }
      } catch (const IoError& e) {
        im.gt_error = problem_of(e);
        im.objects.clear();
      } catch (const std::exception& e) {
        im.gt_error = e.what();
        im.objects.clear();
      }
    }
  }

  void load_models() {
    fs::path models;
    for (const fs::path& dir : {scene_dir_ / "models", scene_dir_.parent_path() / "models",
                                scene_dir_.parent_path().parent_path() / "models"})
      if (fs::is_directory(dir)) {
        models = dir;
        break;
      }
    info_.model_units_per_m = kMmPerM;
    if (models.empty()) return;
    // The BOP toolkit evaluates on models_eval/ (uniformly resampled) when present.
    const fs::path eval_dir = models.parent_path() / "models_eval";
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(models, ec)) {
      const std::string name = e.path().filename().string();
      if (name.size() != 14 || name.rfind("obj_", 0) != 0 || e.path().extension() != ".ply")
        continue;
      const std::string digits = name.substr(4, 6);
      if (!is_digits(digits)) continue;
      const int id = parse_int_field(digits, e.path().string(), "object id in the file name", 0);
      info_.class_names[id] = name.substr(0, 10);
      info_.model_mesh_paths[id] = e.path().string();
      info_.model_points_paths[id] =
          fs::exists(eval_dir / name) ? (eval_dir / name).string() : e.path().string();
    }
    const fs::path info_file = models / "models_info.json";
    if (!fs::exists(info_file)) {
      // Without it every symmetry is lost (ADD instead of ADD-S for the symmetric objects): refused
      // unless asked for (issue 12).
      if (info_.class_names.empty() || params_.bop_without_models_info) return;
      throw IoError(
          info_file.string(),
          "missing: the objects' symmetries are unknown without it (BOP layout); add it, or set "
          "dataset.bop_without_models_info=true to treat every object as asymmetric");
    }
    const json models_info = parse_json_file(info_file.string());
    if (!models_info.is_object())
      throw IoError(info_file.string(), "expected an object {\"obj_id\": {...}}");
    for (const auto& [key, m] : models_info.items()) {
      if (!is_digits(key))
        throw IoError(info_file.string(), fmt::format("key '{}' is not an object id", key));
      const int id = parse_int_field(key, info_file.string(), fmt::format("key '{}'", key), 0);
      if (!info_.class_names.count(id)) info_.class_names[id] = fmt::format("obj_{:06d}", id);
      auto non_empty = [&m = m](const char* field) {  // clang 14 cannot capture a binding
        return m.is_object() && m.contains(field) && m.at(field).is_array() && !m.at(field).empty();
      };
      if (non_empty("symmetries_discrete") || non_empty("symmetries_continuous"))
        info_.symmetric_classes.push_back(id);
    }
    std::sort(info_.symmetric_classes.begin(), info_.symmetric_classes.end());
  }

  fs::path scene_dir_;
  std::vector<BopImage> images_;
};

}  // namespace

bool looks_like_bop(const std::string& path) {
  return fs::exists(fs::path(path) / "scene_camera.json") || !scenes_parent(path).empty();
}

std::unique_ptr<DatasetReader> open_bop(const std::string& path, const DatasetParams& params) {
  if (!looks_like_bop(path))
    throw IoError(path,
                  "not a BOP folder: expected scene_camera.json here or in scene sub-folders");
  return std::make_unique<BopReader>(path, params);
}

}  // namespace orpe::detail
