// Files of the semantic stage. All writers are atomic (temp file + rename) and create folders.
//
//  semantic_map.ply            per surfel (io's point-cloud PLY, binary little-endian): x y z (m,
//  world),
//                              nx ny nz, red green blue (surfel colour), radius (m), confidence,
//                              instance_id (0 = background), class_id (the instance's argmax class)
//  semantic_map_instances.ply  the same surfels coloured by instance (io's label_color), for
//  viewing instances.json              per instance: class distribution, argmax class, detections,
//  surfel
//                              count, world bounding box, first/last frame detected
#pragma once

#include <map>
#include <string>

#include "orpe/semantic/semantic_fusion.h"

namespace orpe {

/// Writes the surfels with confidence >= min_confidence as a binary little-endian PLY (io's
/// write_point_cloud_ply). `color_by_instance` replaces the surfel colour by label_color(instance).
/// Throws IoError.
void write_semantic_map_ply(const std::string& path, const slam::SurfelMap& map,
                            const std::map<int, InstanceInfo>& instances, bool color_by_instance,
                            float min_confidence = 0.0f);

/// Writes instances.json. `class_names` (class id -> name, e.g. DatasetInfo::class_names) may be
/// empty.
void write_instances_json(const std::string& path, const slam::SurfelMap& map,
                          const std::map<int, InstanceInfo>& instances,
                          const std::map<int, std::string>& class_names = {});

/// The three files above into `dir`.
void write_semantic_outputs(const std::string& dir, const slam::SurfelMap& map,
                            const std::map<int, InstanceInfo>& instances,
                            const std::map<int, std::string>& class_names = {},
                            float min_confidence = 0.0f);

/// Colour-coded instance label image (io's label_color; for looking at masks).
ColorImage colorize_instances(const LabelImage& labels);

}  // namespace orpe
