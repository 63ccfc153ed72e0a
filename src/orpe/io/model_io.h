// Object model point sets (evaluation points and registration targets).
#pragma once

#include <string>
#include <vector>

#include "orpe/core/se3.h"

namespace orpe {

/// Reads an ASCII point file with `x y z` per line (extra columns ignored), e.g. YCB-Video points.xyz.
/// Values are divided by `units_per_m` (YCB: 1, metres already). Throws IoError for a missing file, a
/// malformed line, a non-finite value, or an empty file.
std::vector<Vec3> read_xyz_points(const std::string& path, double units_per_m = 1.0);

}  // namespace orpe
