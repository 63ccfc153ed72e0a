#include "orpe/io/dataset_common.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "orpe/core/error.h"
#include "orpe/io/image_io.h"

namespace orpe::detail {

std::vector<size_t> select_frames(size_t total, const DatasetParams& params,
                                  const std::string& root) {
  if (total == 0) throw IoError(root, "no frames found");
  const size_t first = static_cast<size_t>(params.first_frame);
  if (first >= total)
    throw ConfigError(fmt::format("dataset.first_frame = {} but {} has only {} frames",
                                  params.first_frame, root, total));
  size_t last = total - 1;
  if (params.last_frame >= 0) last = std::min(last, static_cast<size_t>(params.last_frame));
  std::vector<size_t> out;
  for (size_t i = first; i <= last; i += static_cast<size_t>(params.stride))
    if (params.cut_first < 0 || i < static_cast<size_t>(params.cut_first) ||
        i > static_cast<size_t>(params.cut_last))
      out.push_back(i);
  if (out.empty())
    throw ConfigError(fmt::format("dataset.cut_first / cut_last ({} - {}) leave no frame of {}",
                                  params.cut_first, params.cut_last, root));
  return out;
}

PinholeIntrinsics apply_intrinsics_overrides(PinholeIntrinsics k, const DatasetParams& params) {
  if (params.fx > 0) k.fx = params.fx;
  if (params.fy > 0) k.fy = params.fy;
  if (params.cx != 0) k.cx = params.cx;
  if (params.cy != 0) k.cy = params.cy;
  return k;
}

void load_color_and_depth(const std::string& color_path, const std::string& depth_path,
                          double depth_units_per_m, const DatasetParams& params, RgbdFrame& frame) {
  if (!(depth_units_per_m > 0) || !std::isfinite(depth_units_per_m))
    throw IoError(depth_path,
                  fmt::format("depth scale must be a positive number of units per metre, got {} "
                              "(set dataset.depth_units_per_m)",
                              depth_units_per_m));
  frame.color = read_color_image(color_path);
  DepthReadStats stats;
  frame.depth = read_depth_image(depth_path, depth_units_per_m, &stats);
  finish_color_and_depth(color_path, depth_path, stats, params, frame);
}

void finish_color_and_depth(const std::string& color_name, const std::string& depth_name,
                            const DepthReadStats& stats, const DatasetParams& params,
                            RgbdFrame& frame) {
  // A depth camera of its own (camera file) is registered into colour later, at any size.
  const bool same_size =
      frame.color.width() == frame.depth.width() && frame.color.height() == frame.depth.height();
  if (!same_size && !params.depth_registered_later)
    throw IoError(depth_name,
                  fmt::format("depth is {}x{} but colour image {} is {}x{} (a depth camera of "
                              "another size needs a camera file with its intrinsics and "
                              "T_colour_depth, docs/DATASETS.md)",
                              frame.depth.width(), frame.depth.height(), color_name,
                              frame.color.width(), frame.color.height()));
  if (stats.nonfinite_or_negative_pixels > 0)
    spdlog::warn("{}: {} NaN, inf or negative depth values set to invalid (0)", depth_name,
                 stats.nonfinite_or_negative_pixels);
  if (stats.invalid_pixels == frame.depth.size())
    throw IoError(depth_name,
                  fmt::format("no valid depth: all {} pixels are 0, NaN, inf or negative",
                              frame.depth.size()));
  if (params.max_depth_m > 0) {
    const float max_m = static_cast<float>(params.max_depth_m);
    for (float& z : frame.depth)
      if (z > max_m) z = 0.0f;
  }
  frame.intrinsics.width = frame.color.width();
  frame.intrinsics.height = frame.color.height();
}

LabelImage load_labels_matching(const std::string& path, const RgbdFrame& frame) {
  LabelImage labels = read_label_image(path);
  if (labels.width() != frame.depth.width() || labels.height() != frame.depth.height())
    throw IoError(path, fmt::format("label image is {}x{} but the frame is {}x{}", labels.width(),
                                    labels.height(), frame.depth.width(), frame.depth.height()));
  return labels;
}

std::vector<double> read_number_matrix(const std::string& path, int rows, int cols) {
  std::ifstream is(path);
  if (!is) throw IoError(path, "cannot open file");
  const int n = rows * cols;
  std::vector<double> values;
  values.reserve(n);
  std::string token;
  while (static_cast<int>(values.size()) < n && is >> token) {
    try {
      size_t used = 0;
      const double x = std::stod(token, &used);
      if (used != token.size()) throw std::invalid_argument(token);
      values.push_back(x);
    } catch (const std::out_of_range&) {
      values.push_back(token[0] == '-' ? -INFINITY : INFINITY);
    } catch (const std::invalid_argument&) {
      throw IoError(
          path, fmt::format("expected a {}x{} matrix of numbers, found '{}'", rows, cols, token));
    }
  }
  if (static_cast<int>(values.size()) < n)
    throw IoError(
        path, fmt::format("expected a {}x{} matrix ({} numbers), found only {} (truncated?)", rows,
                          cols, n, values.size()));
  return values;
}

PinholeIntrinsics read_intrinsics_matrix_file(const std::string& path, PinholeIntrinsics base) {
  const std::vector<double> K = read_number_matrix(path, 3, 3);
  for (double x : K)
    if (!std::isfinite(x)) throw IoError(path, "non-finite value in the camera matrix");
  if (!(K[0] > 0) || !(K[4] > 0))
    throw IoError(path, "camera matrix has non-positive focal lengths");
  base.fx = K[0];
  base.cx = K[2];
  base.fy = K[4];
  base.cy = K[5];
  return base;
}

SE3 checked_pose(const Mat3& R, const Vec3& t, const std::string& path, const std::string& what) {
  if (!R.allFinite() || !t.allFinite()) throw IoError(path, what + ": non-finite value");
  const double orth_err = (R * R.transpose() - Mat3::Identity()).norm();
  if (orth_err > 1e-2 || R.determinant() < 0)
    throw IoError(path,
                  fmt::format("{}: rotation is not orthonormal (|R R^T - I| = {:.2g}, det {:.3f})",
                              what, orth_err, R.determinant()));
  return SE3(orthonormalize(R), t);
}

std::vector<std::pair<size_t, size_t>> associate_stamps(const std::vector<double>& a,
                                                        const std::vector<double>& b,
                                                        double max_dt_s) {
  struct Candidate {
    double dt;
    size_t i, j;
  };
  std::vector<Candidate> candidates;
  for (size_t i = 0; i < a.size(); ++i) {
    const double t = a[i];
    const auto lo = std::lower_bound(b.begin(), b.end(), t - max_dt_s);
    for (auto it = lo; it != b.end() && *it <= t + max_dt_s; ++it)
      candidates.push_back({std::abs(*it - t), i, static_cast<size_t>(it - b.begin())});
  }
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const Candidate& x, const Candidate& y) { return x.dt < y.dt; });
  std::vector<char> a_used(a.size(), 0), b_used(b.size(), 0);
  std::vector<std::pair<size_t, size_t>> matches;
  for (const Candidate& c : candidates) {
    if (a_used[c.i] || b_used[c.j]) continue;
    a_used[c.i] = b_used[c.j] = 1;
    matches.emplace_back(c.i, c.j);
  }
  std::sort(matches.begin(), matches.end());
  return matches;
}

PinholeIntrinsics with_image_size(PinholeIntrinsics k, const std::vector<std::string>& paths) {
  for (size_t i = 0; i < paths.size() && i < 3; ++i) {
    try {
      const ColorImage c = read_color_image(paths[i]);
      k.width = c.width();
      k.height = c.height();
      return k;
    } catch (const IoError&) {
      // A bad first frame is reported (and skipped) when it is read; keep looking here.
    }
  }
  return k;
}

size_t SelectedFramesReader::position(size_t i) const {
  if (i >= selected_.size())
    throw std::out_of_range(
        fmt::format("frame {} out of range (dataset has {} selected frames)", i, selected_.size()));
  return selected_[i];
}

}  // namespace orpe::detail
