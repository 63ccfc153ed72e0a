// TUM RGB-D trajectory files: one pose per line, `timestamp tx ty tz qx qy qz qw` (metres; quaternion
// order x, y, z, w), the pose being camera-to-world (T_world_cam). Lines starting with '#' are comments.
#pragma once

#include <string>
#include <vector>

#include "orpe/io/dataset.h"

namespace orpe {

/// Reads a TUM trajectory. Throws IoError naming the file and line for a malformed line, a non-finite
/// value or a quaternion far from unit length (|q| outside [0.9, 1.1]); quaternions are normalised.
std::vector<StampedPose> read_tum_trajectory(const std::string& path);

/// Writes a TUM trajectory atomically (timestamps with 6 decimals, poses with 9 significant digits).
void write_tum_trajectory(const std::string& path, const std::vector<StampedPose>& poses);

}  // namespace orpe
