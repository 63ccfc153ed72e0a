#include "orpe/render/mesh_io.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <unordered_map>

#include "orpe/core/atomic_file.h"
#include "orpe/core/error.h"

namespace orpe {
namespace fs = std::filesystem;
namespace {

std::string read_whole_file(const std::string& path) {
  if (!fs::exists(path)) throw IoError(path, "file not found");
  if (fs::is_directory(path)) throw IoError(path, "is a folder, expected a mesh file");
  std::ifstream is(path, std::ios::binary);
  if (!is) throw IoError(path, "cannot open for reading");
  std::ostringstream ss;
  ss << is.rdbuf();
  if (is.bad()) throw IoError(path, "read error");
  return ss.str();
}

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

/// Reads an 8-bit texture as RGB8 (OpenCV is BGR). Returns nullptr (with a warning) when
/// unreadable.
std::shared_ptr<const ColorImage> load_texture_image(const std::string& path,
                                                     const std::string& mesh_path,
                                                     bool warn_missing) {
  if (!fs::exists(path)) {
    if (warn_missing)
      spdlog::warn("{}: texture '{}' not found; rendering without texture", mesh_path, path);
    return nullptr;
  }
  cv::Mat m;
  try {
    m = cv::imread(path, cv::IMREAD_COLOR);
  } catch (const cv::Exception&) {
  }
  if (m.empty() || m.depth() != CV_8U) {
    spdlog::warn("{}: texture '{}' cannot be decoded; rendering without texture", mesh_path, path);
    return nullptr;
  }
  auto tex = std::make_shared<ColorImage>(m.cols, m.rows);
  for (int v = 0; v < m.rows; ++v) {
    const cv::Vec3b* row = m.ptr<cv::Vec3b>(v);
    Rgb8* out = tex->row(v);
    for (int u = 0; u < m.cols; ++u) out[u] = {row[u][2], row[u][1], row[u][0]};
  }
  return tex;
}

void finish_mesh(TriangleMesh& mesh, const std::string& path) {
  if (mesh.normals.empty()) mesh.compute_vertex_normals();
  for (auto& n : mesh.normals) {
    const float len = n.norm();
    n = len > 0 && std::isfinite(len) ? Eigen::Vector3f(n / len) : Eigen::Vector3f::UnitZ();
  }
  std::string why;
  if (!mesh.IsValid(&why)) throw IoError(path, "invalid mesh: " + why);
  if (mesh.triangles.empty()) throw IoError(path, "mesh has no faces");
}

// ---------------------------------------------------------------------------------------------
// OBJ

/// Splits a text into lines without copying; tracks line numbers for messages.
struct LineReader {
  std::string_view text;
  size_t pos = 0;
  int line_no = 0;
  bool next(std::string_view& line) {
    if (pos >= text.size()) return false;
    size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    line = text.substr(pos, end - pos);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    pos = end + 1;
    ++line_no;
    return true;
  }
};

void split_ws(std::string_view s, std::vector<std::string_view>& out) {
  out.clear();
  size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && (s[i] == ' ' || s[i] == '\t')) ++i;
    size_t j = i;
    while (j < s.size() && s[j] != ' ' && s[j] != '\t') ++j;
    if (j > i) out.push_back(s.substr(i, j - i));
    i = j;
  }
}

bool parse_double(std::string_view s, double& out) {
  const char* end = s.data() + s.size();
  auto r = std::from_chars(s.data(), end, out);
  return r.ec == std::errc() && r.ptr == end && std::isfinite(out);
}

bool parse_int(std::string_view s, long& out) {
  const char* end = s.data() + s.size();
  auto r = std::from_chars(s.data(), end, out);
  return r.ec == std::errc() && r.ptr == end;
}

struct ObjMaterial {
  Eigen::Vector3f kd{1, 1, 1};
  std::string texture_path;
};

