// TUM RGB-D folder: rgb.txt / depth.txt (`timestamp path`), optional associations.txt, optional
// groundtruth.txt (`timestamp tx ty tz qx qy qz qw`, T_world_cam). See docs/DATASETS.md.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "orpe/core/error.h"
#include "orpe/core/text_lines.h"
#include "orpe/io/dataset_common.h"
#include "orpe/io/trajectory_io.h"

namespace orpe::detail {
namespace fs = std::filesystem;
namespace {

constexpr double kTumDepthUnitsPerM = 5000.0;
constexpr double kSevenScenesDepthUnitsPerM = 1000.0;

struct StampedFile {
  double timestamp_s = 0;
  std::string path;  // as written in the list (relative to the root)
};

std::vector<StampedFile> read_file_list(const std::string& path) {
  std::vector<StampedFile> out;
  for_each_data_line(path, "file list", [&](int line_no, const std::string& line) {
    std::istringstream ls(line);
    StampedFile f;
    if (!(ls >> f.timestamp_s >> f.path) || !std::isfinite(f.timestamp_s))
      throw IoError(path, fmt::format("line {}: expected 'timestamp path'", line_no));
    out.push_back(f);
  });
  std::stable_sort(out.begin(), out.end(), [](const StampedFile& a, const StampedFile& b) {
    return a.timestamp_s < b.timestamp_s;
  });
  return out;
}

struct FramePair {
  StampedFile rgb, depth;
};

std::vector<FramePair> read_associations(const std::string& path) {
  std::vector<FramePair> out;
  for_each_data_line(path, "associations file", [&](int line_no, const std::string& line) {
    std::istringstream ls(line);
    FramePair p;
    if (!(ls >> p.rgb.timestamp_s >> p.rgb.path >> p.depth.timestamp_s >> p.depth.path) ||
        !std::isfinite(p.rgb.timestamp_s) || !std::isfinite(p.depth.timestamp_s))
      throw IoError(
          path, fmt::format("line {}: expected 'rgb_timestamp rgb_path depth_timestamp depth_path'",
                            line_no));
    // associate.py writes whichever list was given first; recognise depth-first files by their
    // paths.
    const bool depth_first = p.rgb.path.find("depth") != std::string::npos &&
                             p.depth.path.find("depth") == std::string::npos;
    if (depth_first) std::swap(p.rgb, p.depth);
    out.push_back(p);
  });
  std::stable_sort(out.begin(), out.end(), [](const FramePair& a, const FramePair& b) {
    return a.rgb.timestamp_s < b.rgb.timestamp_s;
  });
  return out;
}

/// Index of the entry of `sorted` (by stamp) nearest to t, or -1 when none is within max_dt.
template <class T, class Stamp>
long nearest_within(const std::vector<T>& sorted, double t, double max_dt, Stamp stamp) {
  const auto it = std::lower_bound(sorted.begin(), sorted.end(), t,
                                   [&](const T& x, double v) { return stamp(x) < v; });
  long best = -1;
  double best_dt = INFINITY;
  if (it != sorted.end()) {
    best = static_cast<long>(it - sorted.begin());
    best_dt = std::abs(stamp(*it) - t);
  }
  if (it != sorted.begin() && std::abs(stamp(*std::prev(it)) - t) < best_dt) {
    best = static_cast<long>(it - sorted.begin()) - 1;
    best_dt = std::abs(stamp(*std::prev(it)) - t);
  }
  return best_dt <= max_dt ? best : -1;
}

/// One-to-one pairing like TUM's associate.py (detail::associate_stamps), in colour order.
std::vector<FramePair> associate(const std::vector<StampedFile>& rgb,
                                 const std::vector<StampedFile>& depth) {
  std::vector<double> ta, tb;
  for (const StampedFile& f : rgb) ta.push_back(f.timestamp_s);
  for (const StampedFile& f : depth) tb.push_back(f.timestamp_s);
  std::vector<FramePair> out;
  for (auto [r, d] : associate_stamps(ta, tb)) out.push_back({rgb[r], depth[d]});
  return out;
}

/// The TUM-indexed copy of 7-Scenes stores depth in millimetres: recognise it by 7-Scenes' own
/// frame files (the first colour file named frame-NNNNNN.color.* with its frame-NNNNNN.pose.txt).
/// A camera-intrinsics.txt alone does not count: it gives intrinsics, never the depth scale.
bool is_seven_scenes_origin(const fs::path& root, const std::vector<FramePair>& pairs) {
  if (pairs.empty()) return false;
  const std::string name = fs::path(pairs.front().rgb.path).filename().string();
  const auto dot = name.find(".color.");
  if (name.rfind("frame-", 0) != 0 || dot == std::string::npos) return false;
  const fs::path pose =
      (root / pairs.front().rgb.path).parent_path() / (name.substr(0, dot) + ".pose.txt");
  std::error_code ec;  // a name too long to look up is no 7-Scenes frame (and no exception)
  return fs::exists(pose, ec);
}

class TumReader final : public SelectedFramesReader {
 public:
  TumReader(const std::string& path, const DatasetParams& params) : root_(path) {
    params_ = params;
    if (fs::exists(root_ / "associations.txt")) {
      pairs_ = read_associations((root_ / "associations.txt").string());
    } else {
      const auto rgb = read_file_list((root_ / "rgb.txt").string());
      const auto depth = read_file_list((root_ / "depth.txt").string());
      pairs_ = associate(rgb, depth);
      if (pairs_.size() < rgb.size())
        spdlog::info("{}: {} of {} colour frames have no depth frame within {} s", path,
                     rgb.size() - pairs_.size(), rgb.size(), kMaxPairDtS);
    }
    selected_ = select_frames(pairs_.size(), params, path);

    if (fs::exists(root_ / "groundtruth.txt")) {
      const auto gt = read_tum_trajectory((root_ / "groundtruth.txt").string());
      std::vector<StampedPose> sorted = gt;
      std::stable_sort(
          sorted.begin(), sorted.end(),
          [](const StampedPose& a, const StampedPose& b) { return a.timestamp_s < b.timestamp_s; });
      gt_of_pair_.resize(pairs_.size());
      for (size_t i = 0; i < pairs_.size(); ++i) {
        const long j = nearest_within(sorted, pairs_[i].rgb.timestamp_s, kMaxPairDtS,
                                      [](const StampedPose& p) { return p.timestamp_s; });
        if (j >= 0) gt_of_pair_[i] = sorted[static_cast<size_t>(j)].T_world_cam;
      }
    }

    const bool seven_scenes = is_seven_scenes_origin(root_, pairs_);
    info_.format = "tum";
    info_.root = path;
    info_.depth_units_per_m = params.depth_units_per_m > 0 ? params.depth_units_per_m
                              : seven_scenes               ? kSevenScenesDepthUnitsPerM
                                                           : kTumDepthUnitsPerM;
    PinholeIntrinsics
        k;  // TUM fr1/2/3 differ; 525 / 525 / 319.5 / 239.5 is the ROS default for all
    if (fs::exists(root_ / "camera-intrinsics.txt"))
      k = read_intrinsics_matrix_file((root_ / "camera-intrinsics.txt").string(), k);
    intrinsics_ = apply_intrinsics_overrides(k, params);
    info_.intrinsics = with_image_size(intrinsics_, {file(pairs_[selected_.front()].rgb.path)});
  }

