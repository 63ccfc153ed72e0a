#include "orpe/semantic/semantic_output.h"

#include <fmt/format.h>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <ostream>

#include "orpe/core/atomic_file.h"
#include "orpe/io/point_cloud_io.h"
#include "orpe/slam/map_io.h"

namespace orpe {

void write_semantic_map_ply(const std::string& path, const slam::SurfelMap& map,
                            const std::map<int, InstanceInfo>& instances, bool color_by_instance,
                            float min_confidence) {
  std::map<int, int> class_of;
  for (const auto& [id, info] : instances) class_of[id] = info.argmax_class();
  PointCloudData cloud = slam::surfel_map_cloud(map, min_confidence);
  cloud.class_ids.reserve(cloud.size());
  for (const std::int32_t id : cloud.instance_ids) {
    const auto cls = class_of.find(id);
    cloud.class_ids.push_back(cls == class_of.end() ? 0 : cls->second);
  }
  write_point_cloud_ply(path,
                        color_by_instance ? colored_by_labels(cloud, LabelKind::kInstance) : cloud);
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
    ji["missed_keyframes"] = info.missed_keyframes;
    if (info.height_above_support_m >= 0)
      ji["height_above_support_m"] = info.height_above_support_m;
    ji["first_frame"] = info.first_frame;
    ji["last_frame"] = info.last_frame;
    const auto g = geometry.find(id);
    ji["surfels"] = g == geometry.end() ? 0 : g->second.surfels;
    if (g != geometry.end()) {
      ji["bbox_min_world_m"] = {g->second.min_world.x(), g->second.min_world.y(),
                                g->second.min_world.z()};
      ji["bbox_max_world_m"] = {g->second.max_world.x(), g->second.max_world.y(),
                                g->second.max_world.z()};
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
  write_semantic_map_ply((d / "semantic_map_instances.ply").string(), map, instances, true,
                         min_confidence);
  write_instances_json((d / "instances.json").string(), map, instances, class_names);
}

ColorImage colorize_instances(const LabelImage& labels) {
  ColorImage out(labels.width(), labels.height());
  for (size_t i = 0; i < labels.size(); ++i)
    out[i] = labels[i] > 0 ? label_color(labels[i]) : Rgb8{};
  return out;
}

}  // namespace orpe
