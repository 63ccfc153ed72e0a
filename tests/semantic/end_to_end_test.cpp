// The semantic stage end to end on a synthetic table-top scene: the SLAM's surfel fusion at
// ground-truth poses, degraded ground-truth detections (boundary errors, misses, wrong classes,
// spurious blobs), semantic fusion, then instance-level and mask-level checks.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "orpe/io/point_cloud_io.h"
#include "orpe/semantic/mask_eval.h"
#include "orpe/semantic/semantic_mapper.h"
#include "orpe/semantic/semantic_output.h"
#include "orpe/slam/fusion.h"
#include "orpe/slam/preprocess.h"
#include "semantic/synthetic_scene.h"
#include "support/test_data.h"

namespace orpe {
namespace {

struct RunResult {
  SemanticMaskResult eval;
  std::map<int, InstanceInfo> instances;
  slam::SurfelMap map;
  double surfel_accuracy = 0;  ///< stable object surfels labelled with their object's instance
  int object_surfels = 0;      ///< stable object surfels (confidence >= 10: the map as exported)
  double all_surfel_accuracy = 0;  ///< the same over all object surfels, unstable ones included
  double background_labelled = 0;  ///< fraction of background surfels carrying an instance
  std::vector<SemanticFrameReport> reports;
};

RunResult run_scene(const test::SyntheticScene& scene, const std::vector<SE3>& poses,
                    const SegmentationParams& seg, const SemanticParams& sem) {
  std::vector<int> classes;
  for (int c = 1; c <= 10; ++c) classes.push_back(c);
  SemanticMapper mapper(seg, sem, classes);
  slam::FramePreprocessor pre;
  slam::SurfelFusion fusion;
  slam::FramePyramid pyramid;
  slam::IndexImage pixel_surfel;
  RunResult r;
  SemanticMaskEvaluator evaluator;
  for (size_t i = 0; i < poses.size(); ++i) {
    const RgbdFrame frame = scene.render(static_cast<int>(i), poses[i]);
    pre.process(frame, &pyramid);
    fusion.fuse(pyramid, poses[i], static_cast<std::int32_t>(i), &r.map, &pixel_surfel);
    const auto& step = mapper.process(frame, poses[i], r.map, &pixel_surfel);
    if (step.keyframe) r.reports.push_back(step.report);
    evaluator.add_frame(frame, step.detections,
                        mapper.render_instance_labels(r.map, poses[i], scene.K),
                        mapper.fusion().instances());
  }
  mapper.finalize(r.map);
  r.instances = mapper.fusion().instances();
  r.eval = evaluator.result(r.instances);

  // Surfel-level check: which object each surfel lies on (geometry), vs. its instance's owner.
  std::map<int, int> owner;  // instance -> object index (by majority of its surfels)
  std::map<int, std::map<int, int>> votes;
  std::vector<int> surfel_object(r.map.size());
  for (size_t i = 0; i < r.map.size(); ++i) {
    surfel_object[i] = scene.object_at(r.map.position_world[i].cast<double>(), 0.01);
    if (r.map.instance_id[i] > 0) ++votes[r.map.instance_id[i]][surfel_object[i]];
  }
  for (const auto& [id, v] : votes)
    owner[id] = std::max_element(v.begin(), v.end(), [](auto& a, auto& b) {
                  return a.second < b.second;
                })->first;
  int correct = 0, background = 0, background_labelled = 0, all = 0, all_correct = 0;
  for (size_t i = 0; i < r.map.size(); ++i) {
    if (surfel_object[i] < 0) {
      ++background;
      background_labelled += r.map.instance_id[i] > 0;
      continue;
    }
    const int id = r.map.instance_id[i];
    const bool right = id > 0 && owner[id] == surfel_object[i];
    ++all;
    all_correct += right;
    if (r.map.confidence[i] < 10.0f) continue;
    ++r.object_surfels;
    correct += right;
  }
  r.surfel_accuracy = r.object_surfels ? static_cast<double>(correct) / r.object_surfels : 0;
  r.all_surfel_accuracy = all ? static_cast<double>(all_correct) / all : 0;
  r.background_labelled = background ? static_cast<double>(background_labelled) / background : 0;
  return r;
}

TEST(SemanticEndToEnd, NineObjectsDegradedDetections) {
  const auto t0 = std::chrono::steady_clock::now();
  const test::SyntheticScene scene = test::nine_object_scene(320, 240);
  const auto poses = test::orbit(24, 0.75, 0.5, 100.0, -50.0);
  SegmentationParams seg;  // default degradation: boundary shift 0..3 px per object, +-1 per frame,
  seg.gt_spurious_per_frame =
      0.5;  // 10 % misses, 5 % wrong class; more spurious blobs than default
  const RunResult r = run_scene(scene, poses, seg, SemanticParams{});
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::cout << r.eval.report() << "stable object surfels " << r.object_surfels
            << ", right instance " << r.surfel_accuracy << " (all surfels " << r.all_surfel_accuracy
            << "), background surfels labelled " << r.background_labelled << ", " << seconds
            << " s\n";

  // Every object exactly one instance with the right class, no spurious instance.
  EXPECT_EQ(r.instances.size(), scene.objects.size());
  EXPECT_EQ(r.eval.objects.size(), scene.objects.size());
  EXPECT_EQ(r.eval.objects_with_exactly_one_instance, static_cast<int>(scene.objects.size()));
  EXPECT_EQ(r.eval.objects_with_correct_class, static_cast<int>(scene.objects.size()));
  EXPECT_TRUE(r.eval.spurious_instances.empty());
  for (const auto& o : r.eval.objects)
    EXPECT_EQ(o.argmax_class, o.class_id) << o.object_instance_id;
  // Surfels: >= 95 % of (stable) object surfels carry their object's instance; few background ones
  // do.
  EXPECT_GE(r.surfel_accuracy, 0.95);
  EXPECT_GE(r.all_surfel_accuracy, 0.85);
  EXPECT_LT(r.background_labelled, 0.02);
  // The map's projected masks beat the detections that built it.
  EXPECT_GT(r.eval.overall.projected_miou, r.eval.overall.input_miou);
  EXPECT_GT(r.eval.overall.projected_miou_matched, r.eval.overall.input_miou_matched);
  // Boundary refinement did something.
  int joined = 0;
  for (const auto& rep : r.reports) joined += rep.boundary_joined;
  EXPECT_GT(joined, 0);
}

TEST(SemanticEndToEnd, ExactDetectionsGiveNearPerfectMasksAndOutputs) {
  const test::SyntheticScene scene = test::nine_object_scene(320, 240);
  const auto poses = test::orbit(10, 0.75, 0.5, 40.0, -20.0);
  SegmentationParams seg;
  seg.gt_degrade = false;
  seg.gt_min_visible_px = 30;
  SemanticParams sem;
  sem.min_instance_surfels = 20;
  const RunResult r = run_scene(scene, poses, seg, sem);
  EXPECT_EQ(r.instances.size(), scene.objects.size());
  EXPECT_EQ(r.eval.objects_with_correct_class, static_cast<int>(scene.objects.size()));
  for (const auto& [id, info] : r.instances) EXPECT_NEAR(info.argmax_probability(), 1.0, 1e-9);
  // Instances are confirmed at their second detection: the first keyframe projects nothing.
  EXPECT_GT(r.eval.overall.projected_miou_matched, 0.85);
  EXPECT_LE(r.eval.overall.projected_missed, static_cast<int>(scene.objects.size()));
  EXPECT_GE(r.surfel_accuracy, 0.95);

  // Outputs: PLY with one vertex per surfel and matching instance ids; instances.json.
  const std::string dir = test::scratch_dir("out");
  write_semantic_outputs(dir, r.map, r.instances, {{4, "four"}});
  for (const char* name : {"semantic_map.ply", "semantic_map_instances.ply", "instances.json"})
    EXPECT_TRUE(std::filesystem::exists(dir + "/" + name)) << name;
  const PointCloudData cloud = read_point_cloud_ply(dir + "/semantic_map.ply");
  ASSERT_EQ(cloud.size(), r.map.size());
  ASSERT_EQ(cloud.instance_ids.size(), r.map.size());
  ASSERT_EQ(cloud.class_ids.size(), r.map.size());
  for (size_t i = 0; i < cloud.size(); ++i) {
    ASSERT_EQ(cloud.instance_ids[i], r.map.instance_id[i]);
    ASSERT_EQ(cloud.colors[i], r.map.color[i]);
    const int expected_class =
        r.map.instance_id[i] > 0 ? r.instances.at(r.map.instance_id[i]).argmax_class() : 0;
    ASSERT_EQ(cloud.class_ids[i], expected_class);
  }
  const PointCloudData coded = read_point_cloud_ply(dir + "/semantic_map_instances.ply");
  ASSERT_EQ(coded.size(), r.map.size());
  for (size_t i = 0; i < coded.size(); i += 37)
    ASSERT_EQ(coded.colors[i], label_color(r.map.instance_id[i]));
  const auto j = nlohmann::json::parse(std::ifstream(dir + "/instances.json"));
  ASSERT_EQ(j["instances"].size(), r.instances.size());
  int surfels = 0;
  for (const auto& ji : j["instances"]) {
    surfels += ji["surfels"].get<int>();
    EXPECT_EQ(ji["class_id"].get<int>(), r.instances.at(ji["id"].get<int>()).argmax_class());
    EXPECT_LE(ji["bbox_min_world_m"][2].get<double>(), ji["bbox_max_world_m"][2].get<double>());
    if (ji["class_id"] == 4) {
      EXPECT_EQ(ji["class_name"], "four");
    }
  }
  int labelled = 0;
  for (auto id : r.map.instance_id) labelled += id > 0;
  EXPECT_EQ(surfels, labelled);
}

TEST(SemanticEndToEnd, InstanceViewsAreTheMapsMaskDepthAndColour) {
  const test::SyntheticScene scene = test::nine_object_scene(320, 240);
  const auto poses = test::orbit(6, 0.75, 0.5, 20.0, -10.0);
  SegmentationParams seg;
  seg.gt_degrade = false;
  seg.gt_min_visible_px = 30;
  SemanticMapper mapper(seg, SemanticParams{});
  slam::FramePreprocessor pre;
  slam::SurfelFusion fusion;
  slam::FramePyramid pyramid;
  slam::IndexImage pixel_surfel;
  slam::SurfelMap map;
  RgbdFrame frame;
  for (size_t i = 0; i < poses.size(); ++i) {
    frame = scene.render(static_cast<int>(i), poses[i]);
    pre.process(frame, &pyramid);
    fusion.fuse(pyramid, poses[i], static_cast<std::int32_t>(i), &map, &pixel_surfel);
    mapper.process(frame, poses[i], map, &pixel_surfel);
  }
  const auto views = mapper.render_instance_views(map, poses.back(), scene.K, 20);
  ASSERT_GE(views.size(), 7u);
  int total_area = 0, total_depth_ok = 0, total_gt_ok = 0;
  for (const auto& view : views) {
    const auto& info = mapper.fusion().instances().at(view.instance_id);
    EXPECT_EQ(view.class_id, info.argmax_class());
    int area = 0, depth_ok = 0, gt_ok = 0;
    for (int v = 0; v < scene.K.height; ++v)
      for (int u = 0; u < scene.K.width; ++u) {
        if (!view.projected_mask.at(u, v)) {
          ASSERT_EQ(view.projected_depth.at(u, v), 0.0f);
          continue;
        }
        ++area;
        ASSERT_TRUE(view.box.u_min <= u && u <= view.box.u_max && view.box.v_min <= v &&
                    v <= view.box.v_max);
        depth_ok += std::abs(view.projected_depth.at(u, v) - frame.depth.at(u, v)) < 0.01;
        const int k = frame.labels_gt.at(u, v);
        gt_ok += k > 0 && scene.objects[k - 1].class_id == view.class_id;
      }
    EXPECT_EQ(area, view.area_px);
    // PD agrees with the measured depth and PM covers the right object, but for a rim of about one
    // pixel where surfels overhang the silhouette (a larger share of small objects).
    EXPECT_GT(depth_ok, 0.85 * area) << view.instance_id;
    EXPECT_GT(gt_ok, 0.85 * area) << view.instance_id;
    total_area += area;
    total_depth_ok += depth_ok;
    total_gt_ok += gt_ok;
  }
  EXPECT_GT(total_depth_ok, 0.93 * total_area);
  EXPECT_GT(total_gt_ok, 0.93 * total_area);
}

}  // namespace
}  // namespace orpe
