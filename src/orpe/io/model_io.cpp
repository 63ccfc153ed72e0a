#include "orpe/io/model_io.h"

#include <cmath>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "orpe/core/error.h"

namespace orpe {

std::vector<Vec3> read_xyz_points(const std::string& path, double units_per_m) {
  if (!(units_per_m > 0)) throw IoError(path, "units_per_m must be positive");
  std::ifstream is(path);
  if (!is) throw IoError(path, "cannot open point file");
  std::vector<Vec3> pts;
  std::string line;
  int line_no = 0;
  while (std::getline(is, line)) {
    ++line_no;
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream ls(line);
    double x, y, z;
    if (!(ls >> x >> y >> z)) throw IoError(path, fmt::format("line {}: expected 'x y z'", line_no));
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
      throw IoError(path, fmt::format("line {}: non-finite coordinate", line_no));
    pts.emplace_back(x / units_per_m, y / units_per_m, z / units_per_m);
  }
  if (pts.empty()) throw IoError(path, "no points");
  return pts;
}

}  // namespace orpe
