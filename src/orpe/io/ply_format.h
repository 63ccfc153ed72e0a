// Minimal PLY reading shared by read_ply_points (model_io.h) and read_point_cloud_ply
// (point_cloud_io.h): ascii, binary_little_endian and binary_big_endian; the scalar properties of
// one element are returned as columns of doubles, list properties (faces) are skipped. Internal to
// io.
#pragma once

#include <map>
#include <string>
#include <vector>

namespace orpe::detail {

struct PlyColumns {
  size_t count = 0;                                    ///< number of records of the element
  std::map<std::string, std::vector<double>> columns;  ///< scalar property name -> values
  bool has(const std::string& name) const { return columns.count(name) > 0; }
};

/// Reads the scalar properties of element `element` (e.g. "vertex"). Throws IoError naming the file
/// for a missing file, a malformed header, an unknown type, or a body shorter than the header says.
PlyColumns read_ply_element(const std::string& path, const std::string& element);

}  // namespace orpe::detail
