// TUM RGB-D and 7-Scenes readers on tiny folders written by the tests, plus the bad-input cases.
#include <gtest/gtest.h>

#include <cmath>

#include "io/dataset_fixtures.h"
#include "orpe/core/error.h"
#include "orpe/io/dataset.h"
#include "orpe/io/dataset_common.h"
#include "support/test_data.h"

namespace orpe {
namespace {
using test::kH;
using test::kW;

/// A TUM folder: 4 colour frames at 0, 1/30, 2/30, 3/30 s; depth 5 ms late (plus one stray depth
/// frame with no colour partner); ground truth near frames 0, 1, 3 but not 2.
std::string make_tum(const std::string& dir, double depth_units_per_m = 5000) {
  std::string rgb = "# colour\n", depth = "# depth\n", gt = "# timestamp tx ty tz qx qy qz qw\n";
  for (int i = 0; i < 4; ++i) {
    const double t = 100.0 + i / 30.0;
    const std::string r = fmt::format("rgb/{:.6f}.png", t),
                      d = fmt::format("depth/{:.6f}.png", t + 0.005);
    write_color_png(dir + "/" + r, test::tiny_color(i));
    write_depth_png(dir + "/" + d, test::tiny_depth(1.0 + 0.1 * i), depth_units_per_m);
    rgb += fmt::format("{:.6f} {}\n", t, r);
    depth += fmt::format("{:.6f} {}\n", t + 0.005, d);
    if (i != 2) gt += test::tum_line(t + 0.004, test::test_pose(i));
  }
  depth += "200.0 depth/stray.png\n";
  test::write_text(dir + "/rgb.txt", rgb);
  test::write_text(dir + "/depth.txt", depth);
  test::write_text(dir + "/groundtruth.txt", gt);
  return dir;
}

TEST(TumReader, PairsFramesDepthScaleAndGroundTruth) {
  const std::string dir = make_tum(test::scratch_dir("tum"));
  EXPECT_EQ(detect_dataset_format(dir), "tum");
  auto reader = open_dataset(dir, DatasetParams{});
  ASSERT_EQ(reader->size(), 4u);
  EXPECT_EQ(reader->info().format, "tum");
  EXPECT_DOUBLE_EQ(reader->info().depth_units_per_m, 5000.0);
  EXPECT_DOUBLE_EQ(reader->info().intrinsics.fx, 525.0);
  EXPECT_DOUBLE_EQ(reader->info().intrinsics.cy, 239.5);
  EXPECT_EQ(reader->info().intrinsics.width, kW);
  EXPECT_EQ(reader->info().intrinsics.height, kH);
  for (size_t i = 0; i < 4; ++i) {
    const RgbdFrame f = reader->read(i);
    EXPECT_NEAR(f.timestamp_s, 100.0 + i / 30.0, 1e-6);
    EXPECT_EQ(f.color.at(3, 2), test::tiny_color(static_cast<int>(i)).at(3, 2));
    EXPECT_NEAR(f.depth.at(5, 1), 1.0 + 0.1 * i + 0.005, 1e-6);
    EXPECT_EQ(f.depth.at(0, 0), 0.0f);
    EXPECT_EQ(f.intrinsics.width, kW);
    ASSERT_EQ(f.T_world_cam_gt.has_value(), i != 2) << i;
    if (f.T_world_cam_gt) {
      EXPECT_LT((f.T_world_cam_gt->matrix() - test::test_pose(static_cast<int>(i)).matrix()).norm(),
                1e-6);
    }
  }
  test::expect_annotations_match_frames(*reader);
  const auto gt = reader->ground_truth_trajectory();
  ASSERT_EQ(gt.size(), 3u);
  EXPECT_NEAR(gt[2].timestamp_s, 100.1, 1e-6);
}

TEST(TumReader, FrameSelectionIntrinsicsOverridesAndMaxDepth) {
  const std::string dir = make_tum(test::scratch_dir("tum"));
  DatasetParams p;
  p.first_frame = 1;
  p.stride = 2;
  p.fx = 600;
  p.cy = 3.5;
  p.max_depth_m = 1.1045;
  auto reader = open_dataset(dir, p);
  ASSERT_EQ(reader->size(), 2u);  // frames 1 and 3
  const RgbdFrame f = reader->read(0);
  EXPECT_EQ(f.index, 1);
  EXPECT_DOUBLE_EQ(f.intrinsics.fx, 600.0);
  EXPECT_DOUBLE_EQ(f.intrinsics.fy, 525.0);
  EXPECT_DOUBLE_EQ(f.intrinsics.cy, 3.5);
  EXPECT_NEAR(f.depth.at(4, 0), 1.104, 1e-6);  // frame 1: 1.1 m + u mm
  EXPECT_EQ(f.depth.at(5, 0), 0.0f);           // 1.105 m > max_depth_m
  EXPECT_EQ(reader->read(1).index, 3);
  p.last_frame = 1;
  EXPECT_EQ(open_dataset(dir, p)->size(), 1u);
  p.first_frame = 9;
  p.last_frame = -1;
  EXPECT_THROW(open_dataset(dir, p), ConfigError);
  p.first_frame = 0;
  p.stride = 0;
  EXPECT_THROW(open_dataset(dir, p), ConfigError);
  p.stride = 1;
  p.depth_units_per_m = -5000;  // a wrong depth scale is refused up front
  EXPECT_THROW(open_dataset(dir, p), ConfigError);
}

// dataset.cut_first / cut_last: a range of frames left out (a kidnapping); frame indices keep the
// layout's numbering, so ground truth and results still match.
TEST(TumReader, ACutRangeOfFramesIsLeftOut) {
  const std::string dir = make_tum(test::scratch_dir("tum"));
  DatasetParams p;
  p.cut_first = 1;
  p.cut_last = 2;
  auto reader = open_dataset(dir, p);
  ASSERT_EQ(reader->size(), 2u);  // frames 0 and 3
  EXPECT_EQ(reader->read(0).index, 0);
  EXPECT_EQ(reader->read(1).index, 3);
  p.cut_first = 0, p.cut_last = 9;  // nothing left
  EXPECT_THROW(open_dataset(dir, p), ConfigError);
  p.cut_first = 2, p.cut_last = 1;  // an empty range is a mistake
  EXPECT_THROW(open_dataset(dir, p), ConfigError);
  p.cut_first = 1, p.cut_last = -1;  // one end only
  EXPECT_THROW(open_dataset(dir, p), ConfigError);
}

TEST(TumReader, AssociationsFileAndDepthScaleOverride) {
  const std::string dir = make_tum(test::scratch_dir("tum"), 1000);
  // Pair colour 0 with depth 1 on purpose: associations.txt must be followed, not nearest times.
  test::write_text(dir + "/associations.txt",
                   "100.000000 rgb/100.000000.png 100.038333 depth/100.038333.png\n"
                   "100.033333 rgb/100.033333.png 100.038333 depth/100.038333.png\n");
  DatasetParams p;
  p.depth_units_per_m = 1000;
  auto reader = open_dataset(dir, p);
  ASSERT_EQ(reader->size(), 2u);
  EXPECT_NEAR(reader->read(0).depth.at(2, 2), 1.1 + 0.002, 1e-6);
  EXPECT_EQ(reader->read(0).color.at(1, 1), test::tiny_color(0).at(1, 1));
}

TEST(TumReader, CameraIntrinsicsFileGivesIntrinsicsNotTheDepthScale) {
  // Issue #17: a camera-intrinsics.txt dropped into a TUM folder used to switch depth to 1000/m.
  const std::string dir = make_tum(test::scratch_dir("tum"));  // depth written at 5000 per metre
  test::write_text(dir + "/camera-intrinsics.txt", "585 0 320\n0 586 240\n0 0 1\n");
  auto reader = open_dataset(dir, DatasetParams{});
  EXPECT_DOUBLE_EQ(reader->info().depth_units_per_m, 5000.0);
  EXPECT_DOUBLE_EQ(reader->info().intrinsics.fy, 586.0);
  EXPECT_NEAR(reader->read(0).depth.at(4, 4), 1.004, 1e-6);
}

/// A 7-Scenes folder of `n` frames (colour png or jpg), 4x4 poses, depth in mm.
std::string make_7scenes(const std::string& dir, int n, bool jpg = false) {
  for (int i = 0; i < n; ++i) {
    const std::string stem = fmt::format("{}/frame-{:06d}", dir, i);
    write_color_png(stem + (jpg ? ".color.jpg" : ".color.png"), test::tiny_color(i));
    write_depth_png(stem + ".depth.png", test::tiny_depth(0.5 + 0.1 * i), 1000);
    test::write_text(stem + ".pose.txt", test::pose_matrix_text(test::test_pose(i)));
  }
  return dir;
}

TEST(SevenScenesReader, ReadsFramesPosesAndPresets) {
  const std::string dir = make_7scenes(test::scratch_dir("7s"), 3, /*jpg=*/true);
  EXPECT_EQ(detect_dataset_format(dir), "7scenes");
  auto reader = open_dataset(dir, DatasetParams{});
  ASSERT_EQ(reader->size(), 3u);
  EXPECT_EQ(reader->info().format, "7scenes");
  EXPECT_DOUBLE_EQ(reader->info().depth_units_per_m, 1000.0);
  EXPECT_DOUBLE_EQ(reader->info().intrinsics.fx, 585.0);
  EXPECT_DOUBLE_EQ(reader->info().intrinsics.cx, 320.0);
  for (size_t i = 0; i < 3; ++i) {
    const RgbdFrame f = reader->read(i);
    EXPECT_EQ(f.index, static_cast<int>(i));
    EXPECT_NEAR(f.timestamp_s, i / 30.0, 1e-9);
    EXPECT_NEAR(f.depth.at(6, 3), 0.5 + 0.1 * i + 0.006, 1e-6);
    ASSERT_TRUE(f.T_world_cam_gt);
    EXPECT_LT((f.T_world_cam_gt->matrix() - test::test_pose(static_cast<int>(i)).matrix()).norm(),
              1e-9);
  }
  EXPECT_EQ(reader->ground_truth_trajectory().size(), 3u);
  test::expect_annotations_match_frames(*reader);
}

TEST(SevenScenesReader, MissingOrNonFinitePoseMeansNoGroundTruth) {
  const std::string dir = make_7scenes(test::scratch_dir("7s"), 3);
  std::filesystem::remove(dir + "/frame-000001.pose.txt");
  test::write_text(dir + "/frame-000002.pose.txt",
                   "-inf -inf -inf -inf\n" + std::string(3, '\n') + "1 0 0 0\n0 1 0 0\n0 0 1 0\n");
  auto reader = open_dataset(dir, DatasetParams{});
  EXPECT_TRUE(reader->read(0).T_world_cam_gt);
  EXPECT_FALSE(reader->read(1).T_world_cam_gt);
  EXPECT_FALSE(reader->read(2).T_world_cam_gt);
  EXPECT_EQ(reader->ground_truth_trajectory().size(), 1u);
  // A pose that is not rigid is an error, not silently accepted.
  test::write_text(dir + "/frame-000001.pose.txt", "2 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n");
  test::expect_io_error_naming([&] { reader->read(1); }, "frame-000001.pose.txt");
  test::write_text(dir + "/frame-000001.pose.txt", "1 0 0 0\n0 1 0\n");
  test::expect_io_error_naming([&] { reader->read(1); }, "frame-000001.pose.txt");
}

TEST(DatasetDetection, UnknownFolderListsWhatWasLookedFor) {
  const std::string dir = test::scratch_dir("empty");
  try {
    detect_dataset_format(dir);
    FAIL();
  } catch (const IoError& e) {
    const std::string msg = e.what();
    for (const char* needle :
         {"rgb.txt", "scene_camera.json", "meta.mat", "frame-NNNNNN.depth.png"})
      EXPECT_NE(msg.find(needle), std::string::npos) << msg;
  }
  EXPECT_THROW(open_dataset(dir + "/nope", DatasetParams{}), IoError);
  DatasetParams p;
  p.format = "tum";
  EXPECT_THROW(open_dataset(dir, p), IoError);
  p.format = "7scenes";
  EXPECT_THROW(open_dataset(dir, p), IoError);
}

// --- Bad input: each case is an IoError naming the file; FrameStream skips and counts the frame.
// ---

class BadFrame : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = make_7scenes(test::scratch_dir("bad"), 4); }
  /// Frame 1 is damaged by `damage`; expects read(1) to throw naming `file`, the others to read,
  /// and FrameStream to skip exactly one frame.
  template <class Damage>
  void expect_bad_frame(Damage&& damage, const std::string& file) {
    damage(dir_ + "/" + file);
    auto reader = open_dataset(dir_, DatasetParams{});
    ASSERT_EQ(reader->size(), 4u);
    test::expect_io_error_naming([&] { reader->read(1); }, file);
    FrameStream stream(*reader);
    RgbdFrame f;
    std::vector<int> got;
    while (stream.next(f)) got.push_back(f.index);
    EXPECT_EQ(got, (std::vector<int>{0, 2, 3}));
    ASSERT_EQ(stream.skipped(), 1u);
    EXPECT_EQ(stream.skipped_frames()[0].first, 1u);
  }
  std::string dir_;
};

