#include "orpe/io/dataset.h"

#include <filesystem>

#include <spdlog/spdlog.h>

#include "orpe/core/error.h"
#include "orpe/io/camera_file.h"
#include "orpe/io/dataset_common.h"
#include "orpe/io/models_folder.h"

namespace orpe {

bool DatasetParams::IsValid(std::string* why) const {
  auto fail = [&](const std::string& msg) {
    if (why) *why = msg;
    return false;
  };
  if (format != "auto" && format != "tum" && format != "7scenes" && format != "ycbv" &&
      format != "bop" && format != "plain" && format != "rosbag")
    return fail("format must be one of auto, tum, 7scenes, ycbv, bop, plain, rosbag (got '" +
                format + "')");
  if (bag_colour_topic.empty() || bag_depth_topic.empty())
    return fail("bag_colour_topic and bag_depth_topic must not be empty");
  if (first_frame < 0) return fail("first_frame must be >= 0");
  if (last_frame < -1)
    return fail("last_frame must be -1 (to the end) or a frame index, not " +
                std::to_string(last_frame));
  if (last_frame >= 0 && last_frame < first_frame)
    return fail("last_frame must be -1 or >= first_frame");
  if (stride < 1) return fail("stride must be >= 1");
  if ((cut_first < 0) != (cut_last < 0) || cut_first < -1 || cut_last < -1)
    return fail("cut_first and cut_last must both be -1 (no gap) or both frame indices");
  if (cut_last < cut_first) return fail("cut_last must be >= cut_first");
  if (depth_units_per_m < 0) return fail("depth_units_per_m must be >= 0 (0 = preset)");
  if (fx < 0 || fy < 0) return fail("fx, fy must be >= 0 (0 = preset)");
  if (max_depth_m < 0) return fail("max_depth_m must be >= 0 (0 = keep all)");
  if (!models_unit.empty() && models_unit != "m" && models_unit != "mm")
    return fail("models_unit must be m or mm, or empty to detect (got '" + models_unit + "')");
  return true;
}

namespace {
/// A ROS 1 bag given as the dataset: a regular file named *.bag.
bool is_bag_file(const std::string& path) {
  namespace fs = std::filesystem;
  return fs::is_regular_file(path) && fs::path(path).extension() == ".bag";
}
}  // namespace

std::string detect_dataset_format(const std::string& path) {
  namespace fs = std::filesystem;
  if (!fs::exists(path)) throw IoError(path, "dataset folder not found");
  if (is_bag_file(path)) return "rosbag";
  if (!fs::is_directory(path))
    throw IoError(path, "dataset path is not a folder (nor a ROS bag file, *.bag)");
  // Most specific first; the TUM index wins over 7-Scenes' own files when a folder has both (the
  // shared 7-Scenes copy), since it is the explicit frame list.
  if (detail::looks_like_bop(path)) return "bop";
  if (detail::looks_like_ycbv(path)) return "ycbv";
  if (detail::looks_like_tum(path)) return "tum";
  if (detail::looks_like_7scenes(path)) return "7scenes";
  if (detail::looks_like_plain(path)) return "plain";
  throw IoError(
      path,
      "unknown dataset layout; looked for: BOP (scene_camera.json here, in scene sub-folders or in "
      "split/scene sub-folders), "
      "YCB-Video (data/NNNN/NNNNNN-meta.mat, or NNNNNN-color.png + NNNNNN-meta.mat here), "
      "TUM RGB-D (rgb.txt + depth.txt, or associations.txt), 7-Scenes (frame-NNNNNN.depth.png), "
      "a plain folder (rgb/ + depth/ image folders with a camera.yaml), a ROS bag (a *.bag file); "
      "set dataset.format to force one");
}

namespace {

/// A layout's reader with the dataset.* overrides that apply to every layout: the camera file
/// (undistortion, registration, intrinsics, depth range) and the models folder.
class OverrideReader final : public DatasetReader {
 public:
  OverrideReader(std::unique_ptr<DatasetReader> inner, std::optional<CameraFileInfo> camera,
                 const DatasetParams& params)
      : inner_(std::move(inner)), params_(params) {
    info_ = inner_->info();
    if (!params.models_dir.empty())
      apply_models_folder(info_, params.models_dir, params.models_unit);
    if (camera) {
      PinholeIntrinsics k = camera->colour;
      if (k.width == 0) k.width = info_.intrinsics.width, k.height = info_.intrinsics.height;
      camera->colour = k;
      info_.intrinsics = detail::apply_intrinsics_overrides(k, params);
      info_.camera = std::move(camera);
    }
  }
  const DatasetInfo& info() const override { return info_; }
  size_t size() const override { return inner_->size(); }
  RgbdFrame read(size_t i) const override {
    RgbdFrame f = inner_->read(i);
    if (info_.camera) {
      apply_camera_file(*info_.camera, f.name, f);
      f.intrinsics = detail::apply_intrinsics_overrides(f.intrinsics, params_);
    }
    return f;
  }
  RgbdFrame read_annotations(size_t i) const override {
    RgbdFrame f = inner_->read_annotations(i);
    if (info_.camera) f.intrinsics = info_.intrinsics;
    return f;
  }
  std::vector<StampedPose> ground_truth_trajectory() const override {
    return inner_->ground_truth_trajectory();
  }

