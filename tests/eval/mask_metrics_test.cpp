#include "orpe/eval/mask_metrics.h"

#include <gtest/gtest.h>

#include <stdexcept>

#include "orpe/core/error.h"

namespace orpe {
namespace {

/// Sets label `value` on the rectangle [u0, u1) x [v0, v1).
void paint(LabelImage& img, int u0, int v0, int u1, int v1, std::int32_t value) {
  for (int v = v0; v < v1; ++v)
    for (int u = u0; u < u1; ++u) img.at(u, v) = value;
}

TEST(MaskMetrics, RectanglesGiveHandComputedIoU) {
  LabelImage gt(40, 30, 0), pred(40, 30, 0);
  paint(gt, 0, 0, 10, 10, 1);    // instance 1, class 4: 100 px
  paint(gt, 20, 0, 30, 10, 2);   // instance 2, class 6: 100 px
  paint(pred, 5, 0, 15, 10, 7);  // class 4, overlaps instance 1 by 50 px: IoU 50/150
  paint(pred, 20, 0, 30, 5, 8);  // class 6, inside instance 2: IoU 50/100
  paint(pred, 0, 20, 5, 30, 9);  // class 6, overlapping nothing: a false positive
  const LabelClasses gt_classes{{1, 4}, {2, 6}}, pred_classes{{7, 4}, {8, 6}, {9, 6}};
  const auto r = evaluate_instance_masks(gt, gt_classes, pred, pred_classes);
  ASSERT_EQ(r.instances.size(), 2u);
  EXPECT_EQ(r.instances[0].pred_label, 7);
  EXPECT_DOUBLE_EQ(r.instances[0].iou, 50.0 / 150.0);
  EXPECT_EQ(r.instances[0].gt_pixels, 100u);
  EXPECT_EQ(r.instances[1].pred_label, 8);
  EXPECT_DOUBLE_EQ(r.instances[1].iou, 0.5);
  EXPECT_EQ(r.false_positive_instances, 1u);
  EXPECT_DOUBLE_EQ(r.mean_iou, 0.5 * (1.0 / 3.0 + 0.5));
  // Pixels: class 4 TP 50, FP 50, FN 50; class 6 TP 50, FP 50 (the stray 5x10), FN 50.
  EXPECT_EQ(r.class_pixels.at(4).true_positive, 50u);
  EXPECT_EQ(r.class_pixels.at(4).false_positive, 50u);
  EXPECT_EQ(r.class_pixels.at(4).false_negative, 50u);
  EXPECT_EQ(r.class_pixels.at(6).false_positive, 50u);
  EXPECT_DOUBLE_EQ(r.class_pixels.at(6).iou(), 50.0 / 150.0);
}

TEST(MaskMetrics, WrongClassDoesNotMatchAndBestOverlapWins) {
  LabelImage gt(20, 20, 0), pred(20, 20, 0);
  paint(gt, 0, 0, 10, 10, 1);
  paint(pred, 0, 0, 10, 10, 1);  // perfect shape but class 2
  auto r = evaluate_instance_masks(gt, {{1, 1}}, pred, {{1, 2}});
  EXPECT_EQ(r.instances[0].pred_label, 0);
  EXPECT_EQ(r.instances[0].iou, 0.0);
  EXPECT_EQ(r.false_positive_instances, 1u);
  EXPECT_EQ(r.class_pixels.at(1).false_negative, 100u);
  EXPECT_EQ(r.class_pixels.at(2).false_positive, 100u);

  // Two predictions of the right class: the larger overlap matches, the other is a false positive.
  LabelImage pred2(20, 20, 0);
  paint(pred2, 0, 0, 10, 3, 5);   // IoU 0.3
  paint(pred2, 0, 3, 10, 10, 6);  // IoU 0.7
  r = evaluate_instance_masks(gt, {{1, 1}}, pred2, {{5, 1}, {6, 1}});
  EXPECT_EQ(r.instances[0].pred_label, 6);
  EXPECT_DOUBLE_EQ(r.instances[0].iou, 0.7);
  EXPECT_EQ(r.false_positive_instances, 1u);
  // ...but the pixel IoU of the class counts both: all 100 pixels are right.
  EXPECT_DOUBLE_EQ(r.class_pixels.at(1).iou(), 1.0);

  // A matching threshold turns the weak match into a miss.
  MaskMetricsParams strict;
  strict.min_match_iou = 0.8;
  r = evaluate_instance_masks(gt, {{1, 1}}, pred2, {{5, 1}, {6, 1}}, strict);
  EXPECT_EQ(r.instances[0].pred_label, 0);
  EXPECT_EQ(r.false_positive_instances, 2u);
}

TEST(MaskMetrics, RelabelledPerfectPredictionScoresOne) {
  LabelImage gt(16, 16, 0), pred(16, 16, 0);
  paint(gt, 0, 0, 8, 8, 1);
  paint(gt, 8, 8, 16, 16, 2);
  paint(pred, 0, 0, 8, 8, 20);
  paint(pred, 8, 8, 16, 16, 10);
  const auto r = evaluate_instance_masks(gt, {{1, 3}, {2, 3}}, pred, {{10, 3}, {20, 3}});
  EXPECT_DOUBLE_EQ(r.mean_iou, 1.0);
  EXPECT_EQ(r.instances[0].pred_label, 20);
  EXPECT_EQ(r.instances[1].pred_label, 10);
  EXPECT_EQ(r.false_positive_instances, 0u);
}

TEST(MaskMetrics, BadInputIsRejected) {
  LabelImage gt(10, 10, 0), pred(10, 12, 0), pred_ok(10, 10, 0);
  EXPECT_THROW(evaluate_instance_masks(gt, {}, pred, {}), std::invalid_argument);
  paint(gt, 0, 0, 2, 2, 3);
  EXPECT_THROW(evaluate_instance_masks(gt, {}, pred_ok, {}), std::invalid_argument);  // no class
  MaskMetricsParams bad;
  bad.min_match_iou = 1.0;
  EXPECT_THROW(MaskEvaluator{bad}, ConfigError);
  // Empty frames are fine and score 0 instances.
  const auto r = evaluate_instance_masks(LabelImage(4, 4, 0), {}, LabelImage(4, 4, 0), {});
  EXPECT_TRUE(r.instances.empty());
  EXPECT_EQ(r.mean_iou, 0.0);
}

TEST(MaskMetrics, EvaluatorPoolsFramesPerClass) {
  MaskEvaluator ev;
  LabelImage gt1(20, 10, 0), pred1(20, 10, 0), gt2(20, 10, 0), pred2(20, 10, 0);
  paint(gt1, 0, 0, 10, 10, 1);   // class 1, 100 px
  paint(pred1, 0, 0, 10, 5, 1);  // IoU 0.5
  paint(gt2, 0, 0, 10, 10, 1);   // class 1 again, missed
  paint(gt2, 10, 0, 20, 10, 2);  // class 2, perfect
  paint(pred2, 10, 0, 20, 10, 4);
  ev.add_frame(gt1, {{1, 1}}, pred1, {{1, 1}});
  ev.add_frame(gt2, {{1, 1}, {2, 2}}, pred2, {{4, 2}});
  const auto s = ev.summary({{1, "one"}});
  EXPECT_EQ(s.frames, 2u);
  ASSERT_EQ(s.classes.size(), 2u);
  EXPECT_EQ(s.classes[0].name, "one");
  EXPECT_EQ(s.classes[1].name, "class_2");
  EXPECT_EQ(s.classes[0].gt_instances, 2u);
  EXPECT_EQ(s.classes[0].matched, 1u);
  EXPECT_DOUBLE_EQ(s.classes[0].mean_instance_iou, 0.25);
  EXPECT_DOUBLE_EQ(s.classes[0].pixel_iou, 50.0 / 200.0);  // TP 50, FN 150
  EXPECT_DOUBLE_EQ(s.classes[1].pixel_iou, 1.0);
  EXPECT_EQ(s.all.gt_instances, 3u);
  EXPECT_DOUBLE_EQ(s.all.mean_instance_iou, 1.5 / 3.0);
  EXPECT_DOUBLE_EQ(s.all.pixel_iou, 150.0 / 300.0);
  EXPECT_DOUBLE_EQ(s.mean_class_pixel_iou, 0.5 * (0.25 + 1.0));
  ASSERT_EQ(s.frame_mean_iou.size(), 2u);
  EXPECT_DOUBLE_EQ(s.frame_mean_iou[0], 0.5);
  EXPECT_DOUBLE_EQ(s.frame_mean_iou[1], 0.5);
  EXPECT_NE(s.report().find("one"), std::string::npos);
  EXPECT_NE(s.to_json().find("\"mean_class_pixel_iou\""), std::string::npos);
}

}  // namespace
}  // namespace orpe
