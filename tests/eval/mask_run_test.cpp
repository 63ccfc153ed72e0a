// The mask files of a run (index.json + label PNGs) and their evaluation against a dataset's
// ground truth, with an in-memory dataset.
#include "orpe/eval/mask_run.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "orpe/core/error.h"
#include "orpe/io/dataset.h"
#include "orpe/io/image_io.h"
#include "support/in_memory_reader.h"
#include "support/test_data.h"

namespace orpe {
namespace {

void paint(LabelImage& img, int u0, int v0, int u1, int v1, std::int32_t value) {
  for (int v = v0; v < v1; ++v)
    for (int u = u0; u < u1; ++u) img.at(u, v) = value;
}

/// Frames with ground-truth labels only (numbered 10, 11, ...), classes "one" and "two".
test::InMemoryReader labelled_reader(std::vector<RgbdFrame> frames) {
  DatasetInfo info;
  info.format = "fake";
  info.root = "fake-dataset";
  info.class_names = {{1, "one"}, {2, "two"}};
  return test::InMemoryReader(std::move(info), std::move(frames));
}

/// Two frames of 30x20: object A (instance 100, class 1) at [0,10)x[0,10), object B (instance 200,
/// class 2) at [15,25)x[0,10) in frame 10 only.
std::vector<RgbdFrame> two_frames() {
  std::vector<RgbdFrame> frames(2);
  for (int k = 0; k < 2; ++k) {
    RgbdFrame& f = frames[k];
    f.index = 10 + k;
    f.name = "frame" + std::to_string(f.index);
    f.labels_gt = LabelImage(30, 20, 0);
    ObjectGroundTruth a;
    a.class_id = 1;
    a.instance_id = 100;
    f.objects_gt.push_back(a);
    paint(f.labels_gt, 0, 0, 10, 10, 1);
    if (k == 0) {
      ObjectGroundTruth b;
      b.class_id = 2;
      b.instance_id = 200;
      f.objects_gt.push_back(b);
      paint(f.labels_gt, 15, 0, 25, 10, 2);
    }
  }
  return frames;
}

/// Writes a run's masks: frame 10 input = A's top half (class 1) + B exactly (class 2); projected
/// = instance 7 on all of A, instance 9 on a background blob. Frame 11: input misses A, projected
/// instance 7 covers A's left 8 columns.
MaskRunIndex write_run(const std::string& dir) {
  MaskRunIndex index;
  index.dataset_path = "fake-dataset";
  index.dataset_format = "fake";
  index.dataset_scene = "0001";
  LabelImage in10(30, 20, 0), pr10(30, 20, 0), in11(30, 20, 0), pr11(30, 20, 0);
  paint(in10, 0, 0, 10, 5, 1);
  paint(in10, 15, 0, 25, 10, 2);
  paint(pr10, 0, 0, 10, 10, 7);
  paint(pr10, 0, 15, 5, 20, 9);
  paint(pr11, 0, 0, 8, 10, 7);
  const std::vector<std::pair<int, std::pair<LabelImage, LabelImage>>> frames = {
      {10, {in10, pr10}}, {11, {in11, pr11}}};
  for (const auto& [n, images] : frames) {
    MaskRunFrame f;
    f.frame_index = n;
    f.name = "frame" + std::to_string(n);
    f.input.file = std::to_string(n) + "_input.png";
    f.projected.file = std::to_string(n) + "_projected.png";
    if (n == 10) f.input.classes = {{1, 1}, {2, 2}};
    f.projected.classes = {{7, 1}, {9, 2}};
    write_label_png(dir + "/" + f.input.file, images.first);
    write_label_png(dir + "/" + f.projected.file, images.second);
    index.frames.push_back(f);
  }
  write_mask_run_index(dir + "/index.json", index);
  return index;
}

TEST(MaskRun, IndexRoundTripsAndBadIndexNamesTheFile) {
  const std::string dir = test::scratch_dir("mask_run_index");
  const MaskRunIndex written = write_run(dir);
  const MaskRunIndex read = read_mask_run_index(dir + "/index.json");
  EXPECT_EQ(read.dataset_scene, "0001");
  EXPECT_EQ(read.dataset_format, "fake");
  ASSERT_EQ(read.frames.size(), 2u);
  EXPECT_EQ(read.frames[0].frame_index, 10);
  EXPECT_EQ(read.frames[0].input.classes, written.frames[0].input.classes);
  EXPECT_EQ(read.frames[1].projected.classes, written.frames[1].projected.classes);
  EXPECT_EQ(read.frames[1].projected.file, "11_projected.png");

  auto expect_io_error = [](const std::string& path, const std::string& text) {
    { std::ofstream(path) << text; }
    try {
      read_mask_run_index(path);
      ADD_FAILURE() << "no error for " << text;
    } catch (const IoError& e) {
      EXPECT_EQ(e.path(), path);
    }
  };
  expect_io_error(dir + "/bad1.json", "{not json");
  expect_io_error(dir + "/bad2.json", R"({"format": "something-else"})");
  expect_io_error(dir + "/bad3.json",
                  R"({"format": "orpe-masks-1", "dataset": {"path": "", "format": "", "scene": ""},
                      "mask_threshold": 0.5, "frames": [{"frame": 1, "input": {"file": "a.png",
                      "classes": {"x": 1}}, "projected": {"file": "b.png", "classes": {}}}]})");
  EXPECT_THROW(read_mask_run_index(dir + "/missing.json"), IoError);
}

TEST(MaskRun, EvaluatesInputAndProjectedMasksAgainstTheGroundTruth) {
  const std::string dir = test::scratch_dir("mask_run_eval");
  const MaskRunIndex index = write_run(dir);
  const test::InMemoryReader reader = labelled_reader(two_frames());
  const std::map<int, int> final_classes = {{7, 1}, {9, 2}, {12, 1}};
  const MaskRunEvaluation ev = evaluate_mask_run(reader, dir, index, {}, &final_classes);

  // Input: A 0.5 (frame 10) + missed (frame 11); B 1.0.
  EXPECT_EQ(ev.input.frames, 2u);
  EXPECT_EQ(ev.input.all.gt_instances, 3u);
  EXPECT_EQ(ev.input.all.matched, 2u);
  EXPECT_DOUBLE_EQ(ev.input.all.mean_instance_iou, 1.5 / 3);
  EXPECT_DOUBLE_EQ(ev.input.all.mean_matched_iou, 1.5 / 2);
  ASSERT_EQ(ev.input.classes.size(), 2u);
  EXPECT_EQ(ev.input.classes[0].name, "one");
  EXPECT_DOUBLE_EQ(ev.input.classes[0].mean_instance_iou, 0.25);
  EXPECT_DOUBLE_EQ(ev.input.classes[0].mean_matched_iou, 0.5);
  // Projected: A 1.0 and 0.8; B missed; the blob (class 2) is a false positive in frame 10.
  EXPECT_DOUBLE_EQ(ev.projected.classes[0].mean_instance_iou, 0.9);
  EXPECT_DOUBLE_EQ(ev.projected.classes[1].mean_instance_iou, 0.0);
  EXPECT_DOUBLE_EQ(ev.projected.all.mean_instance_iou, 1.8 / 3);
  EXPECT_DOUBLE_EQ(ev.projected.all.mean_matched_iou, 0.9);
  EXPECT_EQ(ev.projected.false_positive_instances, 1u);

  // Instance checks: 7 owned by A, 9 lies on background (spurious), 12 never projected; B owns
  // none.
  ASSERT_EQ(ev.instances.size(), 1u);
  const MaskInstanceChecks& c = ev.instances[0].second;
  ASSERT_EQ(c.objects.size(), 2u);
  EXPECT_EQ(c.objects[0].object_instance_id, 100);
  EXPECT_EQ(c.objects[0].instances, std::vector<int>{7});
  EXPECT_EQ(c.objects[0].argmax_class, 1);
  EXPECT_TRUE(c.objects[1].instances.empty());
  EXPECT_EQ(c.spurious_instances, std::vector<int>{9});
  EXPECT_EQ(c.unseen_instances, std::vector<int>{12});
  EXPECT_EQ(ev.objects_with_exactly_one_instance(), 1);
  EXPECT_EQ(ev.objects_with_correct_class(), 1);
  EXPECT_EQ(ev.spurious_instances(), 1);
  EXPECT_NE(ev.report().find("one"), std::string::npos);
  const auto j = nlohmann::json::parse(ev.to_json());
  EXPECT_DOUBLE_EQ(j["projected"]["all"]["mean_matched_iou"].get<double>(), 0.9);
  EXPECT_EQ(j["instances"]["spurious_instances"].get<int>(), 1);

  // Pooling the same run twice doubles the counts and keeps the means.
  MaskRunEvaluator pooled;
  pooled.add_run(reader, dir, index, &final_classes, "a");
  pooled.add_run(reader, dir, index, nullptr, "b");
  const MaskRunEvaluation p = pooled.result();
  EXPECT_EQ(p.input.all.gt_instances, 6u);
  EXPECT_DOUBLE_EQ(p.projected.all.mean_instance_iou, 1.8 / 3);
  EXPECT_EQ(p.instances.size(), 1u);  // run "b" had no instance table
}

TEST(MaskRun, OwnershipFindsSplitObjectsWrongClassesAndBreaksTiesByObjectId) {
  MaskInstanceOwnership own;
  LabelImage gt(20, 10, 0), proj(20, 10, 0);
  paint(gt, 0, 0, 10, 10, 1);    // object 5
  paint(gt, 10, 0, 20, 10, 2);   // object 6
  paint(proj, 0, 0, 5, 10, 1);   // instance 1: on object 5 (50 px)
  paint(proj, 5, 0, 8, 10, 2);   // instance 2: also on object 5 (30 px; a split object)
  paint(proj, 8, 5, 12, 10, 4);  // instance 4: 10 px on each object: the lower object id owns it
  paint(proj, 10, 0, 20, 5, 3);  // instance 3: the top half of object 6
  own.add_frame(gt, {{1, 5}, {2, 6}}, {{1, 1}, {2, 2}}, proj);
  const auto r = own.result({{1, 1}, {2, 1}, {3, 1}, {4, 2}});
  ASSERT_EQ(r.objects.size(), 2u);
  EXPECT_EQ(r.objects[0].instances, (std::vector<int>{1, 2, 4}));  // most overlapping first
  EXPECT_EQ(r.objects[1].instances, std::vector<int>{3});
  EXPECT_EQ(r.objects[1].argmax_class, 1);  // wrong class for object 6 (class 2)
  EXPECT_EQ(r.objects_with_exactly_one_instance, 1);
  EXPECT_EQ(r.objects_with_correct_class, 0);
  EXPECT_TRUE(r.spurious_instances.empty());
}

TEST(MaskRun, BadFilesGiveIoErrorsNamingThem) {
  const std::string dir = test::scratch_dir("mask_run_bad");
  MaskRunIndex index = write_run(dir);
  const test::InMemoryReader reader = labelled_reader(two_frames());
  auto expect_error_on = [&](const MaskRunIndex& idx, const std::string& path_part) {
    try {
      evaluate_mask_run(reader, dir, idx, {});
      ADD_FAILURE() << "no error, expected one naming " << path_part;
    } catch (const IoError& e) {
      EXPECT_NE(e.path().find(path_part), std::string::npos) << e.what();
    }
  };
  // A missing image.
  MaskRunIndex missing = index;
  missing.frames[1].input.file = "nope.png";
  expect_error_on(missing, "nope.png");
  // A label value without a class.
  MaskRunIndex no_class = index;
  no_class.frames[0].projected.classes.erase(9);
  expect_error_on(no_class, "10_projected.png");
  // An image of the wrong size.
  write_label_png(dir + "/small.png", LabelImage(10, 10, 0));
  MaskRunIndex small = index;
  small.frames[0].input.file = "small.png";
  expect_error_on(small, "small.png");
  // A frame the dataset does not have.
  MaskRunIndex other = index;
  other.frames[0].frame_index = 99;
  expect_error_on(other, "index.json");
  // An empty index.
  MaskRunIndex empty = index;
  empty.frames.clear();
  expect_error_on(empty, "index.json");
}

}  // namespace
}  // namespace orpe