std::map<std::string, ObjMaterial> parse_mtl(const std::string& path) {
  std::map<std::string, ObjMaterial> mats;
  std::string text;
  try {
    text = read_whole_file(path);
  } catch (const IoError& e) {
    spdlog::warn("{} (material library ignored)", e.what());
    return mats;
  }
  LineReader lr{text};
  std::string_view line;
  std::vector<std::string_view> tok;
  ObjMaterial* cur = nullptr;
  while (lr.next(line)) {
    split_ws(line, tok);
    if (tok.empty() || tok[0][0] == '#') continue;
    if (tok[0] == "newmtl" && tok.size() >= 2) {
      cur = &mats[std::string(tok[1])];
    } else if (cur && tok[0] == "Kd" && tok.size() >= 4) {
      double r, g, b;
      if (!parse_double(tok[1], r) || !parse_double(tok[2], g) || !parse_double(tok[3], b))
        throw IoError(path, "line " + std::to_string(lr.line_no) + ": malformed Kd");
      cur->kd =
          Eigen::Vector3f(static_cast<float>(r), static_cast<float>(g), static_cast<float>(b));
    } else if (cur && tok[0] == "map_Kd" && tok.size() >= 2) {
      // Options (-s, -o, ...) precede the file name; the file name is the last token.
      cur->texture_path = (fs::path(path).parent_path() / std::string(tok.back())).string();
    }
  }
  return mats;
}

}  // namespace