TEST_F(BadFrame, MissingColour) {
  expect_bad_frame([](const std::string& p) { std::filesystem::remove(p); },
                   "frame-000001.color.png");
  // Annotations need no pixels: still readable.
  auto reader = open_dataset(dir_, DatasetParams{});
  EXPECT_TRUE(reader->read_annotations(1).T_world_cam_gt);
}
TEST_F(BadFrame, TruncatedDepthPng) {
  expect_bad_frame([](const std::string& p) { test::truncate_file(p, 60); },
                   "frame-000001.depth.png");
}
TEST_F(BadFrame, CorruptColour) {
  expect_bad_frame([](const std::string& p) { test::write_garbage(p); }, "frame-000001.color.png");
}
TEST_F(BadFrame, EmptyDepthFile) {
  expect_bad_frame([](const std::string& p) { test::truncate_file(p, 0); },
                   "frame-000001.depth.png");
}
TEST_F(BadFrame, ColourDepthSizeMismatch) {
  expect_bad_frame(
      [](const std::string& p) { write_depth_png(p, test::tiny_depth(1.0, kW + 2, kH), 1000); },
      "frame-000001.depth.png");
}
TEST_F(BadFrame, EightBitDepth) {
  expect_bad_frame([](const std::string& p) { write_color_png(p, test::tiny_color(1)); },
                   "frame-000001.depth.png");
}
TEST_F(BadFrame, AllDepthInvalid) {
  expect_bad_frame([](const std::string& p) { write_depth_png(p, DepthImage(kW, kH, 0.0f), 1000); },
                   "frame-000001.depth.png");
}

