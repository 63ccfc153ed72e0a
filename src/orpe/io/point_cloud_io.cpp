#include "orpe/io/point_cloud_io.h"

#include <bit>
#include <cmath>
#include <cstring>
#include <ostream>
#include <stdexcept>

#include <fmt/format.h>

#include "orpe/core/atomic_file.h"
#include "orpe/core/error.h"
#include "orpe/core/ply_format.h"

namespace orpe {
namespace {

static_assert(std::endian::native == std::endian::little,
              "PLY writer assumes a little-endian host");

template <class T>
void put(std::string& buf, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  buf.append(bytes, sizeof(T));
}

bool finite(const Eigen::Vector3f& v) {
  return v.allFinite();
}

}  // namespace

bool PointCloudData::IsValid(std::string* why) const {
  auto fail = [&](const std::string& msg) {
    if (why) *why = msg;
    return false;
  };
  const size_t n = size();
  auto check = [&](size_t m, const char* name) {
    return m == 0 || m == n ? true
                            : fail(fmt::format("{} has {} entries for {} points", name, m, n));
  };
  if (!check(normals.size(), "normals") || !check(colors.size(), "colors") ||
      !check(radii_m.size(), "radii_m") || !check(confidences.size(), "confidences") ||
      !check(instance_ids.size(), "instance_ids") || !check(class_ids.size(), "class_ids"))
    return false;
  for (size_t i = 0; i < n; ++i) {
    if (!finite(positions_m[i])) return fail(fmt::format("point {} has a non-finite position", i));
    if (!normals.empty() && !finite(normals[i]))
      return fail(fmt::format("point {} has a non-finite normal", i));
    if (!radii_m.empty() && !std::isfinite(radii_m[i]))
      return fail(fmt::format("point {} has a non-finite radius", i));
    if (!confidences.empty() && !std::isfinite(confidences[i]))
      return fail(fmt::format("point {} has a non-finite confidence", i));
  }
  return true;
}

void write_point_cloud_ply(const std::string& path, const PointCloudData& cloud) {
  std::string why;
  if (!cloud.IsValid(&why)) throw IoError(path, "cannot write point cloud: " + why);
  const size_t n = cloud.size();
  std::string header = "ply\nformat binary_little_endian 1.0\ncomment written by orpe (metres)\n";
  header += fmt::format("element vertex {}\n", n);
  header += "property float x\nproperty float y\nproperty float z\n";
  if (!cloud.normals.empty()) header += "property float nx\nproperty float ny\nproperty float nz\n";
  if (!cloud.colors.empty())
    header += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  if (!cloud.radii_m.empty()) header += "property float radius\n";
  if (!cloud.confidences.empty()) header += "property float confidence\n";
  if (!cloud.instance_ids.empty()) header += "property int instance_id\n";
  if (!cloud.class_ids.empty()) header += "property int class_id\n";
  header += "end_header\n";

  auto encode = [&](size_t i, std::string& body) {
    for (int k = 0; k < 3; ++k) put<float>(body, cloud.positions_m[i][k]);
    if (!cloud.normals.empty())
      for (int k = 0; k < 3; ++k) put<float>(body, cloud.normals[i][k]);
    if (!cloud.colors.empty()) {
      put<uint8_t>(body, cloud.colors[i].r);
      put<uint8_t>(body, cloud.colors[i].g);
      put<uint8_t>(body, cloud.colors[i].b);
    }
    if (!cloud.radii_m.empty()) put<float>(body, cloud.radii_m[i]);
    if (!cloud.confidences.empty()) put<float>(body, cloud.confidences[i]);
    if (!cloud.instance_ids.empty()) put<int32_t>(body, cloud.instance_ids[i]);
    if (!cloud.class_ids.empty()) put<int32_t>(body, cloud.class_ids[i]);
  };
  write_file_atomic(
      path,
      [&](std::ostream& os) {
        os.write(header.data(), static_cast<std::streamsize>(header.size()));
        constexpr size_t kChunk = 1 << 16;  // points per write, bounding the buffer
        std::string body;
        for (size_t start = 0; start < n; start += kChunk) {
          body.clear();
          for (size_t i = start; i < std::min(n, start + kChunk); ++i) encode(i, body);
          os.write(body.data(), static_cast<std::streamsize>(body.size()));
        }
      },
      /*binary=*/true);
}

PointCloudData read_point_cloud_ply(const std::string& path) {
  const detail::PlyColumns v = detail::read_ply_element(path, "vertex");
  for (const char* c : {"x", "y", "z"})
    if (!v.has(c)) throw IoError(path, std::string("PLY vertices have no '") + c + "' property");
  auto col = [&](const char* name) -> const std::vector<double>& { return v.columns.at(name); };
  auto has_all = [&](std::initializer_list<const char*> names) {
    for (const char* name : names)
      if (!v.has(name)) return false;
    return true;
  };
  PointCloudData c;
  const size_t n = v.count;
  auto vec3 = [&](const char* a, const char* b, const char* d, std::vector<Eigen::Vector3f>& out) {
    out.resize(n);
    for (size_t i = 0; i < n; ++i)
      out[i] = Eigen::Vector3f(static_cast<float>(col(a)[i]), static_cast<float>(col(b)[i]),
                               static_cast<float>(col(d)[i]));
  };
  vec3("x", "y", "z", c.positions_m);
  if (has_all({"nx", "ny", "nz"})) vec3("nx", "ny", "nz", c.normals);
  if (has_all({"red", "green", "blue"})) {
    c.colors.resize(n);
    auto u8 = [](double x) { return static_cast<uint8_t>(std::clamp(x, 0.0, 255.0)); };
    for (size_t i = 0; i < n; ++i)
      c.colors[i] = {u8(col("red")[i]), u8(col("green")[i]), u8(col("blue")[i])};
  }
  auto floats = [&](const char* name, std::vector<float>& out) {
    if (!v.has(name)) return;
    out.assign(col(name).begin(), col(name).end());
  };
  auto ints = [&](const char* name, std::vector<int32_t>& out) {
    if (!v.has(name)) return;
    out.resize(n);
    for (size_t i = 0; i < n; ++i) out[i] = static_cast<int32_t>(std::lround(col(name)[i]));
  };
  floats("radius", c.radii_m);
  floats("confidence", c.confidences);
  ints("instance_id", c.instance_ids);
  ints("class_id", c.class_ids);
  std::string why;
  if (!c.IsValid(&why)) throw IoError(path, why);
  return c;
}

Rgb8 label_color(int label) {
  // Well-separated colours (Kelly / Tableau-like), none grey, so background stays distinguishable.
  static const Rgb8 kTable[] = {{230, 25, 75},  {60, 180, 75},   {255, 225, 25}, {0, 130, 200},
                                {245, 130, 48}, {145, 30, 180},  {70, 240, 240}, {240, 50, 230},
                                {210, 245, 60}, {250, 190, 212}, {0, 128, 128},  {220, 190, 255},
                                {170, 110, 40}, {255, 250, 200}, {128, 0, 0},    {170, 255, 195},
                                {128, 128, 0},  {255, 215, 180}, {0, 0, 128},    {255, 0, 0},
                                {0, 255, 0},    {0, 0, 255},     {255, 0, 255},  {0, 255, 255}};
  constexpr int kTableSize = static_cast<int>(sizeof(kTable) / sizeof(kTable[0]));
  if (label <= 0) return {128, 128, 128};
  if (label <= kTableSize) return kTable[label - 1];
  // HSV with hue stepping by the golden ratio (s = 0.8, v = 0.95).
  const double h = std::fmod(label * 0.6180339887498949, 1.0) * 6.0;
  const double s = 0.8, val = 0.95;
  const int sector = static_cast<int>(h) % 6;
  const double f = h - std::floor(h);
  const double p = val * (1 - s), q = val * (1 - s * f), t = val * (1 - s * (1 - f));
  double r = 0, g = 0, b = 0;
  switch (sector) {
    case 0:
      r = val, g = t, b = p;
      break;
    case 1:
      r = q, g = val, b = p;
      break;
    case 2:
      r = p, g = val, b = t;
      break;
    case 3:
      r = p, g = q, b = val;
      break;
    case 4:
      r = t, g = p, b = val;
      break;
    default:
      r = val, g = p, b = q;
      break;
  }
  auto u8 = [](double x) { return static_cast<uint8_t>(std::lround(x * 255.0)); };
  return {u8(r), u8(g), u8(b)};
}

PointCloudData colored_by_labels(const PointCloudData& cloud, LabelKind kind) {
  const auto& ids = kind == LabelKind::kInstance ? cloud.instance_ids : cloud.class_ids;
  if (ids.size() != cloud.size())
    throw std::invalid_argument(kind == LabelKind::kInstance
                                    ? "colored_by_labels: cloud has no instance ids"
                                    : "colored_by_labels: cloud has no class ids");
  PointCloudData out = cloud;
  out.colors.resize(cloud.size());
  for (size_t i = 0; i < cloud.size(); ++i) out.colors[i] = label_color(ids[i]);
  return out;
}

}  // namespace orpe