TriangleMesh load_obj(const std::string& path, const MeshLoadOptions& options) {
  const std::string text = read_whole_file(path);
  const float scale = static_cast<float>(options.metres_per_unit);
  std::vector<Eigen::Vector3f> pos, nrm;
  std::vector<Eigen::Vector2f> tex;
  std::vector<Rgb8> vcol;
  bool any_vcol = false;
  std::map<std::string, ObjMaterial> materials;
  std::string current_material;
  std::string texture_material;  // the material whose texture the mesh uses

  TriangleMesh mesh;
  mesh.name = path;
  // (v, vt, vn) -> output vertex
  std::unordered_map<std::uint64_t, int> corner_index;
  struct Corner {
    long v, t, n;
  };
  std::vector<Corner> corners;
  std::vector<Eigen::Vector3i> tris;
  std::vector<std::string> tri_material;
  std::vector<Corner> poly;
  bool any_uv = false, any_normal = false;

  LineReader lr{text};
  std::string_view line;
  std::vector<std::string_view> tok;
  auto fail = [&](const std::string& what) {
    throw IoError(path, "line " + std::to_string(lr.line_no) + ": " + what);
  };
  std::vector<int> face_material_flags;
  while (lr.next(line)) {
    split_ws(line, tok);
    if (tok.empty() || tok[0][0] == '#') continue;
    const std::string_view kw = tok[0];
    if (kw == "v") {
      if (tok.size() != 4 && tok.size() != 5 && tok.size() != 7)
        fail("'v' needs 3 coordinates (or 3 + rgb)");
      double x = 0, y = 0, z = 0;
      if (!parse_double(tok[1], x) || !parse_double(tok[2], y) || !parse_double(tok[3], z))
        fail("malformed vertex coordinate");
      pos.emplace_back(static_cast<float>(x) * scale, static_cast<float>(y) * scale,
                       static_cast<float>(z) * scale);
      Rgb8 c{255, 255, 255};
      if (tok.size() == 7) {
        double r = 0, g = 0, b = 0;
        if (!parse_double(tok[4], r) || !parse_double(tok[5], g) || !parse_double(tok[6], b))
          fail("malformed vertex colour");
        auto q = [](double c01) {
          return static_cast<std::uint8_t>(std::clamp(c01, 0.0, 1.0) * 255.0 + 0.5);
        };
        c = {q(r), q(g), q(b)};
        any_vcol = true;
      }
      vcol.push_back(c);
    } else if (kw == "vt") {
      if (tok.size() < 3) fail("'vt' needs 2 coordinates");
      double u = 0, v = 0;
      if (!parse_double(tok[1], u) || !parse_double(tok[2], v))
        fail("malformed texture coordinate");
      tex.emplace_back(static_cast<float>(u), static_cast<float>(v));
    } else if (kw == "vn") {
      if (tok.size() != 4) fail("'vn' needs 3 coordinates");
      double x = 0, y = 0, z = 0;
      if (!parse_double(tok[1], x) || !parse_double(tok[2], y) || !parse_double(tok[3], z))
        fail("malformed normal");
      nrm.emplace_back(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z));
    } else if (kw == "f") {
      if (tok.size() < 4) fail("a face needs at least 3 vertices");
      poly.clear();
      for (size_t k = 1; k < tok.size(); ++k) {
        std::string_view s = tok[k];
        long idx[3] = {0, 0, 0};
        int field = 0;
        size_t start = 0;
        for (size_t i = 0; i <= s.size(); ++i) {
          if (i == s.size() || s[i] == '/') {
            if (field > 2) fail("malformed face vertex '" + std::string(s) + "'");
            std::string_view part = s.substr(start, i - start);
            if (!part.empty() && !parse_int(part, idx[field]))
              fail("malformed face index '" + std::string(s) + "'");
            if (part.empty() && field == 0) fail("face vertex without position index");
            ++field;
            start = i + 1;
          }
        }
        // Resolve 1-based and negative (relative) indices; 0 = absent (for vt, vn).
        auto resolve = [&](long i, size_t n, const char* what) -> long {
          if (i > 0) {
            if (static_cast<size_t>(i) > n)
              fail(std::string(what) + " index " + std::to_string(i) + " out of range");
            return i - 1;
          }
          if (i < 0) {
            if (i < -static_cast<long>(n))  // (not -i: overflows for LONG_MIN)
              fail(std::string(what) + " index " + std::to_string(i) + " out of range");
            return static_cast<long>(n) + i;
          }
          return -1;
        };
        Corner c{resolve(idx[0], pos.size(), "vertex"),
                 resolve(idx[1], tex.size(), "texture coordinate"),
                 resolve(idx[2], nrm.size(), "normal")};
        if (idx[0] == 0) fail("vertex index 0 is invalid (OBJ indices start at 1)");
        poly.push_back(c);
      }
      std::vector<int> ids(poly.size());
      for (size_t k = 0; k < poly.size(); ++k) {
        const Corner& c = poly[k];
        if (c.t >= 0) any_uv = true;
        if (c.n >= 0) any_normal = true;
        const std::uint64_t key = (static_cast<std::uint64_t>(c.v) << 42) ^
                                  (static_cast<std::uint64_t>(c.t + 1) << 21) ^
                                  static_cast<std::uint64_t>(c.n + 1);
        auto [it, inserted] = corner_index.emplace(key, static_cast<int>(corners.size()));
        if (inserted) corners.push_back(c);
        ids[k] = it->second;
      }
      for (size_t k = 1; k + 1 < poly.size(); ++k) {
        tris.emplace_back(ids[0], ids[k], ids[k + 1]);
        tri_material.push_back(current_material);
      }
    } else if (kw == "mtllib" && tok.size() >= 2) {
      // The file name may contain spaces: take the rest of the line after the keyword.
      std::string name(line.substr(line.find("mtllib") + 6));
      name.erase(0, name.find_first_not_of(" \t"));
      name.erase(name.find_last_not_of(" \t") + 1);
      auto m = parse_mtl((fs::path(path).parent_path() / name).string());
      materials.insert(m.begin(), m.end());
    } else if (kw == "usemtl" && tok.size() >= 2) {
      current_material = std::string(tok[1]);
    }
    // Other statements (o, g, s, l, p, ...) do not affect the geometry we render.
  }
  if (pos.empty()) throw IoError(path, "no vertices ('v' lines): not an OBJ mesh?");
  if (tris.empty()) throw IoError(path, "no faces ('f' lines)");

  // Texture: the first material with a loadable map_Kd.
  if (options.load_texture && any_uv) {
    for (const auto& mname : tri_material) {
      auto it = materials.find(mname);
      if (it == materials.end() || it->second.texture_path.empty()) continue;
      mesh.texture =
          load_texture_image(it->second.texture_path, path, options.warn_missing_texture);
      texture_material = mname;
      break;
    }
  }
  const bool textured = mesh.texture != nullptr;

  mesh.vertices.resize(corners.size());
  if (any_normal) mesh.normals.resize(corners.size(), Eigen::Vector3f::Zero());
  if (textured) mesh.uvs.resize(corners.size(), Eigen::Vector2f::Zero());
  for (size_t i = 0; i < corners.size(); ++i) {
    const Corner& c = corners[i];
    mesh.vertices[i] = pos[c.v];
    if (any_normal && c.n >= 0) mesh.normals[i] = nrm[c.n];
    if (textured && c.t >= 0) mesh.uvs[i] = tex[c.t];
  }
  mesh.triangles = std::move(tris);
  if (any_normal) {
    // Corners without a normal get the face normal sum; simplest: recompute all if any is missing.
    bool missing = false;
    for (const auto& c : corners) missing |= c.n < 0;
    if (missing) mesh.normals.clear();
  }
  // Colours: vertex colours only without a texture; otherwise the material's Kd per face corner.
  if (!textured) {
    bool kd_varies = false;
    Eigen::Vector3f kd0(1, 1, 1);
    bool first = true;
    for (const auto& mname : tri_material) {
      auto it = materials.find(mname);
      const Eigen::Vector3f kd = it == materials.end() ? Eigen::Vector3f(1, 1, 1) : it->second.kd;
      if (first)
        kd0 = kd, first = false;
      else if ((kd - kd0).cwiseAbs().maxCoeff() > 1e-6f)
        kd_varies = true;
    }
    auto q = [](float x) {
      return static_cast<std::uint8_t>(std::clamp(x, 0.0f, 1.0f) * 255.0f + 0.5f);
    };
    if (any_vcol) {
      mesh.colors.resize(corners.size());
      for (size_t i = 0; i < corners.size(); ++i) mesh.colors[i] = vcol[corners[i].v];
    } else if (kd_varies) {
      mesh.colors.assign(corners.size(), Rgb8{255, 255, 255});
      for (size_t f = 0; f < mesh.triangles.size(); ++f) {
        auto it = materials.find(tri_material[f]);
        if (it == materials.end()) continue;
        const Rgb8 c{q(it->second.kd.x()), q(it->second.kd.y()), q(it->second.kd.z())};
        for (int k = 0; k < 3; ++k) mesh.colors[mesh.triangles[f][k]] = c;
      }
    } else if (!materials.empty()) {
      mesh.base_color = {q(kd0.x()), q(kd0.y()), q(kd0.z())};
    }
  }
  finish_mesh(mesh, path);
  return mesh;
}

