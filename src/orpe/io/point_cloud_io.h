// Point clouds and surfel maps as PLY files, for viewers (MeshLab, CloudCompare, Open3D) and for
// round-trips in tests. Plain struct-of-arrays input: no dependency on the SLAM map type.
//
// Written PLY (binary_little_endian), per vertex, in this order, each group only when present:
//   float x y z (metres) | float nx ny nz | uchar red green blue | float radius (metres)
//   | float confidence | int instance_id | int class_id
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "orpe/core/image.h"

namespace orpe {

struct PointCloudData {
  std::vector<Eigen::Vector3f> positions_m;  ///< required
  // Optional attributes: empty, or one value per position.
  std::vector<Eigen::Vector3f> normals;  ///< unit normals
  std::vector<Rgb8> colors;
  std::vector<float> radii_m;              ///< surfel radius
  std::vector<float> confidences;          ///< surfel confidence (dimensionless)
  std::vector<std::int32_t> instance_ids;  ///< 0 = none
  std::vector<std::int32_t> class_ids;     ///< 0 = none

  size_t size() const { return positions_m.size(); }
  /// Every optional attribute is empty or has size() entries; positions (and normals, radii,
  /// confidences) are finite.
  bool IsValid(std::string* why) const;
};

/// Writes `cloud` atomically as binary little-endian PLY. Throws IoError (naming `path`) when the
/// cloud is not IsValid() or the file cannot be written; never leaves a partial file.
void write_point_cloud_ply(const std::string& path, const PointCloudData& cloud);

/// Reads a PLY written by write_point_cloud_ply, or any PLY with vertex x, y, z (ascii or binary),
/// picking up the optional attributes above by their property names. Throws IoError naming the
/// file.
PointCloudData read_point_cloud_ply(const std::string& path);

/// A fixed palette of well-separated colours: label <= 0 -> grey (128, 128, 128); labels 1..24 from
/// a hand-picked table; larger labels by golden-ratio hue steps. Deterministic.
Rgb8 label_color(int label);

/// Which labels colour_by_labels uses.
enum class LabelKind { kInstance, kClass };

/// A copy of `cloud` whose colours encode its instance (or class) ids with label_color(), so that a
/// plain viewer shows the segmentation. Throws std::invalid_argument when those ids are absent.
PointCloudData colored_by_labels(const PointCloudData& cloud,
                                 LabelKind kind = LabelKind::kInstance);

}  // namespace orpe