 private:
  std::unique_ptr<DatasetReader> inner_;
  DatasetParams params_;
  DatasetInfo info_;
};

}  // namespace

std::unique_ptr<DatasetReader> open_dataset(const std::string& path, const DatasetParams& params) {
  namespace fs = std::filesystem;
  std::string why;
  if (!params.IsValid(&why)) throw ConfigError("dataset: " + why);
  const bool bag_file = is_bag_file(path);
  if (!fs::is_directory(path) && !bag_file) throw IoError(path, "dataset folder not found");
  const std::string format = params.format == "auto" ? detect_dataset_format(path) : params.format;
  // The camera file: dataset.camera_file, else a plain folder's camera.yaml.
  std::optional<CameraFileInfo> camera;
  std::string camera_path = params.camera_file;
  if (camera_path.empty() && format == "plain" && fs::exists(fs::path(path) / "camera.yaml"))
    camera_path = (fs::path(path) / "camera.yaml").string();
  DatasetParams p = params;
  if (!camera_path.empty()) {
    camera = read_camera_file(camera_path);
    if (p.depth_units_per_m == 0) p.depth_units_per_m = camera->depth_units_per_m;
    p.depth_registered_later = camera->has_depth_camera;
  } else if (format == "plain" && !(params.fx > 0 && params.fy > 0)) {
    throw IoError(path,
                  "a plain folder needs a camera file: camera.yaml in the folder, or "
                  "--camera FILE (dataset.camera_file)");
  }
  std::unique_ptr<DatasetReader> reader;
  if (format == "tum")
    reader = detail::open_tum(path, p);
  else if (format == "7scenes")
    reader = detail::open_7scenes(path, p);
  else if (format == "ycbv")
    reader = detail::open_ycbv(path, p);
  else if (format == "bop")
    reader = detail::open_bop(path, p);
  else if (format == "plain")
    reader = detail::open_plain(path, p);
  else if (format == "rosbag")
    reader = detail::open_rosbag(path, p);
  else
    throw ConfigError("dataset.format: unknown layout '" + format + "'");
  if (camera || !params.models_dir.empty())
    reader = std::make_unique<OverrideReader>(std::move(reader), std::move(camera), p);
  const DatasetInfo& info = reader->info();
  spdlog::info(
      "dataset {} ({}): {} frames, depth {} units/m, fx {:.1f} fy {:.1f} cx {:.1f} cy {:.1f}{}",
      path, info.format, reader->size(), info.depth_units_per_m, info.intrinsics.fx,
      info.intrinsics.fy, info.intrinsics.cx, info.intrinsics.cy,
      info.camera ? " (camera file " + info.camera->path + ")" : std::string());
  return reader;
}

bool FrameStream::next(RgbdFrame& frame) {
  while (pos_ < reader_.size()) {
    const size_t i = pos_++;
    try {
      frame = reader_.read(i);
      return true;
    } catch (const IoError& e) {
      spdlog::warn("skipping frame {}: {}", i, e.what());
      skipped_.emplace_back(i, e.what());
    }
  }
  return false;
}

}  // namespace orpe