// ---------------------------------------------------------------------------------------------
// PLY

namespace {

enum class PlyType {
  kInt8,
  kUint8,
  kInt16,
  kUint16,
  kInt32,
  kUint32,
  kFloat32,
  kFloat64,
  kInvalid
};

PlyType ply_type(std::string_view s) {
  if (s == "char" || s == "int8") return PlyType::kInt8;
  if (s == "uchar" || s == "uint8") return PlyType::kUint8;
  if (s == "short" || s == "int16") return PlyType::kInt16;
  if (s == "ushort" || s == "uint16") return PlyType::kUint16;
  if (s == "int" || s == "int32") return PlyType::kInt32;
  if (s == "uint" || s == "uint32") return PlyType::kUint32;
  if (s == "float" || s == "float32") return PlyType::kFloat32;
  if (s == "double" || s == "float64") return PlyType::kFloat64;
  return PlyType::kInvalid;
}

int ply_size(PlyType t) {
  switch (t) {
    case PlyType::kInt8:
    case PlyType::kUint8:
      return 1;
    case PlyType::kInt16:
    case PlyType::kUint16:
      return 2;
    case PlyType::kInt32:
    case PlyType::kUint32:
    case PlyType::kFloat32:
      return 4;
    case PlyType::kFloat64:
      return 8;
    default:
      return 0;
  }
}

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::kInvalid;
  bool is_list = false;
  PlyType count_type = PlyType::kInvalid;
};

struct PlyElement {
  std::string name;
  size_t count = 0;
  std::vector<PlyProperty> props;
};

/// Reads values of a PLY body, ascii or binary, with bounds checks that name the file.
class PlyBodyReader {
 public:
  PlyBodyReader(const std::string& path, const std::string& data, size_t pos, int format)
      : path_(path), data_(data), pos_(pos), format_(format) {}

  double read(PlyType t) {
    if (format_ == 0) return read_ascii();
    const int n = ply_size(t);
    if (pos_ + n > data_.size()) throw IoError(path_, "unexpected end of file in binary PLY body");
    unsigned char b[8];
    std::memcpy(b, data_.data() + pos_, n);
    pos_ += n;
    const bool file_le = format_ == 1;
    const bool host_le = std::endian::native == std::endian::little;
    if (file_le != host_le) std::reverse(b, b + n);
    switch (t) {
      case PlyType::kInt8:
        return static_cast<std::int8_t>(b[0]);
      case PlyType::kUint8:
        return b[0];
      case PlyType::kInt16: {
        std::int16_t v;
        std::memcpy(&v, b, 2);
        return v;
      }
      case PlyType::kUint16: {
        std::uint16_t v;
        std::memcpy(&v, b, 2);
        return v;
      }
      case PlyType::kInt32: {
        std::int32_t v;
        std::memcpy(&v, b, 4);
        return v;
      }
      case PlyType::kUint32: {
        std::uint32_t v;
        std::memcpy(&v, b, 4);
        return v;
      }
      case PlyType::kFloat32: {
        float v;
        std::memcpy(&v, b, 4);
        return v;
      }
      case PlyType::kFloat64: {
        double v;
        std::memcpy(&v, b, 8);
        return v;
      }
      default:
        throw IoError(path_, "invalid PLY property type");
    }
  }
  void end_of_record() {
    if (format_ != 0) return;
    // ascii: the rest of the line must be empty.
    while (pos_ < data_.size() &&
           (data_[pos_] == ' ' || data_[pos_] == '\t' || data_[pos_] == '\r'))
      ++pos_;
    if (pos_ < data_.size() && data_[pos_] != '\n')
      throw IoError(path_,
                    "line " + std::to_string(line_) + ": too many values in ascii PLY record");
    if (pos_ < data_.size()) ++pos_, ++line_;
  }
  void set_line(int line) { line_ = line; }

