// Object model point sets (evaluation points and registration targets).
#pragma once

#include <string>
#include <vector>

#include "orpe/core/se3.h"

namespace orpe {

/// Reads an ASCII point file with `x y z` per line (extra columns ignored), e.g. YCB-Video
/// points.xyz. Values are divided by `units_per_m` (YCB: 1, metres already). Throws IoError for a
/// missing file, a malformed line, a non-finite value, or an empty file.
std::vector<Vec3> read_xyz_points(const std::string& path, double units_per_m = 1.0);

/// Reads the vertices (x, y, z) of a PLY file (ascii, binary little- or big-endian; any numeric
/// type; other properties and elements such as faces are skipped), e.g. a BOP model obj_XXXXXX.ply
/// in millimetres (units_per_m = 1000). Throws IoError for a missing or malformed file, a body
/// shorter than its header, missing x/y/z, a non-finite coordinate, or no vertices.
std::vector<Vec3> read_ply_points(const std::string& path, double units_per_m = 1.0);

/// By extension: .ply read_ply_points, .xyz / .txt read_xyz_points, any other mesh format (.obj,
/// .stl, .gltf, ...) the vertices of load_mesh (render/mesh_io.h).
std::vector<Vec3> read_model_points(const std::string& path, double units_per_m = 1.0);

}  // namespace orpe