TEST(BadFrameJpeg, TruncatedJpegIsDetected) {
  const std::string dir = make_7scenes(test::scratch_dir("jpg"), 2, /*jpg=*/true);
  const std::string file = dir + "/frame-000001.color.jpg";
  test::truncate_file(file, std::filesystem::file_size(file) - 20);
  auto reader = open_dataset(dir, DatasetParams{});
  test::expect_io_error_naming([&] { reader->read(1); }, "frame-000001.color.jpg");
  EXPECT_NO_THROW(reader->read(0));
}

TEST(FloatDepth, NanAndNegativeBecomeInvalidAllInvalidIsAnError) {
  // A TUM folder whose depth list points at 32-bit float TIFFs in metres.
  const std::string dir = test::scratch_dir("float");
  std::string rgb, depth;
  for (int i = 0; i < 2; ++i) {
    write_color_png(fmt::format("{}/c{}.png", dir, i), test::tiny_color(i));
    rgb += fmt::format("{} c{}.png\n", i, i);
    depth += fmt::format("{} d{}.tiff\n", i, i);
  }
  test::write_text(dir + "/rgb.txt", rgb);
  test::write_text(dir + "/depth.txt", depth);
  test::write_float_tiff(dir + "/d0.tiff", {NAN, -1.0f, 2.5f});
  test::write_float_tiff(dir + "/d1.tiff", {-1.0f, 0.0f}, NAN);
  auto reader = open_dataset(dir, DatasetParams{});
  const RgbdFrame f = reader->read(0);
  EXPECT_EQ(f.depth.at(0, 0), 0.0f);  // NaN
  EXPECT_EQ(f.depth.at(1, 0), 0.0f);  // negative
  EXPECT_FLOAT_EQ(f.depth.at(2, 0), 2.5f);
  for (float z : f.depth) EXPECT_TRUE(std::isfinite(z) && z >= 0.0f);
  test::expect_io_error_naming([&] { reader->read(1); }, "d1.tiff");
}

}  // namespace
}  // namespace orpe

// detail::associate_stamps, the pairing of TUM lists, stamped plain folders and ROS bags.
TEST(StampPairing, ClosestPairsFirstOneToOneInTheOrderOfTheFirstList) {
  using orpe::detail::associate_stamps;
  using Pairs = std::vector<std::pair<size_t, size_t>>;
  // The second colour stamp is closer to the only depth stamp: it wins (colour order would not).
  EXPECT_EQ(associate_stamps({0.000, 0.010}, {0.009}), (Pairs{{1, 0}}));
  // Regular streams pair in order; a depth stamp beyond 0.02 s of every colour stamp is dropped.
  EXPECT_EQ(associate_stamps({0.0, 0.033, 0.066}, {0.001, 0.030, 0.070, 0.5}),
            (Pairs{{0, 0}, {1, 1}, {2, 2}}));
  // Each index at most once; the result sorted by the first list's index even when it is unsorted.
  EXPECT_EQ(associate_stamps({0.066, 0.0}, {0.0, 0.065}), (Pairs{{0, 1}, {1, 0}}));
  EXPECT_EQ(associate_stamps({0.0}, {0.0201}), Pairs{});
  EXPECT_EQ(associate_stamps({0.0}, {0.05}, 0.1), (Pairs{{0, 0}}));
}
