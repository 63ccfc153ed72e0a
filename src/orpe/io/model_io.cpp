#include "orpe/io/model_io.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "orpe/core/error.h"
#include "orpe/core/text_lines.h"
#include "orpe/core/ply_format.h"
#include "orpe/render/mesh_io.h"

namespace orpe {

std::vector<Vec3> read_xyz_points(const std::string& path, double units_per_m) {
  if (!(units_per_m > 0)) throw IoError(path, "units_per_m must be positive");
  std::vector<Vec3> pts;
  for_each_data_line(path, "point file", [&](int line_no, const std::string& line) {
    std::istringstream ls(line);
    double x, y, z;
    if (!(ls >> x >> y >> z))
      throw IoError(path, fmt::format("line {}: expected 'x y z'", line_no));
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
      throw IoError(path, fmt::format("line {}: non-finite coordinate", line_no));
    pts.emplace_back(x / units_per_m, y / units_per_m, z / units_per_m);
  });
  if (pts.empty()) throw IoError(path, "no points");
  return pts;
}

std::vector<Vec3> read_ply_points(const std::string& path, double units_per_m) {
  if (!(units_per_m > 0)) throw IoError(path, "units_per_m must be positive");
  const detail::PlyColumns vertex = detail::read_ply_element(path, "vertex");
  for (const char* c : {"x", "y", "z"})
    if (!vertex.has(c))
      throw IoError(path, std::string("PLY vertices have no '") + c + "' property");
  if (vertex.count == 0) throw IoError(path, "no points (PLY has 0 vertices)");
  const auto& x = vertex.columns.at("x");
  const auto& y = vertex.columns.at("y");
  const auto& z = vertex.columns.at("z");
  std::vector<Vec3> pts(vertex.count);
  for (size_t i = 0; i < vertex.count; ++i) {
    pts[i] = Vec3(x[i], y[i], z[i]) / units_per_m;
    if (!pts[i].allFinite())
      throw IoError(path, fmt::format("vertex {}: non-finite coordinate", i));
  }
  return pts;
}

std::vector<Vec3> read_model_points(const std::string& path, double units_per_m) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext == ".ply") return read_ply_points(path, units_per_m);
  if (ext == ".xyz" || ext == ".txt") return read_xyz_points(path, units_per_m);
  // Any other mesh (a models folder's OBJ, STL, glTF ...): its vertices.
  MeshLoadOptions opt;
  opt.metres_per_unit = 1.0 / units_per_m;
  opt.load_texture = false;
  const TriangleMesh mesh = load_mesh(path, opt);
  std::vector<Vec3> pts;
  pts.reserve(mesh.vertices.size());
  for (const auto& v : mesh.vertices) pts.push_back(v.cast<double>());
  return pts;
}

}  // namespace orpe
