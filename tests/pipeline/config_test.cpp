#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>

#include "orpe/core/config_keys.h"
#include "orpe/core/error.h"
#include "orpe/pipeline/config.h"
#include "support/test_data.h"

namespace orpe {
namespace {

TEST(Config, OverridesSetTypedFields) {
  OrpeConfig c;
  apply_config_override(c, "dataset.stride=3");
  apply_config_override(c, "dataset.format=tum");
  apply_config_override(c, "dataset.max_depth_m=4.5");
  EXPECT_EQ(c.dataset.stride, 3);
  EXPECT_EQ(c.dataset.format, "tum");
  EXPECT_DOUBLE_EQ(c.dataset.max_depth_m, 4.5);
}

TEST(Config, BadOverridesNameTheKey) {
  OrpeConfig c;
  try {
    apply_config_override(c, "dataset.stride=abc");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("dataset.stride"), std::string::npos);
  }
  EXPECT_THROW(apply_config_override(c, "dataset.nope=1"), ConfigError);
  EXPECT_THROW(apply_config_override(c, "nosection.x=1"), ConfigError);
  EXPECT_THROW(apply_config_override(c, "stride=1"), ConfigError);
}

TEST(Config, FileRoundTripAndUnknownKeys) {
  OrpeConfig c;
  c.dataset.stride = 7;
  const std::string dir = test::scratch_dir("cfg");
  {
    std::ofstream os(dir + "/c.json");
    os << config_to_json(c);
  }
  OrpeConfig d;
  load_config_file(d, dir + "/c.json");
  EXPECT_EQ(d.dataset.stride, 7);
  {
    std::ofstream os(dir + "/bad.json");
    os << R"({"dataset": {"strid": 2}})";
  }
  try {
    load_config_file(d, dir + "/bad.json");
    FAIL();
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.json"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("dataset.strid"), std::string::npos);
  }
}

// Issue 17: YAML config files, with the same strict checks as JSON (and the line of the problem).
TEST(Config, YamlConfigFilesAreReadWithTheSameChecks) {
  const std::string dir = test::scratch_dir("yaml");
  auto write = [&](const std::string& name, const std::string& text) {
    std::ofstream(dir + "/" + name) << text;
    return dir + "/" + name;
  };
  OrpeConfig c;
  load_config_file(c, write("c.yaml",
                            "# my camera\ndataset:\n  stride: 3\n  scene: 0001\n  max_depth_m: 4.5\n"
                            "slam:\n  fuse_degraded: false\n"));
  EXPECT_EQ(c.dataset.stride, 3);
  EXPECT_EQ(c.dataset.scene, "0001");  // a string key keeps the text as written
  EXPECT_DOUBLE_EQ(c.dataset.max_depth_m, 4.5);
  EXPECT_FALSE(c.slam.fuse_degraded);
  struct Case {
    std::string text, needle;
  };
  const std::vector<Case> bad = {
      {"dataset:\n  strid: 2\n", "line 2: unknown config key 'dataset.strid'"},
      {"dataset:\n  stride: 1.5\n", "line 2"},
      {"dataset:\n  stride: [1, 2]\n", "must be a single value"},
      {"datasets:\n  stride: 2\n", "line 1: unknown config section 'datasets'"},
      {"dataset: 3\n", "must be a mapping"},
      {"dataset:\n  stride: 2\n bad indent: [\n", "invalid YAML"},
      {"slam:\n  fuse_degraded: maybe\n", "expected a boolean"},
      // a list or a map as a name escaped as yaml-cpp's BadConversion (fuzz config_json finding 31)
      {"{dataset: 1}: {stride: 2}\n", "line 1: a section name must be a plain word, not a list"},
      {"dataset:\n  [stride]: 2\n", "line 2: a key of section 'dataset' must be a plain word"},
  };
  for (size_t i = 0; i < bad.size(); ++i) {
    OrpeConfig d;
    const std::string path = write("bad" + std::to_string(i) + ".yml", bad[i].text);
    try {
      load_config_file(d, path);
      ADD_FAILURE() << bad[i].text;
    } catch (const IoError& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(bad[i].needle), std::string::npos) << e.what();
    }
  }
}

// Issue 12: 1.5 for an integer was truncated to 1; 1e8 iterations with convergence_step 0 ran for ever.
TEST(Config, IntegersAreNotTruncatedAndRunawayParametersAreRefused) {
  const std::string dir = test::scratch_dir("cfg_int");
  for (const char* text : {R"({"dataset": {"stride": 1.5}})", R"({"dataset": {"stride": 1e8}})",
                           R"({"dataset": {"stride": 99999999999}})"}) {
    std::ofstream(dir + "/c.json") << text;
    OrpeConfig d;
    try {
      load_config_file(d, dir + "/c.json");
      ADD_FAILURE() << text << " accepted: stride " << d.dataset.stride;
    } catch (const IoError& e) {
      EXPECT_NE(std::string(e.what()).find("dataset.stride"), std::string::npos) << e.what();
    }
  }
  std::string why;
  for (const char* bad : {"slam_tracking.iterations_level0=100000000", "slam_tracking.convergence_step=0",
                          "slam_tracking.convergence_step=-1", "dataset.last_frame=-7"}) {
    OrpeConfig c;
    apply_config_override(c, bad);
    EXPECT_FALSE(c.IsValid(&why)) << bad;
  }
}

