// Internals shared by the dataset readers (tum, 7scenes, ycbv, bop): frame selection, intrinsics
// overrides, loading one colour + depth pair with its checks, small text parsers. Not a public API:
// include "orpe/io/dataset.h" and call open_dataset().
#pragma once

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "orpe/core/frame.h"
#include "orpe/io/dataset.h"
#include "orpe/io/image_io.h"

namespace orpe::detail {

/// Positions (into a list of `total` frames) chosen by first_frame / last_frame / stride.
/// Throws IoError when the list is empty and ConfigError when first_frame is past its end.
std::vector<size_t> select_frames(size_t total, const DatasetParams& params,
                                  const std::string& root);

/// Applies the non-zero fx / fy / cx / cy of `params` to `k`.
PinholeIntrinsics apply_intrinsics_overrides(PinholeIntrinsics k, const DatasetParams& params);

/// Reads colour + depth into `frame` (color, depth, intrinsics' width/height), with the checks
/// every layout needs: both files present and decodable, equal sizes, a positive depth scale, at
/// least one valid depth pixel. Depth beyond params.max_depth_m is set to 0. NaN / inf / negative
/// values of float depth images become 0 (CONVENTIONS.md) and are logged.
void load_color_and_depth(const std::string& color_path, const std::string& depth_path,
                          double depth_units_per_m, const DatasetParams& params, RgbdFrame& frame);

/// The checks of load_color_and_depth on images already decoded (a ROS bag's messages): equal
/// sizes (unless params.depth_registered_later), at least one valid depth pixel (`stats`), depth
/// beyond max_depth_m cleared; sets the intrinsics' size to the colour image's. Names are for
/// messages.
void finish_color_and_depth(const std::string& color_name, const std::string& depth_name,
                            const DepthReadStats& stats, const DatasetParams& params,
                            RgbdFrame& frame);

/// Reads a label image and checks that its size matches `frame.depth`.
LabelImage load_labels_matching(const std::string& path, const RgbdFrame& frame);

/// Reads `rows x cols` whitespace-separated numbers (e.g. a 3x3 K or a 4x4 pose). Throws IoError
/// for a missing file, too few numbers or a non-numeric token. Values may be non-finite ("inf",
/// "nan").
std::vector<double> read_number_matrix(const std::string& path, int rows, int cols);

/// Reads a 3x3 camera matrix file (7-Scenes camera-intrinsics.txt) into fx, fy, cx, cy (keeps
/// width / height of `base`). Throws IoError when the values are not a finite, positive-focal K.
PinholeIntrinsics read_intrinsics_matrix_file(const std::string& path, PinholeIntrinsics base);

/// Makes an SE3 from a row-major 3x3 rotation and translation, checking that R is a rotation within
/// 1e-2 (|R R^T - I|; 7-Scenes poses are off by up to 4e-4), then orthonormalised. Throws
/// IoError(path, what + ...) otherwise.
SE3 checked_pose(const Mat3& R, const Vec3& t, const std::string& path, const std::string& what);

/// Width / height of the first readable colour image among `paths` (tried in order, at most a few),
/// so DatasetInfo::intrinsics carries the real image size. Keeps `k` unchanged when none is
/// readable.
PinholeIntrinsics with_image_size(PinholeIntrinsics k, const std::vector<std::string>& paths);

/// The largest time difference of a colour / depth pair (REFERENCE.md; TUM's associate.py).
constexpr double kMaxPairDtS = 0.02;

/// One-to-one pairing of two stamp lists like TUM's associate.py: every candidate pair within
/// `max_dt_s`, taken greedily by increasing time difference (ties: lower index into `a` first),
/// each index used at most once. Returns (index into a, index into b), sorted by the index into a.
/// Precondition: `b` is sorted ascending (`a` need not be).
std::vector<std::pair<size_t, size_t>> associate_stamps(const std::vector<double>& a,
                                                        const std::vector<double>& b,
                                                        double max_dt_s = kMaxPairDtS);

/// Common base: owns info, params and the selected positions.
class SelectedFramesReader : public DatasetReader {
 public:
  const DatasetInfo& info() const override { return info_; }
  size_t size() const override { return selected_.size(); }

 protected:
  /// Position in the layout's full frame list of selected frame i. Throws std::out_of_range.
  size_t position(size_t i) const;

  DatasetParams params_;
  DatasetInfo info_;
  std::vector<size_t> selected_;
};

// Factories of the readers (one .cpp each).
std::unique_ptr<DatasetReader> open_tum(const std::string& path, const DatasetParams& params);
std::unique_ptr<DatasetReader> open_7scenes(const std::string& path, const DatasetParams& params);
std::unique_ptr<DatasetReader> open_ycbv(const std::string& path, const DatasetParams& params);
std::unique_ptr<DatasetReader> open_bop(const std::string& path, const DatasetParams& params);
std::unique_ptr<DatasetReader> open_plain(const std::string& path, const DatasetParams& params);
/// A ROS 1 bag file (dataset_rosbag.cpp; without ORPE_WITH_ROSBAG a ConfigError saying so).
std::unique_ptr<DatasetReader> open_rosbag(const std::string& path, const DatasetParams& params);

// Layout probes used by detect_dataset_format (true when `path` looks like that layout).
bool looks_like_tum(const std::string& path);
bool looks_like_7scenes(const std::string& path);
bool looks_like_ycbv(const std::string& path);
bool looks_like_bop(const std::string& path);
bool looks_like_plain(const std::string& path);

}  // namespace orpe::detail