 private:
  double read_ascii() {
    while (pos_ < data_.size() &&
           (data_[pos_] == ' ' || data_[pos_] == '\t' || data_[pos_] == '\r'))
      ++pos_;
    if (pos_ >= data_.size()) throw IoError(path_, "unexpected end of file in ascii PLY body");
    if (data_[pos_] == '\n')
      throw IoError(path_,
                    "line " + std::to_string(line_) + ": too few values in ascii PLY record");
    size_t end = pos_;
    while (end < data_.size() && !std::isspace(static_cast<unsigned char>(data_[end]))) ++end;
    double v;
    if (!parse_double(std::string_view(data_).substr(pos_, end - pos_), v))
      throw IoError(path_, "line " + std::to_string(line_) + ": malformed number '" +
                               data_.substr(pos_, std::min<size_t>(end - pos_, 32)) + "'");
    pos_ = end;
    return v;
  }

  const std::string& path_;
  const std::string& data_;
  size_t pos_;
  int format_;  // 0 ascii, 1 little endian, 2 big endian
  int line_ = 0;
};

/// Reads past one list property value: its count, then its items. A count that is negative, NaN
/// or over 1e6 is refused (a float count beyond int would overflow the loop's cast).
void skip_ply_list(PlyBodyReader& body, const PlyProperty& p, const std::string& path) {
  const double n = body.read(p.count_type);
  if (!(n >= 0) || n > 1e6) throw IoError(path, "PLY list '" + p.name + "': bad list length");
  for (int j = 0; j < static_cast<int>(n); ++j) body.read(p.type);
}

}  // namespace

