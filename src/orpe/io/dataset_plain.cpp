// Plain folder: rgb/ + depth/ image folders and a camera file (camera.yaml in the folder, or
// dataset.camera_file). Pairing: when every file name (without extension) is a number, by that
// number: names with a decimal point are timestamps in seconds (as TUM writes them, nearest within
// 0.02 s), whole numbers are frame numbers (the same number in both folders; the frame index, and
// timestamp = number / 30 s); otherwise by sorted name, which needs the same number of files in
// both folders (index = position). See docs/DATASETS.md.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <set>

#include <fmt/format.h>

#include "orpe/core/error.h"
#include "orpe/io/dataset_common.h"

namespace orpe::detail {
namespace fs = std::filesystem;
namespace {

constexpr double kFrameRateHz = 30.0;  // timestamps when the names carry none

std::vector<fs::path> images_in(const fs::path& dir) {
  static const std::set<std::string> kExt = {".png", ".jpg", ".jpeg", ".tif", ".tiff", ".exr"};
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(dir)) {
    std::string ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return std::tolower(c); });
    if (e.is_regular_file() && kExt.count(ext)) out.push_back(e.path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

/// The number a file name (stem) is, or nullopt.
std::optional<double> stamp_of(const fs::path& p) {
  const std::string s = p.stem().string();
  if (s.empty() ||
      !std::all_of(s.begin(), s.end(), [](unsigned char c) { return std::isdigit(c) || c == '.'; }))
    return std::nullopt;
  try {
    size_t used = 0;
    const double t = std::stod(s, &used);
    return used == s.size() && std::isfinite(t) ? std::optional<double>(t) : std::nullopt;
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

struct PlainPair {
  fs::path rgb, depth;
  double timestamp_s = 0;
  int index = 0;
};

bool whole_number_names(const std::vector<fs::path>& v) {
  return std::all_of(v.begin(), v.end(), [](const fs::path& p) {
    const std::string s = p.stem().string();
    return s.size() <= 9 && s.find('.') == std::string::npos;
  });
}

/// Colour and depth files paired one-to-one by the stamps in their names like TUM's associate.py
/// (detail::associate_stamps), in colour order.
std::vector<PlainPair> pair_by_timestamp(const std::vector<fs::path>& rgb,
                                         const std::vector<fs::path>& depth) {
  std::vector<std::pair<double, fs::path>> d;
  for (const auto& p : depth) d.emplace_back(*stamp_of(p), p);
  std::sort(d.begin(), d.end());
  std::vector<double> ta, tb;
  for (const auto& r : rgb) ta.push_back(*stamp_of(r));
  for (const auto& x : d) tb.push_back(x.first);
  std::vector<PlainPair> out;
  for (auto [r, k] : associate_stamps(ta, tb))
    out.push_back({rgb[r], d[k].second, ta[r], static_cast<int>(out.size())});
  return out;
}

class PlainReader final : public SelectedFramesReader {
 public:
  PlainReader(const std::string& path, const DatasetParams& params) {
    params_ = params;
    const fs::path root(path);
    const auto rgb = images_in(root / "rgb"), depth = images_in(root / "depth");
    if (rgb.empty()) throw IoError((root / "rgb").string(), "no images (.png, .jpg, .tif)");
    if (depth.empty()) throw IoError((root / "depth").string(), "no images (.png, .tif)");
    const auto all_stamped = [](const std::vector<fs::path>& v) {
      return std::all_of(v.begin(), v.end(),
                         [](const fs::path& p) { return stamp_of(p).has_value(); });
    };
    if (all_stamped(rgb) && all_stamped(depth)) {
      pairs_ = pair_by_timestamp(rgb, depth);
      if (whole_number_names(rgb) && whole_number_names(depth))
        for (PlainPair& p : pairs_) {
          p.index = static_cast<int>(p.timestamp_s);
          p.timestamp_s = p.index / kFrameRateHz;
        }
      if (pairs_.empty())
        throw IoError(path,
                      "no colour image has a depth image within 0.02 s (names are timestamps)");
    } else {
      if (rgb.size() != depth.size())
        throw IoError(path, fmt::format("rgb/ has {} images and depth/ {}: with names that are not "
                                        "timestamps, frames are paired by sorted name and the "
                                        "counts must agree",
                                        rgb.size(), depth.size()));
      for (size_t i = 0; i < rgb.size(); ++i)
        pairs_.push_back({rgb[i], depth[i], i / kFrameRateHz, static_cast<int>(i)});
    }
    selected_ = select_frames(pairs_.size(), params, path);
    info_.format = "plain";
    info_.root = path;
    info_.depth_units_per_m = params.depth_units_per_m;
    info_.intrinsics = with_image_size(apply_intrinsics_overrides({}, params),
                                       {pairs_[selected_.front()].rgb.string()});
  }

  RgbdFrame read(size_t i) const override {
    RgbdFrame f = read_annotations(i);
    const PlainPair& p = pairs_[position(i)];
    load_color_and_depth(p.rgb.string(), p.depth.string(), info_.depth_units_per_m, params_, f);
    return f;
  }

  RgbdFrame read_annotations(size_t i) const override {
    const size_t pos = position(i);
    RgbdFrame f;
    f.index = pairs_[pos].index;
    f.timestamp_s = pairs_[pos].timestamp_s;
    f.name = pairs_[pos].rgb.string();
    f.intrinsics = info_.intrinsics;
    return f;
  }

 private:
  std::vector<PlainPair> pairs_;
};

}  // namespace

bool looks_like_plain(const std::string& path) {
  const fs::path root(path);
  return fs::is_directory(root / "rgb") && fs::is_directory(root / "depth") &&
         !fs::exists(root / "rgb.txt");
}

std::unique_ptr<DatasetReader> open_plain(const std::string& path, const DatasetParams& params) {
  if (!looks_like_plain(path))
    throw IoError(path, "not a plain folder: expected rgb/ and depth/ image folders");
  if (!(params.depth_units_per_m > 0))
    throw IoError(path,
                  "a plain folder needs its depth scale: DepthMapFactor / depth_units_per_m "
                  "in the camera file (camera.yaml or dataset.camera_file), or "
                  "dataset.depth_units_per_m");
  return std::make_unique<PlainReader>(path, params);
}

}  // namespace orpe::detail
