#include "orpe/io/trajectory_io.h"

#include <cmath>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "orpe/core/atomic_file.h"
#include "orpe/core/error.h"
#include "orpe/core/text_lines.h"

namespace orpe {

std::vector<StampedPose> read_tum_trajectory(const std::string& path) {
  std::vector<StampedPose> poses;
  for_each_data_line(path, "trajectory file", [&](int line_no, const std::string& line) {
    std::istringstream ls(line);
    double v[8];
    for (double& x : v) ls >> x;
    if (ls.fail()) throw IoError(path, fmt::format("line {}: expected 8 numbers 'timestamp tx ty tz qx qy qz qw'", line_no));
    std::string extra;
    if (ls >> extra)
      throw IoError(path, fmt::format("line {}: '{}' after the 8 numbers 'timestamp tx ty tz qx qy qz qw'", line_no, extra));
    for (double x : v)
      if (!std::isfinite(x)) throw IoError(path, fmt::format("line {}: non-finite value", line_no));
    Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);  // Eigen: (w, x, y, z)
    const double n = q.norm();
    if (n < 0.9 || n > 1.1)
      throw IoError(path, fmt::format("line {}: quaternion norm {:.3f} is not ~1 (order must be qx qy qz qw)", line_no, n));
    // Poses are matched by time: a repeated or decreasing timestamp would pair poses with the wrong ones.
    if (!poses.empty() && !(v[0] > poses.back().timestamp_s))
      throw IoError(path, fmt::format("line {}: timestamp {:.6f} is not after the previous one ({:.6f}); "
                                      "timestamps must increase", line_no, v[0], poses.back().timestamp_s));
    poses.push_back({v[0], SE3(q.normalized(), Vec3(v[1], v[2], v[3]))});
  });
  return poses;
}

void write_tum_trajectory(const std::string& path, const std::vector<StampedPose>& poses) {
  write_file_atomic(path, [&](std::ostream& os) {
    os << "# timestamp tx ty tz qx qy qz qw (T_world_cam, metres)\n";
    for (const auto& p : poses) {
      const Eigen::Quaterniond q = p.T_world_cam.quaternion();
      const Vec3& t = p.T_world_cam.translation();
      os << fmt::format("{:.6f} {:.9g} {:.9g} {:.9g} {:.9g} {:.9g} {:.9g} {:.9g}\n", p.timestamp_s, t.x(),
                        t.y(), t.z(), q.x(), q.y(), q.z(), q.w());
    }
  });
}

}  // namespace orpe
