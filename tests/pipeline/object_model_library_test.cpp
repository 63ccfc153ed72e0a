// ObjectModelLibrary::preload (pipeline/object_models.h): the models loaded on several threads are
// the ones get() loads one by one, and a bad model file is reported after the others are loaded.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "orpe/core/error.h"
#include "orpe/io/dataset.h"
#include "orpe/pipeline/object_models.h"
#include "pipeline/pipeline_test_util.h"

namespace orpe {
namespace {

DatasetInfo scene_info(const std::string& scene) {
  DatasetParams p;
  return open_dataset(scene, p)->info();
}

std::vector<int> model_ids(const DatasetInfo& info) {
  std::vector<int> ids;
  for (const auto& [id, path] : info.model_points_paths) ids.push_back(id);
  return ids;
}

TEST(ObjectModelLibrary, PreloadOnThreadsGivesTheModelsGetLoadsOneByOne) {
  const DatasetInfo info =
      scene_info(test::synthetic_scene("models", test::small_scene_params(160, 120, 2, 4, 9)));
  const std::vector<int> ids = model_ids(info);
  ASSERT_GE(ids.size(), 3u);
  const ObjectModelLibrary one_by_one(info), threaded(info);
  threaded.preload(ids, 3);
  for (int id : ids) {
    const ObjectModel& a = one_by_one.get(id);
    const ObjectModel& b = threaded.get(id);
    ASSERT_EQ(a.points.size(), b.points.size()) << id;
    ASSERT_GT(a.points.size(), 0u);
    for (size_t i = 0; i < a.points.size(); ++i) ASSERT_EQ(a.points[i], b.points[i]) << id;
    EXPECT_EQ(a.normals, b.normals) << id;
    EXPECT_EQ(a.name, b.name);
  }
}

TEST(ObjectModelLibrary, PreloadReportsABadModelAndLoadsTheOthers) {
  DatasetInfo info =
      scene_info(test::synthetic_scene("models", test::small_scene_params(160, 120, 2, 4, 9)));
  const std::vector<int> ids = model_ids(info);
  ASSERT_GE(ids.size(), 2u);
  const std::string bad = test::scratch_dir("bad_model") + "/broken.ply";
  std::ofstream(bad) << "ply\nformat ascii 1.0\nelement vertex 3\nend_header\n1 2\n";
  info.model_points_paths[ids.front()] = bad;
  const ObjectModelLibrary library(info);
  try {
    library.preload(ids, 2);
    FAIL() << "a broken model file was accepted";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("broken.ply"), std::string::npos) << e.what();
  }
  for (size_t i = 1; i < ids.size(); ++i) EXPECT_GT(library.get(ids[i]).points.size(), 0u);
}

}  // namespace
}  // namespace orpe
