// docs/PIPELINE.md: an object whose class has no model in the dataset gets no pose, with one
// warning per class on stderr (not one per frame) and the reason on each of its estimates; the
// other objects are estimated as usual.
#include <gtest/gtest.h>
#include <spdlog/spdlog.h>

#include <map>
#include <string>

#include "orpe/io/dataset.h"
#include "pipeline/pipeline_test_util.h"
#include "support/captured_log.h"

namespace orpe {
namespace {

using test::CapturedLog;

TEST(MissingModel, ObjectsOfAClassWithoutAModelGetNoPoseAndOneWarning) {
  const auto reader =
      open_dataset(test::synthetic_scene("nomodel", test::small_scene_params(160, 120, 8, 3, 11)),
                   DatasetParams{});
  DatasetInfo info = reader->info();
  ASSERT_GE(info.model_points_paths.size(), 2u);
  const int missing = info.model_points_paths.begin()->first;
  info.model_points_paths.erase(missing);
  info.model_mesh_paths.erase(missing);

  ObjectRpeParams params = ObjectRpeParams::from_config(OrpeConfig{});
  params.segmentation.gt_degrade = false;
  params.variants = {PoseVariant::named("DF-PM")};
  ObjectRpePipeline pipeline(params, info);
  auto shared = std::make_shared<test::RecordingEstimator::Shared>();
  shared->record_images = false;
  pipeline.set_single_view_estimator(std::make_unique<test::RecordingEstimator>(shared), false);

  CapturedLog log;
  std::map<int, int> estimates, valid, no_model_reason;
  for (size_t i = 0; i < reader->size(); ++i) {
    const RgbdFrame f = reader->read(i);
    test::set_truth(*shared, f);
    const PipelineFrameResult& r = pipeline.process(f);
    if (!r.evaluated) continue;
    for (const auto& e : r.variants.at(0)) {
      ++estimates[e.class_id];
      valid[e.class_id] += e.single_view.valid;
      no_model_reason[e.class_id] += e.single_view.reason == "no model for the class";
    }
  }
  ASSERT_GT(estimates[missing], 1) << "the class without a model must be seen in several frames";
  EXPECT_EQ(valid[missing], 0);
  EXPECT_EQ(no_model_reason[missing], estimates[missing]);
  for (const auto& [cls, n] : estimates)
    if (cls != missing) {
      EXPECT_GT(valid[cls], 0) << "class " << cls;
      EXPECT_EQ(no_model_reason[cls], 0) << "class " << cls;
    }
  EXPECT_EQ(log.count(fmt::format("class {} has no model in the dataset", missing)), 1);
}

}  // namespace
}  // namespace orpe
