// PLY model points, point-cloud PLY writer/reader round trips, label palette, JSON summaries.
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <set>

#include <nlohmann/json.hpp>

#include "io/dataset_fixtures.h"
#include "orpe/core/error.h"
#include "orpe/io/json_summary.h"
#include "orpe/io/model_io.h"
#include "orpe/io/point_cloud_io.h"
#include "support/test_data.h"

namespace orpe {
namespace {

template <class T>
void put(std::string& s, T v, bool big_endian = false) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if (big_endian) std::reverse(b, b + sizeof(T));
  s.append(b, sizeof(T));
}

/// Binary PLY with a face element *before* the vertices (legal, and skipping lists must work),
/// vertex x y z as float (LE) or double (BE), plus a uchar colour.
std::string binary_ply(bool big_endian) {
  std::string s = std::string("ply\nformat ") +
                  (big_endian ? "binary_big_endian" : "binary_little_endian") +
                  " 1.0\ncomment test\nelement face 2\nproperty list uchar int vertex_indices\n"
                  "element vertex 3\nproperty " +
                  (big_endian ? "double" : "float") + " x\nproperty uchar red\nproperty " +
                  (big_endian ? "double" : "float") + " y\nproperty " +
                  (big_endian ? "double" : "float") + " z\nend_header\n";
  for (int f = 0; f < 2; ++f) {
    put<uint8_t>(s, 3);
    for (int k = 0; k < 3; ++k) put<int32_t>(s, k, big_endian);
  }
  for (int i = 0; i < 3; ++i) {
    const double x = 1000.0 * i, y = -500.0 * i, z = 250.0;
    if (big_endian)
      put<double>(s, x, true);
    else
      put<float>(s, static_cast<float>(x));
    put<uint8_t>(s, 200);
    if (big_endian)
      put<double>(s, y, true), put<double>(s, z, true);
    else
      put<float>(s, static_cast<float>(y)), put<float>(s, static_cast<float>(z));
  }
  return s;
}

TEST(PlyPoints, ReadsBinaryBothEndiansAndAsciiInMillimetres) {
  const std::string dir = test::scratch_dir("ply");
  for (bool be : {false, true}) {
    const std::string path = dir + (be ? "/be.ply" : "/le.ply");
    std::ofstream(path, std::ios::binary) << binary_ply(be);
    const auto pts = read_ply_points(path, 1000.0);
    ASSERT_EQ(pts.size(), 3u) << path;
    EXPECT_NEAR(pts[2].x(), 2.0, 1e-9);
    EXPECT_NEAR(pts[2].y(), -1.0, 1e-9);
    EXPECT_NEAR(pts[1].z(), 0.25, 1e-9);
  }
  test::write_text(
      dir + "/a.ply",
      "ply\r\nformat ascii 1.0\r\nelement vertex 2\r\nproperty float x\r\nproperty float y\r\n"
      "property float z\r\nproperty float nx\r\nelement face 1\r\nproperty list uchar int "
      "vertex_indices\r\nend_header\r\n1 2 3 0\r\n4 5 6 1\r\n3 0 1 1\r\n");
  const auto pts = read_model_points(dir + "/a.ply");
  ASSERT_EQ(pts.size(), 2u);
  EXPECT_DOUBLE_EQ(pts[1].y(), 5.0);
}

TEST(PlyPoints, MalformedFilesAreErrors) {
  const std::string dir = test::scratch_dir("ply");
  const std::string good = binary_ply(false);
  std::ofstream(dir + "/trunc.ply", std::ios::binary) << good.substr(0, good.size() - 5);
  test::expect_io_error_naming([&] { read_ply_points(dir + "/trunc.ply"); }, "trunc.ply");
  test::write_text(dir + "/nohdr.ply",
                   "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n");
  test::expect_io_error_naming([&] { read_ply_points(dir + "/nohdr.ply"); }, "nohdr.ply");
  test::write_text(dir + "/noz.ply",
                   "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float "
                   "y\nend_header\n1 2\n");
  test::expect_io_error_naming([&] { read_ply_points(dir + "/noz.ply"); }, "noz.ply");
  test::write_text(
      dir + "/nan.ply",
      "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float "
      "z\nend_header\n1 nan 2\n");
  test::expect_io_error_naming([&] { read_ply_points(dir + "/nan.ply"); }, "nan.ply");
  test::write_text(dir + "/type.ply",
                   "ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n1\n");
  test::expect_io_error_naming([&] { read_ply_points(dir + "/type.ply"); }, "type.ply");
  test::write_text(dir + "/notply.ply", "solid stl\n");
  test::expect_io_error_naming([&] { read_ply_points(dir + "/notply.ply"); }, "notply.ply");
  test::expect_io_error_naming([&] { read_ply_points(dir + "/missing.ply"); }, "missing.ply");
}

PointCloudData sample_cloud(size_t n) {
  PointCloudData c;
  for (size_t i = 0; i < n; ++i) {
    const float t = static_cast<float>(i);
    c.positions_m.emplace_back(0.1f * t, -0.25f * t, 1.0f + 0.001f * t);
    c.normals.push_back(Eigen::Vector3f(t, 1, 2).normalized());
    c.colors.push_back({static_cast<uint8_t>(i), static_cast<uint8_t>(255 - i), 7});
    c.radii_m.push_back(0.002f * (1 + t));
    c.confidences.push_back(0.5f * t);
    c.instance_ids.push_back(static_cast<int32_t>(i % 4));
    c.class_ids.push_back(static_cast<int32_t>(100000 + i));
  }
  return c;
}

TEST(PointCloudPly, FullRoundTripIsExact) {
  const std::string dir = test::scratch_dir("pc");
  const PointCloudData c = sample_cloud(37);
  write_point_cloud_ply(dir + "/c.ply", c);
  const PointCloudData b = read_point_cloud_ply(dir + "/c.ply");
  ASSERT_EQ(b.size(), c.size());
  EXPECT_EQ(b.positions_m, c.positions_m);
  EXPECT_EQ(b.normals, c.normals);
  EXPECT_EQ(b.colors, c.colors);
  EXPECT_EQ(b.radii_m, c.radii_m);
  EXPECT_EQ(b.confidences, c.confidences);
  EXPECT_EQ(b.instance_ids, c.instance_ids);
  EXPECT_EQ(b.class_ids, c.class_ids);
  // Size on disk: header + 37 * (12 + 12 + 3 + 4 + 4 + 4 + 4) bytes.
  std::ifstream is(dir + "/c.ply", std::ios::binary);
  std::string data((std::istreambuf_iterator<char>(is)), std::istreambuf_iterator<char>());
  const size_t header = data.find("end_header\n") + 11;
  EXPECT_EQ(data.size() - header, 37u * 43u);
  EXPECT_NE(data.find("format binary_little_endian 1.0"), std::string::npos);
  // Also readable as plain model points.
  EXPECT_EQ(read_ply_points(dir + "/c.ply").size(), 37u);
}

TEST(PointCloudPly, PositionsOnlyAndEmptyCloud) {
  const std::string dir = test::scratch_dir("pc");
  PointCloudData c;
  c.positions_m = {{1, 2, 3}, {4, 5, 6}};
  write_point_cloud_ply(dir + "/p.ply", c);
  const PointCloudData b = read_point_cloud_ply(dir + "/p.ply");
  EXPECT_EQ(b.positions_m, c.positions_m);
  EXPECT_TRUE(b.normals.empty() && b.colors.empty() && b.instance_ids.empty());
  write_point_cloud_ply(dir + "/e.ply", PointCloudData{});
  EXPECT_EQ(read_point_cloud_ply(dir + "/e.ply").size(), 0u);
}

TEST(PointCloudPly, InvalidCloudThrowsAndLeavesNoFile) {
  const std::string dir = test::scratch_dir("pc");
  PointCloudData c = sample_cloud(5);
  c.radii_m.pop_back();
  test::expect_io_error_naming([&] { write_point_cloud_ply(dir + "/bad.ply", c); }, "bad.ply");
  c = sample_cloud(5);
  c.positions_m[2].y() = std::numeric_limits<float>::quiet_NaN();
  test::expect_io_error_naming([&] { write_point_cloud_ply(dir + "/bad.ply", c); }, "bad.ply");
  EXPECT_TRUE(std::filesystem::is_empty(dir));
}

TEST(PointCloudPly, LabelColoursAreDistinctAndDeterministic) {
  std::set<std::tuple<int, int, int>> seen;
  for (int l = 1; l <= 200; ++l) {
    const Rgb8 c = label_color(l);
    EXPECT_TRUE(seen.insert({c.r, c.g, c.b}).second) << "label " << l << " repeats a colour";
    EXPECT_FALSE(c == label_color(0)) << l;
  }
  EXPECT_EQ(label_color(0), (Rgb8{128, 128, 128}));
  EXPECT_EQ(label_color(-3), label_color(0));
  EXPECT_EQ(label_color(57), label_color(57));

  const PointCloudData c = sample_cloud(8);
  const PointCloudData by_instance = colored_by_labels(c);
  for (size_t i = 0; i < c.size(); ++i)
    EXPECT_EQ(by_instance.colors[i], label_color(c.instance_ids[i]));
  EXPECT_EQ(by_instance.positions_m, c.positions_m);
  const PointCloudData by_class = colored_by_labels(c, LabelKind::kClass);
  EXPECT_EQ(by_class.colors[3], label_color(c.class_ids[3]));
  PointCloudData plain;
  plain.positions_m = {{0, 0, 1}};
  EXPECT_THROW(colored_by_labels(plain), std::invalid_argument);
}

TEST(JsonSummary, NestedKeysArraysRowsAndAtomicWrite) {
  const std::string dir = test::scratch_dir("json");
  JsonSummary s;
  s.set("dataset.frames", 500);
  s.set("dataset.name", "7scenes");
  s.set("timing.tracking_ms", 12.5);
  s.set("timing.bad", std::nan(""));
  s.set("ok", true);
  s.set("big", static_cast<size_t>(1) << 40);
  s.set("ate_m", std::vector<double>{0.1, 0.2});
  s.set_json("config", R"({"dataset": {"stride": 2}})");
  EXPECT_THROW(s.set_json("x", "{oops"), std::invalid_argument);
  JsonSummary row;
  row.set("obj_id", 3);
  s.append("objects", row);
  s.append("objects", row);
  EXPECT_TRUE(s.contains("timing.tracking_ms"));
  EXPECT_FALSE(s.contains("timing.nope"));
  s.write(dir + "/s.json");
  const auto j = nlohmann::json::parse(std::ifstream(dir + "/s.json"));
  EXPECT_EQ(j["dataset"]["frames"], 500);
  EXPECT_EQ(j["dataset"]["name"], "7scenes");
  EXPECT_DOUBLE_EQ(j["timing"]["tracking_ms"].get<double>(), 12.5);
  EXPECT_TRUE(j["timing"]["bad"].is_null());
  EXPECT_EQ(j["ok"], true);
  EXPECT_EQ(j["big"].get<uint64_t>(), uint64_t{1} << 40);
  EXPECT_EQ(j["ate_m"].size(), 2u);
  EXPECT_EQ(j["config"]["dataset"]["stride"], 2);
  EXPECT_EQ(j["objects"].size(), 2u);
  EXPECT_EQ(j["objects"][1]["obj_id"], 3);
  EXPECT_THROW(s.write("/proc/orpe_cannot_write/s.json"), IoError);
}

}  // namespace
}  // namespace orpe
