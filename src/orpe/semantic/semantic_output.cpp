#include "orpe/semantic/semantic_output.h"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <ostream>

#include "orpe/core/atomic_file.h"

namespace orpe {
namespace {

template <class T>
void put(std::ostream& os, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));  // x86-64 and aarch64 are little-endian, as the header says
  os.write(bytes, sizeof(T));
}

}  // namespace

Rgb8 instance_color(int instance_id) {
  if (instance_id <= 0) return {128, 128, 128};
  // Golden-ratio hue steps, full saturation, two brightness levels alternating.
  const double h = std::fmod(instance_id * 0.618033988749895, 1.0) * 6.0;
  const double value = instance_id % 2 ? 1.0 : 0.75;
  const int sector = static_cast<int>(h);
  const double f = h - sector;
  const double p = 0, q = value * (1 - f), t = value * f;
  double r = 0, g = 0, b = 0;
  switch (sector % 6) {
    case 0: r = value, g = t, b = p; break;
    case 1: r = q, g = value, b = p; break;
    case 2: r = p, g = value, b = t; break;
    case 3: r = p, g = q, b = value; break;
    case 4: r = t, g = p, b = value; break;
    default: r = value, g = p, b = q; break;
  }
  auto c = [](double x) { return static_cast<std::uint8_t>(std::lround(std::clamp(x, 0.0, 1.0) * 255)); };
  return {c(r), c(g), c(b)};
}

void write_semantic_map_ply(const std::string& path, const slam::SurfelMap& map,
                            const std::map<int, InstanceInfo>& instances, bool color_by_instance,
                            float min_confidence) {
  std::map<int, int> class_of;
  for (const auto& [id, info] : instances) class_of[id] = info.argmax_class();
  size_t count = 0;
  for (size_t i = 0; i < map.size(); ++i) count += map.confidence[i] >= min_confidence;
  write_file_atomic(
      path,
      [&](std::ostream& os) {
        os << "ply\nformat binary_little_endian 1.0\ncomment orpe semantic map (metres, world frame)\n"
           << "element vertex " << count << "\n"
           << "property float x\nproperty float y\nproperty float z\n"
           << "property float nx\nproperty float ny\nproperty float nz\n"
           << "property uchar red\nproperty uchar green\nproperty uchar blue\n"
           << "property int instance\nproperty int class\nend_header\n";
        for (size_t i = 0; i < map.size(); ++i) {
          if (map.confidence[i] < min_confidence) continue;
          const auto& p = map.position_world[i];
          const auto& n = map.normal_world[i];
          for (int k = 0; k < 3; ++k) put<float>(os, p[k]);
          for (int k = 0; k < 3; ++k) put<float>(os, n[k]);
          const int id = map.instance_id[i];
          const auto cls = class_of.find(id);
          const Rgb8 rgb = color_by_instance ? instance_color(id) : map.color[i];
          put<std::uint8_t>(os, rgb.r);
          put<std::uint8_t>(os, rgb.g);
          put<std::uint8_t>(os, rgb.b);
          put<std::int32_t>(os, id);
          put<std::int32_t>(os, cls == class_of.end() ? 0 : cls->second);
        }
      },
      true);
}

void write_instances_json(const std::string& path, const slam::SurfelMap& map,
                          const std::map<int, InstanceInfo>& instances,
                          const std::map<int, std::string>& class_names) {
  const auto geometry = instance_geometry(map);
  auto name_of = [&](int c) {
    const auto it = class_names.find(c);
    return it == class_names.end() ? std::string() : it->second;
  };
  nlohmann::json j;
  j["instances"] = nlohmann::json::array();
  for (const auto& [id, info] : instances) {
    nlohmann::json ji;
    ji["id"] = id;
    ji["class_id"] = info.argmax_class();
    ji["class_name"] = name_of(info.argmax_class());
    ji["class_probability"] = info.argmax_probability();
    nlohmann::json dist = nlohmann::json::array();
    for (const auto& [c, p] : info.class_distribution())
      dist.push_back({{"class_id", c}, {"class_name", name_of(c)}, {"probability", p}});
    ji["class_distribution"] = dist;
    ji["detections"] = info.detections;
    ji["visible_keyframes"] = info.visible_keyframes;
    ji["first_frame"] = info.first_frame;
    ji["last_frame"] = info.last_frame;
    const auto g = geometry.find(id);
    ji["surfels"] = g == geometry.end() ? 0 : g->second.surfels;
    if (g != geometry.end()) {
      ji["bbox_min_world_m"] = {g->second.min_world.x(), g->second.min_world.y(), g->second.min_world.z()};
      ji["bbox_max_world_m"] = {g->second.max_world.x(), g->second.max_world.y(), g->second.max_world.z()};
    } else {
      ji["bbox_min_world_m"] = nullptr;
      ji["bbox_max_world_m"] = nullptr;
    }
    j["instances"].push_back(ji);
  }
  write_file_atomic(path, [&](std::ostream& os) { os << j.dump(2) << "\n"; });
}

void write_semantic_outputs(const std::string& dir, const slam::SurfelMap& map,
                            const std::map<int, InstanceInfo>& instances,
                            const std::map<int, std::string>& class_names, float min_confidence) {
  const std::filesystem::path d(dir);
  write_semantic_map_ply((d / "semantic_map.ply").string(), map, instances, false, min_confidence);
  write_semantic_map_ply((d / "semantic_map_instances.ply").string(), map, instances, true, min_confidence);
  write_instances_json((d / "instances.json").string(), map, instances, class_names);
}

ColorImage colorize_instances(const LabelImage& labels) {
  ColorImage out(labels.width(), labels.height());
  for (size_t i = 0; i < labels.size(); ++i) out[i] = labels[i] > 0 ? instance_color(labels[i]) : Rgb8{};
  return out;
}

}  // namespace orpe