  RgbdFrame read(size_t i) const override {
    RgbdFrame f = read_annotations(i);
    const FramePair& pair = pairs_[position(i)];
    load_color_and_depth(file(pair.rgb.path), file(pair.depth.path), info_.depth_units_per_m,
                         params_, f);
    return f;
  }

  RgbdFrame read_annotations(size_t i) const override {
    const size_t p = position(i);
    const FramePair& pair = pairs_[p];
    RgbdFrame f;
    f.index = static_cast<int>(p);
    f.timestamp_s = pair.rgb.timestamp_s;
    f.name = pair.rgb.path;
    f.intrinsics = info_.intrinsics;
    if (p < gt_of_pair_.size()) f.T_world_cam_gt = gt_of_pair_[p];
    return f;
  }

  std::vector<StampedPose> ground_truth_trajectory() const override {
    std::vector<StampedPose> out;
    for (size_t p : selected_)
      if (p < gt_of_pair_.size() && gt_of_pair_[p])
        out.push_back({pairs_[p].rgb.timestamp_s, *gt_of_pair_[p]});
    return out;
  }

 private:
  std::string file(const std::string& relative) const {
    const fs::path rel(relative);
    return rel.is_absolute() ? relative : (root_ / rel).string();
  }

  fs::path root_;
  std::vector<FramePair> pairs_;
  std::vector<std::optional<SE3>> gt_of_pair_;
  PinholeIntrinsics intrinsics_;
};

}  // namespace

bool looks_like_tum(const std::string& path) {
  const fs::path root(path);
  return fs::exists(root / "associations.txt") ||
         (fs::exists(root / "rgb.txt") && fs::exists(root / "depth.txt"));
}

std::unique_ptr<DatasetReader> open_tum(const std::string& path, const DatasetParams& params) {
  if (!looks_like_tum(path))
    throw IoError(path,
                  "not a TUM RGB-D folder: expected rgb.txt and depth.txt (or associations.txt)");
  return std::make_unique<TumReader>(path, params);
}

}  // namespace orpe::detail
