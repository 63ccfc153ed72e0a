#include "orpe/eval/mask_metrics.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <vector>

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
  // Matched-only means: class 1 has one matched instance (0.5), class 2 one (1.0).
  EXPECT_DOUBLE_EQ(s.classes[0].mean_matched_iou, 0.5);
  EXPECT_DOUBLE_EQ(s.classes[1].mean_matched_iou, 1.0);
  EXPECT_EQ(s.all.matched, 2u);
  EXPECT_DOUBLE_EQ(s.all.mean_matched_iou, 1.5 / 2.0);
  EXPECT_NE(s.report().find("one"), std::string::npos);
  EXPECT_NE(s.to_json().find("\"mean_class_pixel_iou\""), std::string::npos);
}

TEST(MaskMetrics, PerClassAggregationOverManyFramesMatchesAHandTally) {
  // Three classes over three frames; each gt instance a 10x10 square, predictions cover a known
  // number of its rows (IoU = rows / 10) or miss it. The per-class means (misses 0 / matched only)
  // and the overall ones are tallied by hand from the same table.
  struct Obs {
    int frame, cls, rows;  // rows = 0: missed
  };
  const std::vector<Obs> table = {{0, 1, 10}, {0, 2, 5}, {0, 3, 0}, {1, 1, 8},
                                  {1, 2, 0},  {1, 3, 4}, {2, 1, 0}, {2, 3, 6}};
  MaskEvaluator ev;
  for (int f = 0; f < 3; ++f) {
    LabelImage gt(40, 10, 0), pred(40, 10, 0);
    LabelClasses gt_classes, pred_classes;
    for (const Obs& o : table) {
      if (o.frame != f) continue;
      const int u0 = 10 * (o.cls - 1);
      paint(gt, u0, 0, u0 + 10, 10, o.cls);
      gt_classes[o.cls] = o.cls;
      if (o.rows > 0) {
        paint(pred, u0, 0, u0 + 10, o.rows, 10 + o.cls);
        pred_classes[10 + o.cls] = o.cls;
      }
    }
    ev.add_frame(gt, gt_classes, pred, pred_classes);
  }
  const MaskEvaluation s = ev.summary();
  ASSERT_EQ(s.classes.size(), 3u);
  double all_sum = 0;
  int all_n = 0, all_matched = 0;
  for (int c = 1; c <= 3; ++c) {
    double sum = 0;
    int n = 0, matched = 0;
    for (const Obs& o : table)
      if (o.cls == c) {
        sum += o.rows / 10.0;
        ++n;
        matched += o.rows > 0;
      }
    const MaskClassSummary& cs = s.classes[c - 1];
    EXPECT_EQ(cs.class_id, c);
    EXPECT_EQ(cs.gt_instances, static_cast<size_t>(n));
    EXPECT_EQ(cs.matched, static_cast<size_t>(matched));
    EXPECT_NEAR(cs.mean_instance_iou, sum / n, 1e-12) << c;
    EXPECT_NEAR(cs.mean_matched_iou, sum / matched, 1e-12) << c;
    all_sum += sum;
    all_n += n;
    all_matched += matched;
  }
  EXPECT_NEAR(s.all.mean_instance_iou, all_sum / all_n, 1e-12);
  EXPECT_NEAR(s.all.mean_matched_iou, all_sum / all_matched, 1e-12);
  EXPECT_GT(s.all.mean_matched_iou, s.all.mean_instance_iou);  // there are misses
  // The JSON carries both means.
  EXPECT_NE(s.to_json().find("\"mean_matched_iou\""), std::string::npos);
}

TEST(MaskMetrics, ClassAgnosticMatchingScoresTheMaskWhateverItsClass) {
  LabelImage gt(20, 20, 0), pred(20, 20, 0);
  paint(gt, 0, 0, 10, 10, 1);   // class 3
  paint(pred, 0, 0, 10, 5, 7);  // class 4: half the object
  MaskMetricsParams agnostic;
  agnostic.class_agnostic_matching = true;
  const auto same = evaluate_instance_masks(gt, {{1, 3}}, pred, {{7, 4}});
  const auto any = evaluate_instance_masks(gt, {{1, 3}}, pred, {{7, 4}}, agnostic);
  EXPECT_EQ(same.instances[0].pred_label, 0);
  EXPECT_EQ(same.false_positive_instances, 1u);
  ASSERT_EQ(any.instances.size(), 1u);
  EXPECT_EQ(any.instances[0].pred_label, 7);
  EXPECT_EQ(any.instances[0].class_id, 3);  // the row keeps the ground-truth class
  EXPECT_DOUBLE_EQ(any.instances[0].iou, 0.5);
  EXPECT_EQ(any.false_positive_instances, 0u);
  // Pixel IoU stays per class: class 3 has no true positive either way.
  EXPECT_EQ(any.class_pixels.at(3).true_positive, 0u);
}

TEST(MaskMetrics, TinyGroundTruthObjectsAreNotScored) {
  LabelImage gt(30, 10, 0), pred(30, 10, 0);
  paint(gt, 0, 0, 10, 10, 1);   // 100 px
  paint(gt, 20, 0, 23, 3, 2);   // 9 px
  paint(pred, 20, 0, 23, 3, 5);  // a perfect mask of the tiny object
  MaskMetricsParams p;
  p.min_gt_area_px = 10;
  const auto r = evaluate_instance_masks(gt, {{1, 1}, {2, 1}}, pred, {{5, 1}}, p);
  ASSERT_EQ(r.instances.size(), 1u);  // only the large object, missed
  EXPECT_EQ(r.instances[0].gt_label, 1);
  EXPECT_EQ(r.instances[0].iou, 0.0);
  EXPECT_EQ(r.false_positive_instances, 0u);  // matched to the unscored object: not a false positive
  const auto all = evaluate_instance_masks(gt, {{1, 1}, {2, 1}}, pred, {{5, 1}});
  EXPECT_EQ(all.instances.size(), 2u);
  MaskMetricsParams bad;
  bad.min_gt_area_px = -1;
  EXPECT_FALSE(bad.IsValid(nullptr));
}

}  // namespace
}  // namespace orpe