TEST(Config, ValidityCheckNamesSection) {
  OrpeConfig c;
  c.dataset.stride = 0;
  std::string why;
  EXPECT_FALSE(c.IsValid(&why));
  EXPECT_NE(why.find("dataset"), std::string::npos);
}

TEST(Config, DescribeListsEveryKeyWithDocs) {
  const auto docs = describe_config(OrpeConfig{});
  ASSERT_FALSE(docs.empty());
  for (const auto& d : docs) EXPECT_FALSE(d.doc.empty()) << d.key;
}

TEST(Config, PresetsAreValidAndOverridable) {
  for (const auto& name : config_preset_names()) {
    OrpeConfig c;
    apply_config_preset(c, name);
    std::string why;
    EXPECT_TRUE(c.IsValid(&why)) << name << ": " << why;
  }
  OrpeConfig c;
  apply_config_preset(c, "realtime");
  EXPECT_EQ(c.slam_tracking.level0_pixel_step, 2);
  EXPECT_EQ(c.slam_tracking.iterations_level1, 1);
  EXPECT_GT(c.slam_tracking.convergence_step, OrpeConfig().slam_tracking.convergence_step);
  EXPECT_EQ(c.slam_fusion.fusion_level, 1);
  EXPECT_FALSE(c.slam_loop.enabled);
  EXPECT_EQ(c.slam.prediction_surface_band_m, 0);
  EXPECT_GT(OrpeConfig().slam.prediction_surface_band_m, 0);
  EXPECT_TRUE(OrpeConfig().slam_loop.enabled);  // on by default (docs/SLAM.md "Loop closure")
  apply_config_override(c, "slam_fusion.fusion_level=0");  // overrides come after the preset
  EXPECT_EQ(c.slam_fusion.fusion_level, 0);
  apply_config_preset(c, "default");
  EXPECT_EQ(c.slam_tracking.level0_pixel_step, OrpeConfig().slam_tracking.level0_pixel_step);
  EXPECT_THROW(apply_config_preset(c, "turbo"), ConfigError);
}

std::string override_error(const std::string& assignment) {
  OrpeConfig c;
  try {
    apply_config_override(c, assignment);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(Config, ARenamedOrMistypedKeyIsToldTheWayForward) {
  // A renamed key points to its successor, in every way a key is given.
  const std::string renamed = override_error("pose_registration.colour_lambert_fit=true");
  EXPECT_NE(renamed.find("unknown config key 'pose_registration.colour_lambert_fit'"),
            std::string::npos) << renamed;
  EXPECT_NE(renamed.find("renamed: use 'pose_registration.colour_evidence'"), std::string::npos)
      << renamed;
  const std::string dir = test::scratch_dir("renamed_keys");
  for (const std::string name : {"c.json", "c.yaml"}) {
    const bool yaml = name == "c.yaml";
    std::ofstream(dir + "/" + name) << (yaml ? "pose_registration:\n  colour_lambert_fit: false\n"
                                             : R"({"pose_registration": {"colour_lambert_fit": false}})");
    OrpeConfig c;
    try {
      load_config_file(c, dir + "/" + name);
      ADD_FAILURE() << name;
    } catch (const IoError& e) {
      EXPECT_NE(std::string(e.what()).find("use 'pose_registration.colour_evidence'"),
                std::string::npos) << e.what();
    }
  }
  // A typo gets the nearest key of its section; a word far from every key gets no guess.
  EXPECT_NE(override_error("dataset.strid=2").find("did you mean 'dataset.stride'?"),
            std::string::npos);
  EXPECT_NE(override_error("slam_loop.enabeld=true").find("did you mean 'slam_loop.enabled'?"),
            std::string::npos);
  const std::string far = override_error("dataset.colour=2");
  EXPECT_NE(far.find("unknown config key 'dataset.colour'"), std::string::npos) << far;
  EXPECT_EQ(far.find("did you mean"), std::string::npos) << far;
  // The table stays true: every old key is unknown now, every new key is a key.
  std::vector<std::string> keys;
  for (const ParamDoc& d : describe_config(OrpeConfig{})) keys.push_back(d.key);
  for (const RenamedConfigKey& r : renamed_config_keys()) {
    EXPECT_EQ(std::count(keys.begin(), keys.end(), r.old_key), 0) << r.old_key;
    EXPECT_EQ(std::count(keys.begin(), keys.end(), r.new_key), 1) << r.new_key;
  }
  EXPECT_EQ(edit_distance("stride", "strid"), 1u);
  EXPECT_EQ(edit_distance("enabled", "enabeld"), 2u);
  EXPECT_EQ(edit_distance("", "abc"), 3u);
}

}  // namespace
}  // namespace orpe
