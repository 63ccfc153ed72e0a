#include "orpe/io/bop_results.h"

#include <cmath>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "orpe/core/atomic_file.h"
#include "orpe/core/error.h"
#include "orpe/core/parse_number.h"

namespace orpe {
namespace {

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::string cur;
  std::istringstream is(s);
  while (std::getline(is, cur, sep)) out.push_back(cur);
  if (!s.empty() && s.back() == sep) out.emplace_back();
  return out;
}

std::vector<double> numbers(const std::string& s, const std::string& path, int line_no,
                            const char* what) {
  std::istringstream is(s);
  std::vector<double> v;
  double x;
  while (is >> x) v.push_back(x);
  if (!is.eof()) throw IoError(path, fmt::format("line {}: bad number in {}", line_no, what));
  for (double y : v)
    if (!std::isfinite(y))
      throw IoError(path, fmt::format("line {}: non-finite value in {}", line_no, what));
  return v;
}

}  // namespace

void write_bop_results(const std::string& path, const std::vector<PoseResultRow>& rows) {
  write_file_atomic(path, [&](std::ostream& os) {
    os << "scene_id,im_id,obj_id,score,R,t,time\n";
    for (const auto& r : rows) {
      const Mat3& R = r.T_cam_obj.rotation();
      const Vec3 t_mm = r.T_cam_obj.translation() * 1000.0;
      os << fmt::format("{},{},{},{:.6g},", r.scene_id, r.im_id, r.obj_id, r.score);
      for (int i = 0; i < 9; ++i) os << fmt::format("{}{:.9g}", i ? " " : "", R(i / 3, i % 3));
      os << fmt::format(",{:.6f} {:.6f} {:.6f},{:.6g}\n", t_mm.x(), t_mm.y(), t_mm.z(), r.time_s);
    }
  });
}

std::vector<PoseResultRow> read_bop_results(const std::string& path) {
  std::ifstream is(path);
  if (!is) throw IoError(path, "cannot open results file");
  std::vector<PoseResultRow> rows;
  std::string line;
  int line_no = 0;
  while (std::getline(is, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    if (line_no == 1 && line.rfind("scene_id", 0) == 0) continue;
    const auto f = split(line, ',');
    if (f.size() != 7)
      throw IoError(path, fmt::format("line {}: expected 7 comma-separated fields "
                                      "scene_id,im_id,obj_id,score,R,t,time, got {}",
                                      line_no, f.size()));
    PoseResultRow r;
    auto where = [&](const char* field) {
      return fmt::format("line {}, field {}", line_no, field);
    };
    r.scene_id = parse_int_field(f[0], path, where("scene_id"), 0);
    r.im_id = parse_int_field(f[1], path, where("im_id"), 0);
    r.obj_id = parse_int_field(f[2], path, where("obj_id"), 0);
    // A NaN score would sort anywhere and vote in any fusion: refused like any non-number.
    r.score = parse_finite_field(f[3], path, where("score"));
    r.time_s = parse_finite_field(f[6], path, where("time"));
    const auto R = numbers(f[4], path, line_no, "R");
    const auto t = numbers(f[5], path, line_no, "t");
    if (R.size() != 9)
      throw IoError(path, fmt::format("line {}: R needs 9 values, got {}", line_no, R.size()));
    if (t.size() != 3)
      throw IoError(path, fmt::format("line {}: t needs 3 values, got {}", line_no, t.size()));
    Mat3 Rm;
    for (int i = 0; i < 9; ++i) Rm(i / 3, i % 3) = R[i];
    if ((Rm * Rm.transpose() - Mat3::Identity()).norm() > 1e-3 || Rm.determinant() < 0)
      throw IoError(path, fmt::format("line {}: R is not a rotation matrix", line_no));
    r.T_cam_obj = SE3(orthonormalize(Rm), Vec3(t[0], t[1], t[2]) / 1000.0);
    rows.push_back(r);
  }
  return rows;
}

}  // namespace orpe