TriangleMesh load_ply(const std::string& path, const MeshLoadOptions& options) {
  const std::string data = read_whole_file(path);
  if (data.compare(0, 3, "ply") != 0) throw IoError(path, "not a PLY file (missing 'ply' magic)");
  // Header.
  size_t pos = 0;
  int line_no = 0;
  int format = -1;
  std::vector<PlyElement> elements;
  std::string texture_file;
  bool header_done = false;
  std::vector<std::string_view> tok;
  while (pos < data.size()) {
    size_t end = data.find('\n', pos);
    if (end == std::string::npos) break;
    std::string_view line(data.data() + pos, end - pos);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    pos = end + 1;
    ++line_no;
    split_ws(line, tok);
    if (tok.empty()) continue;
    auto fail = [&](const std::string& what) {
      throw IoError(path, "header line " + std::to_string(line_no) + ": " + what);
    };
    if (tok[0] == "ply") continue;
    if (tok[0] == "format") {
      if (tok.size() < 2) fail("malformed format line");
      if (tok[1] == "ascii")
        format = 0;
      else if (tok[1] == "binary_little_endian")
        format = 1;
      else if (tok[1] == "binary_big_endian")
        format = 2;
      else
        fail("unknown format '" + std::string(tok[1]) + "'");
    } else if (tok[0] == "comment" || tok[0] == "obj_info") {
      if (tok.size() >= 3 && (tok[1] == "TextureFile" || tok[1] == "texturefile")) {
        std::string_view rest = line.substr(line.find(tok[1]) + tok[1].size());
        std::string name(rest);
        name.erase(0, name.find_first_not_of(" \t"));
        name.erase(name.find_last_not_of(" \t") + 1);
        texture_file = name;
      }
    } else if (tok[0] == "element") {
      long count = 0;
      if (tok.size() != 3 || !parse_int(tok[2], count) || count < 0) fail("malformed element line");
      elements.push_back({std::string(tok[1]), static_cast<size_t>(count), {}});
    } else if (tok[0] == "property") {
      if (elements.empty()) fail("property before any element");
      PlyProperty p;
      if (tok.size() == 5 && tok[1] == "list") {
        p.is_list = true;
        p.count_type = ply_type(tok[2]);
        p.type = ply_type(tok[3]);
        p.name = std::string(tok[4]);
        if (p.count_type == PlyType::kInvalid || p.type == PlyType::kInvalid)
          fail("unknown list property type");
      } else if (tok.size() == 3) {
        p.type = ply_type(tok[1]);
        p.name = std::string(tok[2]);
        if (p.type == PlyType::kInvalid)
          fail("unknown property type '" + std::string(tok[1]) + "'");
      } else {
        fail("malformed property line");
      }
      elements.back().props.push_back(p);
    } else if (tok[0] == "end_header") {
      header_done = true;
      break;
    } else {
      fail("unexpected header keyword '" + std::string(tok[0]) + "'");
    }
  }
  if (!header_done) throw IoError(path, "PLY header has no end_header");
  if (format < 0) throw IoError(path, "PLY header has no format line");

  const float scale = static_cast<float>(options.metres_per_unit);
  TriangleMesh mesh;
  mesh.name = path;
  std::vector<Eigen::Vector3i> faces;
  std::vector<std::array<Eigen::Vector2f, 3>> face_uv;  // per-face texcoords, when given
  bool have_vertex_element = false;
  PlyBodyReader body(path, data, pos, format);
  body.set_line(line_no + 1);
  std::vector<double> listv;
  for (const auto& el : elements) {
    // Each record takes at least one byte: a count beyond the body is a corrupt header and must not
    // size the allocations below (as in io/ply_format.cpp, found by the ply_points fuzz target).
    if (!el.props.empty() && el.count > data.size() - pos)
      throw IoError(path, "unexpected end of file: PLY element '" + el.name + "' has " +
                              std::to_string(el.count) + " records but the body only " +
                              std::to_string(data.size() - pos) + " bytes (truncated file?)");
    if (el.name == "vertex") {
      have_vertex_element = true;
      int ix = -1, iy = -1, iz = -1, inx = -1, iny = -1, inz = -1, ir = -1, ig = -1, ib = -1,
          iu = -1, iv = -1;
      for (int k = 0; k < static_cast<int>(el.props.size()); ++k) {
        const std::string& n = el.props[k].name;
        if (el.props[k].is_list) continue;
        if (n == "x")
          ix = k;
        else if (n == "y")
          iy = k;
        else if (n == "z")
          iz = k;
        else if (n == "nx")
          inx = k;
        else if (n == "ny")
          iny = k;
        else if (n == "nz")
          inz = k;
        else if (n == "red" || n == "r" || n == "diffuse_red")
          ir = k;
        else if (n == "green" || n == "g" || n == "diffuse_green")
          ig = k;
        else if (n == "blue" || n == "b" || n == "diffuse_blue")
          ib = k;
        else if (n == "texture_u" || n == "u" || n == "s")
          iu = k;
        else if (n == "texture_v" || n == "v" || n == "t")
          iv = k;
      }
      if (ix < 0 || iy < 0 || iz < 0) throw IoError(path, "vertex element lacks x, y or z");
      const bool has_n = inx >= 0 && iny >= 0 && inz >= 0;
      const bool has_c = ir >= 0 && ig >= 0 && ib >= 0;
      const bool has_uv = iu >= 0 && iv >= 0;
      const bool color_float = has_c && (el.props[ir].type == PlyType::kFloat32 ||
                                         el.props[ir].type == PlyType::kFloat64);
      mesh.vertices.resize(el.count);
      if (has_n) mesh.normals.resize(el.count);
      if (has_c) mesh.colors.resize(el.count);
      if (has_uv) mesh.uvs.resize(el.count);
      std::vector<double> rec(el.props.size());
      for (size_t i = 0; i < el.count; ++i) {
        for (size_t k = 0; k < el.props.size(); ++k) {
          const auto& p = el.props[k];
          if (p.is_list) {
            skip_ply_list(body, p, path);
            rec[k] = 0;
          } else {
            rec[k] = body.read(p.type);
          }
        }
        body.end_of_record();
        Eigen::Vector3f v(static_cast<float>(rec[ix]), static_cast<float>(rec[iy]),
                          static_cast<float>(rec[iz]));
        if (!v.allFinite())
          throw IoError(path, "vertex " + std::to_string(i) + " has a non-finite coordinate");
        mesh.vertices[i] = v * scale;
        if (has_n)
          mesh.normals[i] =
              Eigen::Vector3f(static_cast<float>(rec[inx]), static_cast<float>(rec[iny]),
                              static_cast<float>(rec[inz]));
        if (has_c) {
          auto q = [&](double x) {
            const double s = color_float ? x * 255.0 : x;
            return static_cast<std::uint8_t>(std::clamp(s, 0.0, 255.0) + (color_float ? 0.5 : 0.0));
          };
          mesh.colors[i] = {q(rec[ir]), q(rec[ig]), q(rec[ib])};
        }
        if (has_uv)
          mesh.uvs[i] = Eigen::Vector2f(static_cast<float>(rec[iu]), static_cast<float>(rec[iv]));
      }
    } else if (el.name == "face") {
      int iidx = -1, itc = -1;
      for (int k = 0; k < static_cast<int>(el.props.size()); ++k) {
        const auto& p = el.props[k];
        if (p.is_list && (p.name == "vertex_indices" || p.name == "vertex_index"))
          iidx = k;
        else if (p.is_list && p.name == "texcoord")
          itc = k;
      }
      if (iidx < 0) throw IoError(path, "face element lacks a vertex_indices list");
      for (size_t f = 0; f < el.count; ++f) {
        std::vector<long> idx;
        std::vector<double> tc;
        for (size_t k = 0; k < el.props.size(); ++k) {
          const auto& p = el.props[k];
          if (p.is_list) {
            const double nd = body.read(p.count_type);
            if (nd < 0 || nd > 1e6)
              throw IoError(path, "face " + std::to_string(f) + ": bad list length");
            const int n = static_cast<int>(nd);
            for (int j = 0; j < n; ++j) {
              const double x = body.read(p.type);
              if (static_cast<int>(k) == iidx)
                idx.push_back(static_cast<long>(x));
              else if (static_cast<int>(k) == itc)
                tc.push_back(x);
            }
          } else {
            body.read(p.type);
          }
        }
        body.end_of_record();
        if (idx.size() < 3)
          throw IoError(path, "face " + std::to_string(f) + " has fewer than 3 vertices");
        const bool with_tc = itc >= 0 && tc.size() == 2 * idx.size();
        for (size_t k = 1; k + 1 < idx.size(); ++k) {
          faces.emplace_back(static_cast<int>(idx[0]), static_cast<int>(idx[k]),
                             static_cast<int>(idx[k + 1]));
          if (with_tc) {
            auto uv = [&](size_t c) {
              return Eigen::Vector2f(static_cast<float>(tc[2 * c]),
                                     static_cast<float>(tc[2 * c + 1]));
            };
            face_uv.push_back({uv(0), uv(k), uv(k + 1)});
          }
        }
      }
    } else {
      // Skip unknown elements record by record (an element without properties has nothing to skip).
      for (size_t i = 0; i < (el.props.empty() ? 0 : el.count); ++i) {
        for (const auto& p : el.props) {
          if (p.is_list) {
            skip_ply_list(body, p, path);
          } else {
            body.read(p.type);
          }
        }
        body.end_of_record();
      }
    }
  }
  if (!have_vertex_element || mesh.vertices.empty()) throw IoError(path, "PLY has no vertices");
  for (const auto& f : faces)
    for (int k = 0; k < 3; ++k)
      if (f[k] < 0 || static_cast<size_t>(f[k]) >= mesh.vertices.size())
        throw IoError(path, "face vertex index " + std::to_string(f[k]) + " out of range (" +
                                std::to_string(mesh.vertices.size()) + " vertices)");
  if (!face_uv.empty() && face_uv.size() == faces.size()) {
    // Per-corner texcoords: split vertices so that each corner has its own uv.
    TriangleMesh split;
    split.name = mesh.name;
    for (size_t f = 0; f < faces.size(); ++f) {
      Eigen::Vector3i t;
      for (int k = 0; k < 3; ++k) {
        const int v = faces[f][k];
        t[k] = static_cast<int>(split.vertices.size());
        split.vertices.push_back(mesh.vertices[v]);
        if (!mesh.normals.empty()) split.normals.push_back(mesh.normals[v]);
        if (!mesh.colors.empty()) split.colors.push_back(mesh.colors[v]);
        split.uvs.push_back(face_uv[f][k]);
      }
      split.triangles.push_back(t);
    }
    mesh = std::move(split);
  } else {
    mesh.triangles = std::move(faces);
  }
  if (options.load_texture && !texture_file.empty() && !mesh.uvs.empty())
    mesh.texture = load_texture_image((fs::path(path).parent_path() / texture_file).string(), path,
                                      options.warn_missing_texture);
  if (!mesh.texture)
    mesh.uvs.clear();
  else
    mesh.colors.clear();  // the texture carries the colour (vertex colours are usually its bake)
  finish_mesh(mesh, path);
  return mesh;
}

