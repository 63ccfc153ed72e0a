// `orpe colour` (colour models from an annotated recording) and pipeline.model_colour_dir: the
// files it writes hold the colour seen at the ground-truth poses, and a run given the folder uses
// them in place of the models' own colour (objects.json names the source). Bad output folders are
// refused.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>

#include "orpe/io/dataset.h"
#include "orpe/pose/colour_score.h"
#include "pipeline/pipeline_test_util.h"
#include "support/cli_run.h"

namespace orpe {
namespace {

/// `orpe -q ARGS`, output discarded; 0 on success.
int orpe_cli(const std::string& args) {
  return test::run_cli(args + " > /dev/null 2>&1");
}

TEST(ColourCli, ColoursEveryAnnotatedClassAndARunUsesTheFiles) {
  const std::string scene =
      test::synthetic_scene("colour_cli", test::small_scene_params(160, 120, 8, 3, 7));
  const std::string out = test::scratch_dir("colours");
  std::filesystem::remove_all(out);
  ASSERT_EQ(orpe_cli("colour --dataset " + scene + " --out " + out), 0);

  const auto reader = open_dataset(scene, DatasetParams{});
  std::set<std::string> names;
  for (const auto& g : reader->read(0).objects_gt)
    names.insert(reader->info().class_names.at(g.class_id));
  ASSERT_FALSE(names.empty());
  for (const std::string& name : names) {
    const std::string path = out + "/" + name + ".colour";
    ASSERT_TRUE(std::filesystem::is_regular_file(path)) << path;
    const auto colour = read_model_colour(path);
    std::string why;
    EXPECT_TRUE(colour->IsValid(&why)) << why;
    // Seen from one side over a 16-degree arc: a good part of the surface, never all of it.
    const double known = static_cast<double>(colour->num_known()) / colour->size();
    EXPECT_GT(known, 0.1) << name;
    EXPECT_LT(known, 1.0) << name;
    EXPECT_EQ(colour->source.rfind("annotated: ", 0), 0u) << colour->source;
  }

  // A non-empty --out is refused without --overwrite; a file as --out always.
  EXPECT_NE(orpe_cli("colour --dataset " + scene + " --out " + out), 0);
  EXPECT_EQ(orpe_cli("colour --dataset " + scene + " --out " + out + " --overwrite"), 0);
  const std::string file = out + "/" + *names.begin() + ".colour";
  EXPECT_NE(orpe_cli("colour --dataset " + scene + " --out " + file + " --overwrite"), 0);

  // The run takes the colour from the folder (here the same frames: a wiring check, not a score).
  const std::string run = test::scratch_dir("colour_run");
  std::filesystem::remove_all(run);
  ASSERT_EQ(orpe_cli("run --dataset " + scene + " --out " + run +
                     " --mode full --set pose_registration.num_rotations=60"
                     " --set pipeline.model_colour_dir=" +
                     out),
            0);
  const auto objects = test::read_json(run + "/objects.json")["objects"];
  ASSERT_FALSE(objects.empty());
  for (const auto& o : objects)
    EXPECT_EQ(o["model_colour"].get<std::string>().rfind("annotated: ", 0), 0u) << o.dump();
}

}  // namespace
}  // namespace orpe
