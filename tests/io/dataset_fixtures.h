// Tiny on-disk datasets (8x6 images) for the reader tests.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "orpe/core/error.h"
#include "orpe/core/se3.h"
#include "orpe/io/dataset.h"
#include "orpe/io/image_io.h"

namespace orpe::test {

constexpr int kW = 8;
constexpr int kH = 6;

/// Colour with a per-frame pattern so frames can be told apart.
inline ColorImage tiny_color(int seed, int w = kW, int h = kH) {
  ColorImage c(w, h);
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u)
      c.at(u, v) = {static_cast<uint8_t>(10 * u + seed), static_cast<uint8_t>(20 * v),
                    static_cast<uint8_t>(7 * seed)};
  return c;
}

/// Depth in whole millimetres (exact in every scale used here): base + u mm, pixel (0,0) invalid.
inline DepthImage tiny_depth(double base_m, int w = kW, int h = kH) {
  DepthImage d(w, h);
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) d.at(u, v) = static_cast<float>(base_m + 0.001 * u);
  d.at(0, 0) = 0.0f;
  return d;
}

/// A distinct rigid pose per index.
inline SE3 test_pose(int i) {
  Vec6 xi;
  xi << 0.1 * i, -0.2 + 0.01 * i, 0.3, 0.05 * i, 0.1, -0.3 + 0.02 * i;
  return SE3::exp(xi);
}

inline void write_text(const std::string& path, const std::string& text) {
  std::filesystem::create_directories(std::filesystem::path(path).parent_path());
  std::ofstream(path) << text;
}

/// Keeps only the first `keep` bytes of a file (a truncated download).
inline void truncate_file(const std::string& path, size_t keep) {
  std::filesystem::resize_file(path, keep);
}

inline void write_garbage(const std::string& path) {
  std::ofstream os(path, std::ios::binary);
  for (int i = 0; i < 300; ++i) os.put(static_cast<char>((i * 37 + 11) & 0xff));
}

inline std::string pose_matrix_text(const SE3& T) {
  const Mat4 M = T.matrix();
  std::string s;
  for (int r = 0; r < 4; ++r)
    s += fmt::format("{:.12e} {:.12e} {:.12e} {:.12e}\n", M(r, 0), M(r, 1), M(r, 2), M(r, 3));
  return s;
}

inline std::string tum_line(double t, const SE3& T) {
  const auto q = T.quaternion();
  const Vec3& p = T.translation();
  return fmt::format("{:.6f} {:.9f} {:.9f} {:.9f} {:.9f} {:.9f} {:.9f} {:.9f}\n", t, p.x(), p.y(),
                     p.z(), q.x(), q.y(), q.z(), q.w());
}

/// A 32-bit float depth TIFF (metres), `fill` everywhere except the first values of row 0.
inline void write_float_tiff(const std::string& path, const std::vector<float>& first_row,
                             float fill = 1.0f) {
  cv::Mat m(kH, kW, CV_32F, cv::Scalar(fill));
  for (size_t i = 0; i < first_row.size(); ++i) m.at<float>(0, static_cast<int>(i)) = first_row[i];
  ASSERT_TRUE(cv::imwrite(path, m));
}

/// read_annotations(i) carries the same metadata and ground truth as read(i), without pixels.
inline void expect_annotations_match_frames(const DatasetReader& reader) {
  for (size_t i = 0; i < reader.size(); ++i) {
    const RgbdFrame f = reader.read(i);
    const RgbdFrame a = reader.read_annotations(i);
    EXPECT_TRUE(a.color.empty() && a.depth.empty() && a.labels_gt.empty());
    EXPECT_EQ(a.index, f.index);
    EXPECT_EQ(a.timestamp_s, f.timestamp_s);
    EXPECT_EQ(a.name, f.name);
    EXPECT_EQ(a.intrinsics, f.intrinsics);
    ASSERT_EQ(a.T_world_cam_gt.has_value(), f.T_world_cam_gt.has_value());
    if (a.T_world_cam_gt) {
      EXPECT_EQ(a.T_world_cam_gt->matrix(), f.T_world_cam_gt->matrix());
    }
    ASSERT_EQ(a.objects_gt.size(), f.objects_gt.size());
    for (size_t k = 0; k < a.objects_gt.size(); ++k) {
      EXPECT_EQ(a.objects_gt[k].class_id, f.objects_gt[k].class_id);
      EXPECT_EQ(a.objects_gt[k].instance_id, f.objects_gt[k].instance_id);
      EXPECT_EQ(a.objects_gt[k].visible_fraction, f.objects_gt[k].visible_fraction);
      EXPECT_EQ(a.objects_gt[k].T_cam_obj.matrix(), f.objects_gt[k].T_cam_obj.matrix());
    }
  }
}

/// Expects `fn` to throw IoError whose message contains `needle` (a file name).
template <class Fn>
void expect_io_error_naming(Fn&& fn, const std::string& needle) {
  try {
    fn();
    ADD_FAILURE() << "expected IoError mentioning " << needle;
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
}

}  // namespace orpe::test
