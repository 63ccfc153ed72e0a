#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "orpe/core/error.h"
#include "orpe/semantic/segmenter.h"
#include "semantic/test_scenes.h"
#include "support/test_data.h"

namespace orpe {
namespace {

SegmentationParams exact_params() {
  SegmentationParams p;
  p.gt_degrade = false;
  return p;
}

SegmentationParams boundary_only_params(int shift_px) {
  SegmentationParams p;
  p.gt_miss_rate = 0;
  p.gt_wrong_class_rate = 0;
  p.gt_spurious_per_frame = 0;
  p.gt_boundary_shift_min_px = shift_px;
  p.gt_boundary_shift_max_px = shift_px;
  p.gt_boundary_jitter_px = 0;
  return p;
}

const std::vector<test::Disc> kTwoDiscs = {{3, 30, 40, 60, 20}, {5, 50, 110, 60, 25}};

TEST(GtSegmenter, ExactMasksMatchLabels) {
  const RgbdFrame f = test::frame_with_discs(0, kTwoDiscs);
  GroundTruthSegmenter seg(exact_params(), {});
  const auto dets = seg.detect(f);
  ASSERT_EQ(dets.size(), 2u);
  for (size_t k = 0; k < dets.size(); ++k) {
    EXPECT_EQ(dets[k].class_id, kTwoDiscs[k].class_id);
    EXPECT_EQ(dets[k].source_instance_id, kTwoDiscs[k].instance_id);
    for (size_t i = 0; i < f.labels_gt.size(); ++i)
      ASSERT_EQ(dets[k].probability[i] >= 0.5f, f.labels_gt[i] == static_cast<int>(k) + 1);
    EXPECT_EQ(dets[k].box.u_min,
              static_cast<int>(std::ceil(kTwoDiscs[k].cu - kTwoDiscs[k].radius_px)));
  }
}

TEST(GtSegmenter, ErodedBoundaryIsJustBelowHalfAndBackgroundFarBelow) {
  const RgbdFrame f = test::frame_with_discs(0, {kTwoDiscs[0]});
  const int shift = 3;
  GroundTruthSegmenter seg(boundary_only_params(shift), {});
  const auto dets = seg.detect(f);
  ASSERT_EQ(dets.size(), 1u);
  const auto& p = dets[0].probability;
  int band = 0, core = 0;
  for (int v = 0; v < f.labels_gt.height(); ++v)
    for (int u = 0; u < f.labels_gt.width(); ++u) {
      const double r = std::hypot(u - 40.0, v - 60.0);
      const float pr = p.at(u, v);
      if (f.labels_gt.at(u, v) == 0) {
        ASSERT_LT(pr, 0.35f) << u << "," << v;  // real background: far below 0.5
      } else if (r > 20 - 1.5) {                // outermost object ring: eroded
        ASSERT_GE(pr, 0.4f);
        ASSERT_LT(pr, 0.5f);
        ++band;
      } else if (r < 20 - shift - 1.5) {
        ASSERT_GE(pr, 0.5f);
        ++core;
      }
    }
  EXPECT_GT(band, 50);
  EXPECT_GT(core, 500);
}

TEST(GtSegmenter, DilationAddsBackgroundPixels) {
  const RgbdFrame f = test::frame_with_discs(0, {kTwoDiscs[0]});
  GroundTruthSegmenter seg(boundary_only_params(-2), {});
  const auto dets = seg.detect(f);
  ASSERT_EQ(dets.size(), 1u);
  int gt_area = 0;
  for (auto l : f.labels_gt) gt_area += l > 0;
  EXPECT_GT(mask_area(dets[0].probability, 0.5f), gt_area + 100);
}

TEST(GtSegmenter, DeterministicPerSeedAndFrame) {
  SegmentationParams p;
  p.gt_spurious_per_frame = 2.0;
  p.gt_probability_noise = 0.01;
  GroundTruthSegmenter a(p, {}), b(p, {});
  const RgbdFrame f3 = test::frame_with_discs(3, kTwoDiscs),
                  f4 = test::frame_with_discs(4, kTwoDiscs);
  const auto d1 = a.detect(f3), d2 = b.detect(f3), d3 = a.detect(f3);
  ASSERT_EQ(d1.size(), d2.size());
  ASSERT_EQ(d1.size(), d3.size());
  for (size_t k = 0; k < d1.size(); ++k) {
    EXPECT_EQ(d1[k].class_id, d2[k].class_id);
    EXPECT_EQ(d1[k].score, d2[k].score);
    EXPECT_EQ(d1[k].box, d2[k].box);
    EXPECT_TRUE(
        std::equal(d1[k].probability.begin(), d1[k].probability.end(), d3[k].probability.begin()));
  }
  // Another frame index or seed gives other random choices (compare the summed probability mass).
  auto mass = [](const std::vector<Detection>& ds) {
    double m = 0;
    for (const auto& d : ds)
      for (float v : d.probability) m += v;
    return m;
  };
  const double m3 = mass(d1);
  EXPECT_NE(m3, mass(a.detect(f4)));
  p.seed += 1;
  EXPECT_NE(m3, mass(GroundTruthSegmenter(p, {}).detect(f3)));
}

TEST(GtSegmenter, ErrorRatesAreRoughlyAsConfigured) {
  SegmentationParams p;
  p.gt_miss_rate = 0.2;
  p.gt_wrong_class_rate = 0.1;
  p.gt_spurious_per_frame = 0.5;
  GroundTruthSegmenter seg(p, {1, 2, 3, 4, 5, 6});
  int real = 0, wrong = 0, spurious = 0;
  const int frames = 200;
  for (int i = 0; i < frames; ++i)
    for (const auto& d : seg.detect(test::frame_with_discs(i, kTwoDiscs))) {
      if (d.source_instance_id < 0) {
        ++spurious;
        continue;
      }
      ++real;
      const int truth = d.source_instance_id == 30 ? 3 : 5;
      wrong += d.class_id != truth;
    }
  EXPECT_NEAR(real / (2.0 * frames), 0.8, 0.06);
  EXPECT_NEAR(wrong / static_cast<double>(real), 0.1, 0.05);
  EXPECT_GT(spurious, 0.25 * frames);  // some blobs fall off-image or below the area limit
  EXPECT_LT(spurious, 0.6 * frames);
}

TEST(GtSegmenter, SmallObjectsAreNotDetectedAndMissingLabelsGiveNothing) {
  SegmentationParams p = exact_params();
  p.gt_min_visible_px = 1500;  // between the two discs (1257 and 1963 px)
  EXPECT_TRUE(GroundTruthSegmenter(p, {}).detect(test::frame_with_discs(0, kTwoDiscs)).size() ==
              1u);
  RgbdFrame bare = test::frame_with_discs(0, kTwoDiscs);
  bare.labels_gt = LabelImage();
  EXPECT_TRUE(GroundTruthSegmenter(exact_params(), {}).detect(bare).empty());
}

TEST(FileSegmenter, RoundTripKeepsSoftMasksAndClasses) {
  const std::string dir = test::scratch_dir("det");
  const RgbdFrame f = test::frame_with_discs(12, kTwoDiscs);
  GroundTruthSegmenter gt(boundary_only_params(2), {});
  auto dets = gt.detect(f);
  ASSERT_EQ(dets.size(), 2u);
  dets[1].class_probabilities = {{5, 0.7f}, {2, 0.2f}};
  write_detection_files(dir, f.index, dets);
  SegmentationParams p;
  p.backend = "files";
  p.files_dir = dir;
  const auto seg = make_segmenter(p);
  const auto back = seg->detect(f);
  ASSERT_EQ(back.size(), 2u);
  for (size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(back[k].class_id, dets[k].class_id);
    EXPECT_NEAR(back[k].score, dets[k].score, 1e-6);
    EXPECT_EQ(back[k].box, dets[k].box);
    for (size_t i = 0; i < f.labels_gt.size(); ++i)
      ASSERT_NEAR(back[k].probability[i], dets[k].probability[i], 1.0 / 65535);
  }
  ASSERT_EQ(back[1].class_probabilities.size(), 2u);
  EXPECT_EQ(class_distribution(back[0]).front().first, dets[0].class_id);
  // A frame without a file has no detections.
  EXPECT_TRUE(seg->detect(test::frame_with_discs(13, kTwoDiscs)).empty());
}

TEST(FileSegmenter, BinaryMaskOnlyAndBadFilesNameTheFile) {
  const std::string dir = test::scratch_dir("bad");
  const RgbdFrame f = test::frame_with_discs(1, kTwoDiscs);
  auto dets = GroundTruthSegmenter(exact_params(), {}).detect(f);
  write_detection_files(dir, 1, dets);
  // Rewrite the JSON with masks only: probabilities become 1 / 0.
  std::ofstream(detection_json_path(dir, 1))
      << R"({"detections": [{"class_id": 3, "score": 0.9, "mask": "000001_00_mask.png"}]})";
  const auto back = FileSegmenter::read(dir, 1, 160, 120);
  ASSERT_EQ(back.size(), 1u);
  for (size_t i = 0; i < f.labels_gt.size(); ++i)
    ASSERT_EQ(back[0].probability[i], f.labels_gt[i] == 1 ? 1.0f : 0.0f);

  auto expect_error = [&](const std::string& json, const std::string& needle) {
    std::ofstream(detection_json_path(dir, 2)) << json;
    try {
      FileSegmenter::read(dir, 2, 160, 120);
      FAIL() << json;
    } catch (const IoError& e) {
      EXPECT_NE(std::string(e.what()).find("000002.json"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  expect_error("{not json", "invalid JSON");
  expect_error(R"({"detections": [{"score": 0.9, "mask": "000001_00_mask.png"}]})", "malformed");
  expect_error(R"({"detections": [{"class_id": 2}]})", "needs");
  expect_error(R"({"detections": [{"class_id": 2, "mask": "000001_00_mask.png", "score": 3}]})",
               "score");
  EXPECT_THROW(FileSegmenter::read(dir, 1, 320, 240), IoError);  // size mismatch
  std::ofstream(detection_json_path(dir, 3))
      << R"({"detections": [{"class_id": 2, "mask": "nope.png"}]})";
  try {
    FileSegmenter::read(dir, 3, 160, 120);
    FAIL();
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("nope.png"), std::string::npos) << e.what();
  }
}

TEST(SegmentationParams, ValidationAndFactory) {
  SegmentationParams p;
  std::string why;
  EXPECT_TRUE(p.IsValid(&why)) << why;
  p.backend = "maskrcnn";
  EXPECT_FALSE(p.IsValid(&why));
  EXPECT_THROW(make_segmenter(p), ConfigError);
  p = {};
  p.backend = "files";
  EXPECT_FALSE(p.IsValid(&why));
  p.files_dir = "/nonexistent/orpe";
  EXPECT_THROW(make_segmenter(p), IoError);
  p = {};
  p.gt_boundary_shift_min_px = 3;
  p.gt_boundary_shift_max_px = 1;
  EXPECT_FALSE(p.IsValid(&why));
  p = {};
  p.keyframe_every_n_frames = 0;
  EXPECT_FALSE(p.IsValid(&why));
}

TEST(KeyframeSelector, EveryNthAndByMotion) {
  SegmentationParams p;
  p.keyframe_every_n_frames = 3;
  KeyframeSelector every(p);
  std::vector<int> keys;
  for (int i = 0; i < 10; ++i)
    if (every.is_keyframe(SE3())) keys.push_back(i);
  EXPECT_EQ(keys, (std::vector<int>{0, 3, 6, 9}));

  p.keyframe_every_n_frames = 0;
  p.keyframe_min_translation_m = 0.1;
  p.keyframe_min_rotation_deg = 10;
  KeyframeSelector motion(p);
  keys.clear();
  for (int i = 0; i < 10; ++i) {
    SE3 T(Mat3::Identity(), Vec3(0.04 * i, 0, 0));  // 4 cm per frame
    if (motion.is_keyframe(T)) keys.push_back(i);
  }
  EXPECT_EQ(keys, (std::vector<int>{0, 3, 6, 9}));
  motion.reset();
  EXPECT_TRUE(motion.is_keyframe(SE3()));
  EXPECT_FALSE(motion.is_keyframe(SE3(so3_exp(Vec3(0, 0.1, 0)), Vec3::Zero())));  // 5.7 deg
  EXPECT_TRUE(motion.is_keyframe(SE3(so3_exp(Vec3(0, 0.2, 0)), Vec3::Zero())));   // 11.5 deg
}

}  // namespace
}  // namespace orpe
