// The on-disk cache of prepared object models (pipeline/model_cache.h, pipeline.model_cache_dir):
// a model read from the cache is bit for bit the one a fresh load gives; an input file's change
// (size, modification time, a texture that appears), or another option, makes it load afresh; a
// corrupt entry is a warning and is rebuilt; an unwritable folder is one warning; off writes
// nothing; the CLI's poses are the same with and without it.
#include <gtest/gtest.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <sstream>

#include "orpe/io/dataset.h"
#include "orpe/pipeline/model_cache.h"
#include "orpe/pipeline/object_models.h"
#include "orpe/pose/colour_score.h"
#include "orpe/pose/model_search.h"
#include "pipeline/pipeline_test_util.h"
#include "support/captured_log.h"
#include "support/cli_run.h"

namespace orpe {
namespace {
namespace fs = std::filesystem;

using test::CapturedLog;

/// A YCB-Video style model in `dir`: points.xyz on a box, a textured box OBJ with its MTL and PNG.
struct BoxModel {
  std::string dir, points, mesh, mtl, texture;
};

void write_texture(const std::string& path, int seed) {
  cv::Mat img(32, 32, CV_8UC3);
  std::mt19937 rng(seed);
  for (int v = 0; v < img.rows; ++v)
    for (int u = 0; u < img.cols; ++u)
      img.at<cv::Vec3b>(v, u) = cv::Vec3b(rng() % 256, (8 * u) % 256, (8 * v) % 256);
  ASSERT_TRUE(cv::imwrite(path, img));
}

BoxModel write_box_model(const std::string& dir, bool with_texture = true) {
  BoxModel m{dir, dir + "/points.xyz", dir + "/textured.obj", dir + "/textured.obj.mtl",
             dir + "/texture_map.png"};
  fs::create_directories(dir);
  const Eigen::Vector3f half(0.05f, 0.03f, 0.02f);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> uni(-1, 1);
  std::ofstream xyz(m.points);
  for (int i = 0; i < 600; ++i) {  // on the faces of the box
    Eigen::Vector3f p(uni(rng), uni(rng), uni(rng));
    p[i % 3] = i % 2 ? 1.0f : -1.0f;
    xyz << p.x() * half.x() << ' ' << p.y() * half.y() << ' ' << p.z() * half.z() << '\n';
  }
  std::ofstream obj(m.mesh);
  obj << "mtllib textured.obj.mtl\nusemtl box\n";
  for (int i = 0; i < 8; ++i)
    obj << "v " << (i & 1 ? half.x() : -half.x()) << ' ' << (i & 2 ? half.y() : -half.y()) << ' '
        << (i & 4 ? half.z() : -half.z()) << '\n';
  for (int i = 0; i < 8; ++i) obj << "vt " << (i & 1) * 0.9 + 0.05 << ' ' << (i & 6) / 7.0 << '\n';
  const int faces[12][3] = {{1, 3, 2}, {1, 4, 3}, {5, 6, 7}, {5, 7, 8}, {1, 2, 6}, {1, 6, 5},
                            {3, 4, 8}, {3, 8, 7}, {1, 5, 8}, {1, 8, 4}, {2, 3, 7}, {2, 7, 6}};
  for (const auto& f : faces)
    obj << "f " << f[0] << '/' << f[0] << ' ' << f[1] << '/' << f[1] << ' ' << f[2] << '/' << f[2]
        << '\n';
  std::ofstream(m.mtl) << "newmtl box\nKd 0.8 0.8 0.8\nmap_Kd texture_map.png\n";
  if (with_texture) write_texture(m.texture, 1);
  return m;
}

DatasetInfo box_dataset(const BoxModel& m) {
  DatasetInfo info;
  info.format = "ycbv";
  info.root = m.dir;
  info.class_names[1] = "box";
  info.model_points_paths[1] = m.points;
  info.model_mesh_paths[1] = m.mesh;
  return info;
}

void expect_same_colour(const ModelColour* a, const ModelColour* b) {
  ASSERT_EQ(a == nullptr, b == nullptr);
  if (!a) return;
  EXPECT_EQ(a->points, b->points);
  EXPECT_EQ(a->normals, b->normals);
  EXPECT_EQ(a->grey, b->grey);
  EXPECT_EQ(a->weight, b->weight);
  EXPECT_EQ(a->chroma, b->chroma);
  EXPECT_EQ(a->source, b->source);
}

/// Every field exactly (== on floats: bit for bit up to the sign of zero).
void expect_same_model(const ObjectModel& a, const ObjectModel& b) {
  EXPECT_EQ(a.class_id, b.class_id);
  EXPECT_EQ(a.name, b.name);
  EXPECT_EQ(a.points, b.points);
  EXPECT_EQ(a.normals, b.normals);
  EXPECT_EQ(a.diameter_m, b.diameter_m);
  EXPECT_EQ(a.mean_spacing_m, b.mean_spacing_m);
  EXPECT_EQ(a.symmetric_for_metric, b.symmetric_for_metric);
  EXPECT_EQ(a.symmetry.continuous, b.symmetry.continuous);
  EXPECT_EQ(a.symmetry.axis_obj, b.symmetry.axis_obj);
  EXPECT_EQ(a.symmetry.axis_point_obj, b.symmetry.axis_point_obj);
  ASSERT_EQ(a.symmetry.discrete.size(), b.symmetry.discrete.size());
  for (size_t k = 0; k < a.symmetry.discrete.size(); ++k) {
    EXPECT_EQ(a.symmetry.discrete[k].rotation(), b.symmetry.discrete[k].rotation());
    EXPECT_EQ(a.symmetry.discrete[k].translation(), b.symmetry.discrete[k].translation());
  }
  ASSERT_TRUE(a.search_index && b.search_index);
  EXPECT_EQ(a.search_index->size(), b.search_index->size());
  for (size_t i = 0; i < a.points.size(); i += 7) {
    const Eigen::Vector3f q = a.points[i] + Eigen::Vector3f(0.003f, -0.002f, 0.001f);
    float da = 0, db = 0;
    EXPECT_EQ(a.search_index->nearest(q, &da), b.search_index->nearest(q, &db));
    EXPECT_EQ(da, db);
  }
  expect_same_colour(a.colour.get(), b.colour.get());
}

std::vector<fs::path> entries(const std::string& dir) {
  std::vector<fs::path> out;
  if (fs::is_directory(dir))
    for (const auto& e : fs::directory_iterator(dir))
      if (e.path().extension() == ".model") out.push_back(e.path());
  return out;
}

std::string read_text(const fs::path& p) {
  std::ifstream is(p);
  std::stringstream ss;
  ss << is.rdbuf();
  return ss.str();
}

/// Rewrites `path` with `text` and gives it back its modification time: same time, maybe same size.
void replace_keeping_mtime(const std::string& path, const std::string& text) {
  const auto t = fs::last_write_time(path);
  std::ofstream(path, std::ios::trunc) << text;
  fs::last_write_time(path, t);
}

TEST(ModelCache, ACachedModelIsTheFreshOneBitForBit) {
  const BoxModel box = write_box_model(test::scratch_dir("box"));
  const DatasetInfo info = box_dataset(box);
  const ModelCache cache(test::scratch_dir("cache"));
  const ObjectModel fresh = load_dataset_object_model(info, 1);
  ASSERT_TRUE(fresh.colour) << "the textured box has a colour";
  const ObjectModel cold = load_dataset_object_model(info, 1, 2620, &cache);
  ASSERT_EQ(entries(cache.dir()).size(), 1u);
  // The entry records the material library and the texture beside the mesh and the points.
  const std::string entry = read_text(entries(cache.dir()).front());
  for (const std::string& f : {box.points, box.mesh, box.mtl, box.texture})
    EXPECT_NE(entry.find(fs::absolute(f).lexically_normal().string()), std::string::npos) << f;
  // The warm load comes from the entry: a points file rewritten behind its back (same size and
  // time) goes unnoticed.
  const std::string points = read_text(box.points);
  std::string altered = points;
  std::replace(altered.begin(), altered.end(), '1', '2');
  ASSERT_EQ(altered.size(), points.size());
  replace_keeping_mtime(box.points, altered);
  const ObjectModel warm = load_dataset_object_model(info, 1, 2620, &cache);
  expect_same_model(fresh, cold);
  expect_same_model(fresh, warm);
  replace_keeping_mtime(box.points, points);
}

TEST(ModelCache, YcbModelsReadBackBitForBit) {
  ORPE_REQUIRE_DATA(data, "ycbv/models/003_cracker_box/texture_map.png");
  DatasetInfo info;
  info.format = "ycbv";
  info.root = data + "/ycbv";
  int id = 0;
  for (const std::string name : {"003_cracker_box", "024_bowl"}) {  // textured, untextured
    info.class_names[++id] = name;
    info.model_points_paths[id] = data + "/ycbv/models/" + name + "/points.xyz";
    info.model_mesh_paths[id] = data + "/ycbv/models/" + name + "/textured_simple.obj";
  }
  const ModelCache cache(test::scratch_dir("cache"));
  for (int c = 1; c <= id; ++c) {
    const ObjectModel fresh = load_dataset_object_model(info, c, 2620, &cache);
    EXPECT_EQ(fresh.colour != nullptr, c == 1);
    expect_same_model(fresh, load_dataset_object_model(info, c, 2620, &cache));
  }
  EXPECT_EQ(entries(cache.dir()).size(), 2u);
}

TEST(ModelCache, ChangedInputsOrOptionsLoadAfresh) {
  const BoxModel box = write_box_model(test::scratch_dir("box"), false);
  DatasetInfo info = box_dataset(box);
  const ModelCache cache(test::scratch_dir("cache"));
  const ObjectModel untextured = load_dataset_object_model(info, 1, 2620, &cache);
  EXPECT_FALSE(untextured.colour);
  // The texture the MTL names appears: the entry recorded its absence.
  write_texture(box.texture, 1);
  const ObjectModel textured = load_dataset_object_model(info, 1, 2620, &cache);
  ASSERT_TRUE(textured.colour);
  // Another texture.
  const auto t = fs::last_write_time(box.texture);
  write_texture(box.texture, 2);
  fs::last_write_time(box.texture, t + std::chrono::seconds(2));
  const ObjectModel retextured = load_dataset_object_model(info, 1, 2620, &cache);
  expect_same_model(retextured, load_dataset_object_model(info, 1));
  EXPECT_NE(retextured.colour->grey, textured.colour->grey);
  // A points file of another size (same time).
  std::string points = read_text(box.points);
  replace_keeping_mtime(box.points, points + "0.05 0.03 0.02\n");
  const ObjectModel more = load_dataset_object_model(info, 1, 2620, &cache);
  EXPECT_EQ(more.points.size(), textured.points.size() + 1);
  // Another option: model units (a second entry; both stay valid).
  info.model_units_per_m = 100;
  const ObjectModel scaled = load_dataset_object_model(info, 1, 2620, &cache);
  EXPECT_FLOAT_EQ(scaled.diameter_m * 100, more.diameter_m);
  EXPECT_EQ(entries(cache.dir()).size(), 2u);
  expect_same_model(scaled, load_dataset_object_model(info, 1));
}

TEST(ModelCache, ACorruptEntryIsAWarningAndRebuilt) {
  const BoxModel box = write_box_model(test::scratch_dir("box"));
  const DatasetInfo info = box_dataset(box);
  const ModelCache cache(test::scratch_dir("cache"));
  const ObjectModel fresh = load_dataset_object_model(info, 1, 2620, &cache);
  const fs::path entry = entries(cache.dir()).at(0);
  const std::string text = read_text(entry);
  for (const std::string& bad : {text.substr(0, text.size() / 2), text.substr(0, text.size() - 3),
                                 std::string("garbage"), std::string()}) {
    std::ofstream(entry, std::ios::trunc) << bad;
    CapturedLog log;
    expect_same_model(fresh, load_dataset_object_model(info, 1, 2620, &cache));
    EXPECT_EQ(log.count(entry.string()), 1) << "a warning names the entry";
    EXPECT_EQ(read_text(entry), text) << "rebuilt";
  }
  // One number altered (the checksum catches it).
  std::string altered = text;
  altered[altered.find("\npoints ") + 12] ^= 1;
  std::ofstream(entry, std::ios::trunc) << altered;
  CapturedLog log;
  expect_same_model(fresh, load_dataset_object_model(info, 1, 2620, &cache));
  EXPECT_EQ(log.count("corrupt model cache entry"), 1);
}

TEST(ModelCache, AnUnwritableFolderIsOneWarning) {
  const BoxModel box = write_box_model(test::scratch_dir("box"));
  const DatasetInfo info = box_dataset(box);
  const ObjectModel model = load_dataset_object_model(info, 1);
  // A file where the folder should be: one warning, models still load.
  const std::string file = test::scratch_dir("blocked") + "/file";
  std::ofstream(file) << "not a folder";
  DatasetInfo two = info;
  const BoxModel box2 = write_box_model(test::scratch_dir("box2"));
  two.class_names[2] = "box2";
  two.model_points_paths[2] = box2.points;
  two.model_mesh_paths[2] = box2.mesh;
  CapturedLog log;
  ObjectModelLibrary blocked(two);
  blocked.set_cache_dir(file + "/cache");
  blocked.preload({1, 2}, 2);
  expect_same_model(model, blocked.get(1));
  EXPECT_EQ(log.count("cannot write"), 1);
  EXPECT_EQ(log.size(), 1u);
}

TEST(ModelCache, AutoFollowsTheEnvironmentAndEmptyOrNoneIsOff) {
  EXPECT_EQ(resolve_model_cache_dir(""), "");
  EXPECT_EQ(resolve_model_cache_dir("none"), "");
  EXPECT_EQ(resolve_model_cache_dir("/some/where"), "/some/where");
  const auto saved = [](const char* name) -> std::optional<std::string> {
    const char* v = std::getenv(name);
    return v ? std::optional<std::string>(v) : std::nullopt;
  };
  const auto orpe = saved("ORPE_CACHE_DIR"), xdg = saved("XDG_CACHE_HOME"), home = saved("HOME");
  ::setenv("ORPE_CACHE_DIR", "/a", 1);
  EXPECT_EQ(resolve_model_cache_dir("auto"), "/a");
  ::setenv("ORPE_CACHE_DIR", "", 1);
  EXPECT_EQ(resolve_model_cache_dir("auto"), "") << "set and empty: off";
  ::unsetenv("ORPE_CACHE_DIR");
  ::setenv("XDG_CACHE_HOME", "/x", 1);
  EXPECT_EQ(resolve_model_cache_dir("auto"), "/x/orpe/models");
  ::unsetenv("XDG_CACHE_HOME");
  ::setenv("HOME", "/h", 1);
  EXPECT_EQ(resolve_model_cache_dir("auto"), "/h/.cache/orpe/models");
  const auto restore = [](const char* name, const std::optional<std::string>& v) {
    if (v)
      ::setenv(name, v->c_str(), 1);
    else
      ::unsetenv(name);
  };
  restore("ORPE_CACHE_DIR", orpe);
  restore("XDG_CACHE_HOME", xdg);
  restore("HOME", home);
}

/// poses.csv of `orpe run` on a synthetic scene with `sets`, without its time column.
std::string run_poses(const std::string& scene, const std::string& out, const std::string& sets) {
  fs::remove_all(out);
  EXPECT_EQ(test::run_cli("run --dataset " + scene + " --out " + out +
                          " --mode full --set pose_registration.num_rotations=60 " + sets +
                          " > /dev/null 2>&1"),
            0);
  std::istringstream csv(read_text(out + "/poses.csv"));
  std::string poses, line;
  while (std::getline(csv, line)) poses += line.substr(0, line.rfind(',')) + '\n';
  return poses;
}

TEST(CliModelCache, PosesAreTheSameWithAndWithoutTheCacheAndOffWritesNothing) {
  const std::string scene =
      test::synthetic_scene("model_cache_cli", test::small_scene_params(160, 120, 4, 3, 13));
  const std::string cache = test::scratch_dir("cli_cache");
  const char* env = std::getenv("ORPE_CACHE_DIR");
  const std::string saved = env ? env : "";
  ::setenv("ORPE_CACHE_DIR", cache.c_str(), 1);  // "auto" (the default) is this folder
  const std::string off =
      run_poses(scene, test::scratch_dir("off"), "--set pipeline.model_cache_dir=");
  EXPECT_TRUE(entries(cache).empty()) << "off writes nothing";
  ASSERT_FALSE(off.empty());
  EXPECT_EQ(run_poses(scene, test::scratch_dir("cold"), ""), off);
  const auto stored = entries(cache);
  EXPECT_GE(stored.size(), 1u);
  const auto written = fs::last_write_time(stored.front());
  EXPECT_EQ(run_poses(scene, test::scratch_dir("warm"), ""), off);
  EXPECT_EQ(entries(cache).size(), stored.size());
  EXPECT_EQ(fs::last_write_time(stored.front()), written) << "the warm run read, not rewrote";
  if (env)
    ::setenv("ORPE_CACHE_DIR", saved.c_str(), 1);
  else
    ::unsetenv("ORPE_CACHE_DIR");
}

}  // namespace
}  // namespace orpe
