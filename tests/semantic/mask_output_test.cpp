// The per-frame mask output of a run (MaskRecorder, `orpe run --write-masks`) and its evaluation
// (`orpe eval masks`), end to end on a small synthetic scene (orpe synth's generator, BOP layout).
#include "orpe/semantic/mask_output.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "orpe/eval/mask_run.h"
#include "orpe/io/dataset.h"
#include "orpe/io/image_io.h"
#include "orpe/io/point_cloud_io.h"
#include "orpe/semantic/mask_eval.h"
#include "orpe/synth/generator.h"
#include "support/test_data.h"

namespace orpe {
namespace {

Detection disc_detection(int cls, int W, int H, double cu, double cv, double r, float p_in) {
  Detection d;
  d.class_id = cls;
  d.score = 0.9f;
  d.probability = ProbabilityImage(W, H, 0.0f);
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u)
      if (std::hypot(u - cu, v - cv) <= r) d.probability.at(u, v) = p_in;
  return d;
}

TEST(MaskOutput, DetectionLabelImageTakesTheMostProbableDetectionAboveThreshold) {
  const int W = 40, H = 20;
  std::vector<Detection> dets = {disc_detection(3, W, H, 10, 10, 6, 0.7f),
                                 disc_detection(5, W, H, 14, 10, 6, 0.9f),   // wins the overlap
                                 disc_detection(6, W, H, 30, 10, 4, 0.4f),   // below threshold
                                 disc_detection(8, W, H, 10, 10, 6, 0.7f)};  // ties with the first
  dets.push_back(Detection{});  // no mask of the frame's size: listed, never drawn
  dets.back().class_id = 9;
  LabelClasses classes;
  const LabelImage labels = detection_label_image(dets, W, H, 0.5f, &classes);
  EXPECT_EQ(classes, (LabelClasses{{1, 3}, {2, 5}, {3, 6}, {4, 8}, {5, 9}}));
  EXPECT_EQ(labels.at(5, 10), 1);   // only the first (and its tie, which loses)
  EXPECT_EQ(labels.at(12, 10), 2);  // the overlap: the more probable one
  EXPECT_EQ(labels.at(30, 10), 0);  // 0.4 < 0.5
  EXPECT_EQ(labels.at(39, 0), 0);
  for (const auto v : labels) EXPECT_NE(v, 4);
}

int run_cli(const std::string& args) {
  const std::string cmd = std::string("OMP_WAIT_POLICY=passive ") + ORPE_CLI_PATH + " -q " + args;
  return std::system(cmd.c_str());
}

nlohmann::json read_json(const std::string& path) {
  std::ifstream is(path);
  EXPECT_TRUE(is.good()) << path;
  return nlohmann::json::parse(is);
}

/// A small synthetic BOP scene (written once per process).
const std::string& synthetic_scene() {
  static const std::string dir = [] {
    const std::string parent = test::process_scratch_dir("mask_output_scene");
    SynthParams p;
    p.seed = 5;
    p.frames = 10;
    p.objects = 4;
    p.width = 320;
    p.height = 240;
    p.span_deg = 25;
    p.noise = true;
    p.model_points = 500;
    p.preview_stride = 0;
    p.threads = 1;
    const std::string d = parent + "/000000";
    synth::SyntheticSceneGenerator(p).write_bop(d);
    return d;
  }();
  return dir;
}

/// Class-agnostic projected IoU of every scored object, computed here from the written files with
/// the semantic stage's own matcher (match_by_iou): an independent check of the evaluator.
std::vector<double> projected_iou_by_hand(const std::string& scene, const std::string& run,
                                          int min_area_px) {
  const MaskRunIndex index = read_mask_run_index(run + "/masks/index.json");
  const auto reader = open_dataset(scene, DatasetParams{});
  std::vector<double> out;
  for (const auto& f : index.frames) {
    RgbdFrame frame;
    for (size_t i = 0; i < reader->size(); ++i)
      if (reader->read_annotations(i).index == f.frame_index) frame = reader->read(i);
    const LabelImage proj = read_label_image(run + "/masks/" + f.projected.file);
    const int n = static_cast<int>(frame.objects_gt.size());
    std::map<int, int> column;
    std::vector<long> gt_area(n, 0), col_area;
    std::vector<std::vector<long>> inter(n);
    for (size_t k = 0; k < proj.size(); ++k) {
      const int g = frame.labels_gt[k];
      if (g > 0) ++gt_area[g - 1];
      if (proj[k] <= 0) continue;
      auto [it, added] = column.try_emplace(proj[k], static_cast<int>(col_area.size()));
      if (added) {
        col_area.push_back(0);
        for (auto& row : inter) row.push_back(0);
      }
      ++col_area[it->second];
      if (g > 0) ++inter[g - 1][it->second];
    }
    std::vector<double> iou;
    match_by_iou(inter, gt_area, col_area, &iou);
    for (int g = 0; g < n; ++g)
      if (gt_area[g] > 0 && gt_area[g] >= min_area_px) out.push_back(iou[g]);
  }
  return out;
}

TEST(MaskOutput, RunWritesMasksAndEvalMasksScoresThem) {
  const std::string scene = synthetic_scene();
  const std::string root = test::scratch_dir("runs");
  const std::string exact = root + "/exact", degraded = root + "/degraded";
  ASSERT_EQ(run_cli("run --dataset " + scene + " --out " + exact +
                    " --mode semantic --write-masks --set segmentation.gt_degrade=false"),
            0);
  ASSERT_EQ(run_cli("run --dataset " + scene + " --out " + degraded +
                    " --mode semantic --write-masks --set segmentation.gt_spurious_per_frame=0"),
            0);
  const MaskRunIndex index = read_mask_run_index(exact + "/masks/index.json");
  EXPECT_EQ(index.frames.size(), 10u);  // every frame a keyframe by default
  EXPECT_EQ(index.dataset_format, "bop");
  EXPECT_EQ(index.dataset_scene, "000000");
  int labelled = 0;  // pixels with a label, over every colour image
  for (const auto& f : index.frames) {
    EXPECT_TRUE(std::filesystem::is_regular_file(exact + "/masks/" + f.input.file));
    EXPECT_TRUE(std::filesystem::is_regular_file(exact + "/masks/" + f.projected.file));
    // Beside each 16-bit label PNG a viewable colour copy: the projected one by instance id, the
    // input one by class.
    for (const auto* m : {&f.projected, &f.input}) {
      const LabelImage labels = read_label_image(exact + "/masks/" + m->file);
      const ColorImage colour = read_color_image(exact + "/masks/" + color_file_name(m->file));
      ASSERT_EQ(colour.width(), labels.width());
      ASSERT_EQ(colour.height(), labels.height());
      for (size_t k = 0; k < labels.size(); ++k) {
        const int value =
            labels[k] > 0 ? (m == &f.input ? m->classes.at(labels[k]) : labels[k]) : 0;
        ASSERT_EQ(colour[k], value > 0 ? label_color(value) : Rgb8{}) << m->file << " pixel " << k;
        labelled += value > 0;
      }
    }
  }
  EXPECT_GT(labelled, 1000);

  // Exact detections (objects under the segmenter's 100 px minimum are never detected, so they are
  // not scored): every input mask is its object's ground truth.
  const std::string common = " --dataset " + scene + " --min-gt-area 100 --class-agnostic";
  ASSERT_EQ(run_cli("eval masks --run " + exact + common + " --json " + exact +
                    "/masks.json > /dev/null"),
            0);
  const auto je = read_json(exact + "/masks.json");
  EXPECT_GT(je["input"]["all"]["gt_instances"].get<int>(), 20);
  EXPECT_DOUBLE_EQ(je["input"]["all"]["mean_instance_iou"].get<double>(), 1.0);
  EXPECT_DOUBLE_EQ(je["input"]["all"]["mean_matched_iou"].get<double>(), 1.0);
  EXPECT_EQ(je["input"]["false_positive_instances"].get<int>(), 0);

  // The projected IoU equals the one computed by hand from the files.
  const std::vector<double> by_hand = projected_iou_by_hand(scene, exact, 100);
  ASSERT_EQ(by_hand.size(), je["projected"]["all"]["gt_instances"].get<size_t>());
  double sum = 0;
  for (double v : by_hand) sum += v;
  EXPECT_NEAR(je["projected"]["all"]["mean_instance_iou"].get<double>(), sum / by_hand.size(),
              1e-12);
  EXPECT_GT(je["projected"]["all"]["mean_matched_iou"].get<double>(), 0.6);
  EXPECT_LT(je["projected"]["all"]["mean_matched_iou"].get<double>(), 1.0);  // a render, not a copy

  // A known degradation (boundary shifts, misses, wrong classes) lowers the input IoU; the map
  // keeps the objects: each becomes one instance of the right class.
  ASSERT_EQ(run_cli("eval masks --run " + degraded + common + " --json " + degraded +
                    "/masks.json > /dev/null"),
            0);
  const auto jd = read_json(degraded + "/masks.json");
  EXPECT_LT(jd["input"]["all"]["mean_matched_iou"].get<double>(), 0.97);
  EXPECT_LT(jd["input"]["all"]["mean_instance_iou"].get<double>(),
            jd["input"]["all"]["mean_matched_iou"].get<double>());  // misses count 0
  EXPECT_GT(jd["projected"]["all"]["mean_instance_iou"].get<double>(),
            jd["input"]["all"]["mean_instance_iou"].get<double>());
  const auto& inst = jd["instances"];
  ASSERT_FALSE(inst.is_null());
  EXPECT_EQ(inst["objects"].get<int>(), 4);
  EXPECT_EQ(inst["objects_with_correct_class"].get<int>(), 4);
  EXPECT_EQ(inst["spurious_instances"].get<int>(), 0);

  // Bad input: a run without masks names the missing index.
  EXPECT_NE(run_cli("eval masks --dataset " + scene + " --run " + root + " 2>/dev/null"), 0);
}

}  // namespace
}  // namespace orpe
