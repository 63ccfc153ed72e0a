// Microsoft 7-Scenes native layout: frame-NNNNNN.{color.png|color.jpg, depth.png, pose.txt} plus
// camera-intrinsics.txt. Depth in millimetres, pose.txt a 4x4 camera-to-world matrix in metres.
#include <algorithm>
#include <filesystem>
#include <map>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "orpe/core/error.h"
#include "orpe/core/parse_number.h"
#include "orpe/io/dataset_common.h"

namespace orpe::detail {
namespace fs = std::filesystem;
namespace {

constexpr double kDepthUnitsPerM = 1000.0;
constexpr double kFrameRateHz = 30.0;  // Kinect v1; 7-Scenes has no timestamps

struct SevenScenesFrame {
  int number = 0;
  std::string color, depth, pose;  // full paths (color / pose may not exist)
};

/// Frame number of "frame-NNNNNN.<suffix>", or -1.
int frame_number(const std::string& name, const std::string& suffix) {
  if (name.size() <= 6 + suffix.size() || name.rfind("frame-", 0) != 0) return -1;
  if (name.compare(name.size() - suffix.size(), suffix.size(), suffix) != 0) return -1;
  const std::string digits = name.substr(6, name.size() - 6 - suffix.size());
  if (digits.empty() || !std::all_of(digits.begin(), digits.end(), ::isdigit)) return -1;
  return parse_int_field(digits, name, "frame number", 0);
}

std::vector<SevenScenesFrame> scan_frames(const fs::path& root) {
  std::map<int, SevenScenesFrame> frames;
  std::map<int, std::string> colors;
  for (const auto& entry : fs::directory_iterator(root)) {
    const std::string name = entry.path().filename().string();
    if (int n = frame_number(name, ".depth.png"); n >= 0) {
      frames[n].number = n;
      frames[n].depth = entry.path().string();
    } else if (int c = frame_number(name, ".color.png"); c >= 0) {
      colors[c] = entry.path().string();
    } else if (int j = frame_number(name, ".color.jpg"); j >= 0) {
      colors.emplace(j, entry.path().string());  // png preferred when both exist
    }
  }
  std::vector<SevenScenesFrame> out;
  for (auto& [n, f] : frames) {
    const std::string stem = (root / fmt::format("frame-{:06d}", n)).string();
    // A missing colour file is reported when the frame is read (named after the expected path).
    f.color = colors.count(n) ? colors[n] : stem + ".color.png";
    f.pose = stem + ".pose.txt";
    out.push_back(f);
  }
  return out;
}

class SevenScenesReader final : public SelectedFramesReader {
 public:
  SevenScenesReader(const std::string& path, const DatasetParams& params) {
    params_ = params;
    frames_ = scan_frames(path);
    selected_ = select_frames(frames_.size(), params, path);
    info_.format = "7scenes";
    info_.root = path;
    info_.depth_units_per_m =
        params.depth_units_per_m > 0 ? params.depth_units_per_m : kDepthUnitsPerM;
    PinholeIntrinsics k;
    k.fx = k.fy = 585.0;
    k.cx = 320.0;
    k.cy = 240.0;
    const fs::path kfile = fs::path(path) / "camera-intrinsics.txt";
    if (fs::exists(kfile)) k = read_intrinsics_matrix_file(kfile.string(), k);
    intrinsics_ = apply_intrinsics_overrides(k, params);
    info_.intrinsics = with_image_size(intrinsics_, {frames_[selected_.front()].color});
  }

  RgbdFrame read(size_t i) const override {
    RgbdFrame f = read_annotations(i);
    const SevenScenesFrame& fr = frames_[position(i)];
    load_color_and_depth(fr.color, fr.depth, info_.depth_units_per_m, params_, f);
    return f;
  }

  RgbdFrame read_annotations(size_t i) const override {
    const SevenScenesFrame& fr = frames_[position(i)];
    RgbdFrame f;
    f.index = fr.number;
    f.timestamp_s = fr.number / kFrameRateHz;
    f.name = fs::path(fr.color).filename().string();
    f.intrinsics = info_.intrinsics;
    f.T_world_cam_gt = read_pose(fr.pose);
    return f;
  }

  std::vector<StampedPose> ground_truth_trajectory() const override {
    std::vector<StampedPose> out;
    for (size_t p : selected_) {
      try {
        if (auto T = read_pose(frames_[p].pose))
          out.push_back({frames_[p].number / kFrameRateHz, *T});
      } catch (const IoError& e) {
        spdlog::warn("ground truth: {}", e.what());
      }
    }
    return out;
  }

 private:
  /// The frame's T_world_cam, or nothing when pose.txt is absent or holds non-finite values
  /// (7-Scenes marks lost tracking that way). A malformed or non-rigid matrix is an IoError.
  static std::optional<SE3> read_pose(const std::string& path) {
    if (!fs::exists(path)) return std::nullopt;
    const std::vector<double> m = read_number_matrix(path, 4, 4);
    if (!std::all_of(m.begin(), m.end(), [](double x) { return std::isfinite(x); })) {
      spdlog::warn("{}: non-finite pose, frame has no ground truth", path);
      return std::nullopt;
    }
    Mat3 R;
    R << m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10];
    return checked_pose(R, Vec3(m[3], m[7], m[11]), path, "pose");
  }

  std::vector<SevenScenesFrame> frames_;
  PinholeIntrinsics intrinsics_;
};

}  // namespace

bool looks_like_7scenes(const std::string& path) {
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(path, ec))
    if (frame_number(entry.path().filename().string(), ".depth.png") >= 0) return true;
  return false;
}

std::unique_ptr<DatasetReader> open_7scenes(const std::string& path, const DatasetParams& params) {
  if (!fs::is_directory(path)) throw IoError(path, "not a folder");
  if (!looks_like_7scenes(path))
    throw IoError(path, "not a 7-Scenes folder: expected frame-NNNNNN.depth.png files");
  return std::make_unique<SevenScenesReader>(path, params);
}

}  // namespace orpe::detail