TriangleMesh load_mesh(const std::string& path, const MeshLoadOptions& options) {
  const std::string ext = lower(fs::path(path).extension().string());
  if (!(options.metres_per_unit > 0) || !std::isfinite(options.metres_per_unit))
    throw IoError(path, "metres_per_unit must be positive");
  if (ext == ".obj") return load_obj(path, options);
  if (ext == ".ply") return load_ply(path, options);
  throw IoError(path, "unsupported mesh format '" + ext + "' (expected .obj or .ply)");
}

void write_ply(const std::string& path, const TriangleMesh& mesh, const PlyWriteOptions& opt) {
  std::string why;
  if (!mesh.IsValid(&why)) throw IoError(path, "cannot write invalid mesh: " + why);
  TriangleMesh m = mesh;
  if (opt.write_normals && m.normals.empty()) m.compute_vertex_normals();
  const bool with_uv = !opt.texture_file.empty() && !m.uvs.empty();
  std::vector<Rgb8> colors;
  if (opt.write_colors) {
    if (m.has_texture()) bake_texture_into_vertex_colors(m);
    if (!m.colors.empty())
      colors = m.colors;
    else
      colors.assign(m.vertices.size(), Rgb8{255, 255, 255});
    // Base colour multiplies in.
    for (auto& c : colors) {
      auto mul = [](std::uint8_t a, std::uint8_t b) {
        return static_cast<std::uint8_t>((a * b + 127) / 255);
      };
      c = {mul(c.r, m.base_color.r), mul(c.g, m.base_color.g), mul(c.b, m.base_color.b)};
    }
  }
  const double s = opt.units_per_metre;
  write_file_atomic(
      path,
      [&](std::ostream& os) {
        os << "ply\nformat " << (opt.binary ? "binary_little_endian" : "ascii") << " 1.0\n";
        os << "comment orpe TriangleMesh, units per metre " << s << "\n";
        if (with_uv) os << "comment TextureFile " << opt.texture_file << "\n";
        os << "element vertex " << m.vertices.size() << "\n";
        os << "property float x\nproperty float y\nproperty float z\n";
        if (opt.write_normals) os << "property float nx\nproperty float ny\nproperty float nz\n";
        if (opt.write_colors)
          os << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
        if (with_uv) os << "property float texture_u\nproperty float texture_v\n";
        os << "element face " << m.triangles.size() << "\n";
        os << "property list uchar int vertex_indices\nend_header\n";
        if (opt.binary) {
          static_assert(std::endian::native == std::endian::little,
                        "binary PLY writer assumes little endian");
          auto put = [&](const auto& v) { os.write(reinterpret_cast<const char*>(&v), sizeof(v)); };
          for (size_t i = 0; i < m.vertices.size(); ++i) {
            const Eigen::Vector3f p = (m.vertices[i].cast<double>() * s).cast<float>();
            put(p.x()), put(p.y()), put(p.z());
            if (opt.write_normals)
              put(m.normals[i].x()), put(m.normals[i].y()), put(m.normals[i].z());
            if (opt.write_colors) put(colors[i].r), put(colors[i].g), put(colors[i].b);
            if (with_uv) put(m.uvs[i].x()), put(m.uvs[i].y());
          }
          for (const auto& t : m.triangles) {
            const std::uint8_t three = 3;
            put(three), put(t[0]), put(t[1]), put(t[2]);
          }
        } else {
          char buf[256];
          for (size_t i = 0; i < m.vertices.size(); ++i) {
            const Eigen::Vector3d p = m.vertices[i].cast<double>() * s;
            int n = std::snprintf(buf, sizeof(buf), "%.7g %.7g %.7g", p.x(), p.y(), p.z());
            os.write(buf, n);
            if (opt.write_normals) {
              n = std::snprintf(buf, sizeof(buf), " %.5f %.5f %.5f", m.normals[i].x(),
                                m.normals[i].y(), m.normals[i].z());
              os.write(buf, n);
            }
            if (opt.write_colors) {
              n = std::snprintf(buf, sizeof(buf), " %d %d %d", colors[i].r, colors[i].g,
                                colors[i].b);
              os.write(buf, n);
            }
            if (with_uv) {
              n = std::snprintf(buf, sizeof(buf), " %.6f %.6f", m.uvs[i].x(), m.uvs[i].y());
              os.write(buf, n);
            }
            os.put('\n');
          }
          for (const auto& t : m.triangles) {
            const int n = std::snprintf(buf, sizeof(buf), "3 %d %d %d\n", t[0], t[1], t[2]);
            os.write(buf, n);
          }
        }
      },
      opt.binary);
}

}  // namespace orpe
