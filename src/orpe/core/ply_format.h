// The point-cloud PLY reader (orpe's one reader for point clouds; meshes go through assimp in
// render/mesh_io): ascii, binary_little_endian and binary_big_endian; the scalar properties of one
// element are returned as columns of doubles, list properties (faces) are skipped. Used by
// read_ply_points (io/model_io.h), read_point_cloud_ply (io/point_cloud_io.h), and by
// render/mesh_io to check a PLY mesh's structure before assimp reads it (assimp accepts a body
// shorter than its header and loops on a header without end_header).
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
/// for a missing file, a malformed header, an unknown type, a record count the body cannot hold, or
/// a body shorter than the header says.
PlyColumns read_ply_element(const std::string& path, const std::string& element);

/// Walks the whole file (every element, lists included) and throws IoError as read_ply_element
/// does when the header and the body do not agree.
void check_ply_structure(const std::string& path);

}  // namespace orpe::detail
