#include "orpe/io/dataset.h"

#include <filesystem>

#include <spdlog/spdlog.h>

#include "orpe/core/error.h"
#include "orpe/io/dataset_common.h"

namespace orpe {

bool DatasetParams::IsValid(std::string* why) const {
  auto fail = [&](const std::string& msg) {
    if (why) *why = msg;
    return false;
  };
  if (format != "auto" && format != "tum" && format != "7scenes" && format != "ycbv" &&
      format != "bop")
    return fail("format must be one of auto, tum, 7scenes, ycbv, bop (got '" + format + "')");
  if (first_frame < 0) return fail("first_frame must be >= 0");
  if (last_frame < -1) return fail("last_frame must be -1 (to the end) or a frame index, not " + std::to_string(last_frame));
  if (last_frame >= 0 && last_frame < first_frame)
    return fail("last_frame must be -1 or >= first_frame");
  if (stride < 1) return fail("stride must be >= 1");
  if (depth_units_per_m < 0) return fail("depth_units_per_m must be >= 0 (0 = preset)");
  if (fx < 0 || fy < 0) return fail("fx, fy must be >= 0 (0 = preset)");
  if (max_depth_m < 0) return fail("max_depth_m must be >= 0 (0 = keep all)");
  return true;
}

std::string detect_dataset_format(const std::string& path) {
  namespace fs = std::filesystem;
  if (!fs::exists(path)) throw IoError(path, "dataset folder not found");
  if (!fs::is_directory(path)) throw IoError(path, "dataset path is not a folder");
  // Most specific first; the TUM index wins over 7-Scenes' own files when a folder has both (the
  // shared 7-Scenes copy), since it is the explicit frame list.
  if (detail::looks_like_bop(path)) return "bop";
  if (detail::looks_like_ycbv(path)) return "ycbv";
  if (detail::looks_like_tum(path)) return "tum";
  if (detail::looks_like_7scenes(path)) return "7scenes";
  throw IoError(
      path,
      "unknown dataset layout; looked for: BOP (scene_camera.json here, in scene sub-folders or in "
      "split/scene sub-folders), "
      "YCB-Video (data/NNNN/NNNNNN-meta.mat, or NNNNNN-color.png + NNNNNN-meta.mat here), "
      "TUM RGB-D (rgb.txt + depth.txt, or associations.txt), 7-Scenes (frame-NNNNNN.depth.png); "
      "set dataset.format to force one");
}

std::unique_ptr<DatasetReader> open_dataset(const std::string& path, const DatasetParams& params) {
  std::string why;
  if (!params.IsValid(&why)) throw ConfigError("dataset: " + why);
  if (!std::filesystem::is_directory(path)) throw IoError(path, "dataset folder not found");
  const std::string format = params.format == "auto" ? detect_dataset_format(path) : params.format;
  std::unique_ptr<DatasetReader> reader;
  if (format == "tum")
    reader = detail::open_tum(path, params);
  else if (format == "7scenes")
    reader = detail::open_7scenes(path, params);
  else if (format == "ycbv")
    reader = detail::open_ycbv(path, params);
  else if (format == "bop")
    reader = detail::open_bop(path, params);
  else
    throw ConfigError("dataset.format: unknown layout '" + format + "'");
  const DatasetInfo& info = reader->info();
  spdlog::info(
      "dataset {} ({}): {} frames, depth {} units/m, fx {:.1f} fy {:.1f} cx {:.1f} cy {:.1f}", path,
      info.format, reader->size(), info.depth_units_per_m, info.intrinsics.fx, info.intrinsics.fy,
      info.intrinsics.cx, info.intrinsics.cy);
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
