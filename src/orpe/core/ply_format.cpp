#include "orpe/core/ply_format.h"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <optional>
#include <sstream>

#include <fmt/format.h>

#include "orpe/core/error.h"

namespace orpe::detail {
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

PlyType parse_type(const std::string& s) {
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

size_t type_size(PlyType t) {
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
    default:
      return 8;
  }
}

struct Property {
  std::string name;
  PlyType type = PlyType::kInvalid;
  bool is_list = false;
  PlyType count_type = PlyType::kInvalid;
};

struct Element {
  std::string name;
  size_t count = 0;
  std::vector<Property> properties;
  int line = 0;  ///< of its header line
};

enum class Format { kAscii, kBinaryLittleEndian, kBinaryBigEndian };

template <class T>
T load(const char* p, bool swap) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  if (swap) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    for (size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
    std::memcpy(&v, b, sizeof(T));
  }
  return v;
}

double decode(PlyType t, const char* p, bool swap) {
  switch (t) {
    case PlyType::kInt8:
      return load<int8_t>(p, false);
    case PlyType::kUint8:
      return load<uint8_t>(p, false);
    case PlyType::kInt16:
      return load<int16_t>(p, swap);
    case PlyType::kUint16:
      return load<uint16_t>(p, swap);
    case PlyType::kInt32:
      return load<int32_t>(p, swap);
    case PlyType::kUint32:
      return load<uint32_t>(p, swap);
    case PlyType::kFloat32:
      return load<float>(p, swap);
    default:
      return load<double>(p, swap);
  }
}

/// Sequential reader of body values in either encoding, bounds-checked.
class BodyReader {
 public:
  BodyReader(const std::string& path, const std::string& data, size_t pos, Format format)
      : path_(path), data_(data), pos_(pos), format_(format) {
    swap_ = (format == Format::kBinaryBigEndian) == (std::endian::native == std::endian::little);
  }

  double next(PlyType t) {
    if (format_ == Format::kAscii) return next_ascii();
    const size_t n = type_size(t);
    if (pos_ + n > data_.size()) throw IoError(path_, "PLY body ends early (truncated file?)");
    const double v = decode(t, data_.data() + pos_, swap_);
    pos_ += n;
    return v;
  }

  /// ASCII: a record is one line (as assimp reads it: a record split over lines made it read a
  /// face of 0 indices and abort, fuzz mesh_ply finding 26). begin_record skips blank lines;
  /// next_ascii does not read past the line's end; end_record wants nothing more on the line.
  void begin_record() {
    if (format_ != Format::kAscii) return;
    while (pos_ < data_.size() && std::isspace(static_cast<unsigned char>(data_[pos_]))) ++pos_;
  }
  void end_record() {
    if (format_ != Format::kAscii) return;
    skip_blanks();
    if (pos_ < data_.size() && data_[pos_] != '\n')
      throw IoError(path_, fmt::format("PLY body line {}: more values than the element's "
                                       "properties (each record is one line)",
                                       line()));
  }

  /// True when only whitespace (ascii) is left; binary bodies may carry trailing bytes.
  bool only_whitespace_left() const {
    if (format_ != Format::kAscii) return true;
    for (size_t i = pos_; i < data_.size(); ++i)
      if (!std::isspace(static_cast<unsigned char>(data_[i]))) return false;
    return true;
  }

 private:
  void skip_blanks() {
    while (pos_ < data_.size() && data_[pos_] != '\n' &&
           std::isspace(static_cast<unsigned char>(data_[pos_])))
      ++pos_;
  }
  /// The 1-based line of the file at the read position.
  size_t line() const {
    return 1 + static_cast<size_t>(std::count(data_.begin(), data_.begin() + pos_, '\n'));
  }
  double next_ascii() {
    skip_blanks();
    if (pos_ >= data_.size()) throw IoError(path_, "PLY body ends early (truncated file?)");
    if (data_[pos_] == '\n')
      throw IoError(path_, fmt::format("PLY body line {}: fewer values than the element's "
                                       "properties (each record is one line)",
                                       line()));
    const size_t start = pos_;
    while (pos_ < data_.size() && !std::isspace(static_cast<unsigned char>(data_[pos_]))) ++pos_;
    const std::string token = data_.substr(start, pos_ - start);
    try {
      size_t used = 0;
      const double v = std::stod(token, &used);
      if (used == token.size()) return v;
    } catch (const std::exception&) {
    }
    throw IoError(path_, fmt::format("PLY body: '{}' is not a number", token));
  }

  const std::string& path_;
  const std::string& data_;
  size_t pos_;
  Format format_;
  bool swap_ = false;
};

}  // namespace

namespace {

struct PlyFile {
  std::string data;  ///< the whole file
  std::vector<Element> elements;
  Format format = Format::kAscii;
  size_t body_pos = 0;  ///< first byte after end_header
};

/// Smallest number of bytes one record of `e` takes (binary: scalar sizes + list counts; ascii:
/// one character and one separator per value).
size_t min_record_bytes(const Element& e, Format format) {
  size_t n = 0;
  for (const Property& p : e.properties)
    n += format == Format::kAscii ? 2 : type_size(p.is_list ? p.count_type : p.type);
  return n;
}

/// assimp ends a line at \r, \n, NUL and form feed and separates values by spaces and tabs only;
/// orpe's reader took the other control characters for spaces, so the two read different records
/// (a form feed inside a vertex line made assimp read a face of 0 indices and abort: fuzz mesh_ply
/// finding 29). The text (the header; an ASCII body) may hold no other control character, and a
/// carriage return only before a newline.
void check_text_bytes(const std::string& path, const std::string& data, size_t end) {
  size_t line = 1;
  for (size_t i = 0; i < end; ++i) {
    const auto c = static_cast<unsigned char>(data[i]);
    if (c == '\n') ++line;
    if (c >= 0x20 || c == '\t' || c == '\n' || (c == '\r' && i + 1 < end && data[i + 1] == '\n'))
      continue;
    throw IoError(path, fmt::format("PLY line {}: a control character (byte 0x{:02x}); values are "
                                    "separated by spaces or tabs, lines end with a newline",
                                    line, c));
  }
}

namespace {

/// The header's lines read into a PlyFile, one keyword at a time; errors name the line.
struct HeaderReader {
  const std::string& path;
  PlyFile& file;
  bool have_format = false;
  int line_no = 0;

  [[noreturn]] void fail(const std::string& what) const {
    throw IoError(path, fmt::format("PLY header line {}: {}", line_no, what));
  }

  /// One line (without its newline); false at end_header.
  bool read_line(std::string line) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream ls(line);
    std::string key;
    ls >> key;
    if (key == "end_header") return false;
    if (key.empty() || key == "ply" || key == "comment" || key == "obj_info") return true;
    if (key == "format")
      read_format(ls);
    else if (key == "element")
      read_element(ls);
    else if (key == "property")
      read_property(ls);
    else
      fail("unknown keyword '" + key + "'");
    return true;
  }

  void read_format(std::istringstream& ls) {
    // assimp reads the first format line, an element by its name (two elements of one name made
    // it read out of bounds: fuzz mesh_ply finding 30): a second of either is refused.
    if (have_format) fail("a second format line");
    std::string f;
    ls >> f;
    if (f == "ascii")
      file.format = Format::kAscii;
    else if (f == "binary_little_endian")
      file.format = Format::kBinaryLittleEndian;
    else if (f == "binary_big_endian")
      file.format = Format::kBinaryBigEndian;
    else
      fail("unknown format '" + f + "'");
    have_format = true;
  }

  void read_element(std::istringstream& ls) {
    Element e;
    long long count = -1;
    if (!(ls >> e.name >> count) || count < 0) fail("malformed element line");
    for (const Element& other : file.elements)
      if (other.name == e.name)
        fail(fmt::format("a second element '{}' (the first is on line {})", e.name, other.line));
    e.count = static_cast<size_t>(count);
    e.line = line_no;
    file.elements.push_back(e);
  }

  void read_property(std::istringstream& ls) {
    if (file.elements.empty()) fail("property before any element");
    Property p;
    std::string type;
    ls >> type;
    if (type == "list") {
      std::string count_type, item_type;
      ls >> count_type >> item_type >> p.name;
      p.is_list = true;
      p.count_type = parse_type(count_type);
      p.type = parse_type(item_type);
      if (p.count_type == PlyType::kInvalid || p.type == PlyType::kInvalid)
        fail("unknown list type");
    } else {
      ls >> p.name;
      p.type = parse_type(type);
      if (p.type == PlyType::kInvalid) fail("unknown property type '" + type + "'");
    }
    if (p.name.empty()) fail("property without a name");
    file.elements.back().properties.push_back(p);
  }
};

/// Counts the body cannot hold (a corrupt or hostile header) fail before any allocation. Records
/// without properties take no bytes, so nothing bounds their count: assimp made an instance of
/// each (1e9 records: over 10 s, fuzz mesh_ply finding 27); no PLY writer makes one.
void check_record_counts(const std::string& path, const PlyFile& file, size_t body_pos) {
  size_t remaining = file.data.size() - body_pos;
  for (const Element& e : file.elements) {
    if (e.properties.empty() && e.count > 0)
      throw IoError(path, fmt::format("PLY header line {}: element '{}' declares {} records but no "
                                      "properties",
                                      e.line, e.name, e.count));
    const size_t per = min_record_bytes(e, file.format);
    if (per > 0 && e.count > remaining / per)
      throw IoError(path,
                    fmt::format("PLY element '{}' declares {} records, more than the {} bytes "
                                "of the body can hold (truncated file?)",
                                e.name, e.count, remaining));
    remaining -= per * e.count;
  }
}

}  // namespace

PlyFile read_ply_header(const std::string& path) {
  PlyFile file;
  std::ifstream is(path, std::ios::binary);
  if (!is) throw IoError(path, "cannot open PLY file");
  file.data.assign((std::istreambuf_iterator<char>(is)), std::istreambuf_iterator<char>());
  const std::string& data = file.data;
  if (data.compare(0, 3, "ply") != 0) throw IoError(path, "not a PLY file (no 'ply' magic)");

  // Header: lines up to "end_header".
  HeaderReader header{path, file};
  bool have_end = false;
  size_t pos = 0;
  while (pos < data.size()) {
    const size_t eol = data.find('\n', pos);
    if (eol == std::string::npos) break;
    const std::string line = data.substr(pos, eol - pos);
    pos = eol + 1;
    if (!header.read_line(line)) {
      have_end = true;
      break;
    }
  }
  if (!have_end) throw IoError(path, "PLY header has no end_header (truncated file?)");
  if (!header.have_format) throw IoError(path, "PLY header has no format line");
  check_text_bytes(path, data, file.format == Format::kAscii ? data.size() : pos);
  check_record_counts(path, file, pos);
  file.body_pos = pos;
  return file;
}

/// Walks the body element by element; `wanted` (may be null) collects one element's scalars.
namespace {

/// Records of the "vertex" element, or nullopt when the file has none.
std::optional<size_t> vertex_count(const PlyFile& file) {
  for (const Element& e : file.elements)
    if (e.name == "vertex") return e.count;
  return std::nullopt;
}

/// A face's vertex list must name at least 3 existing vertices (libassimp aborts the process on a
/// face of 0 indices: ai_assert in its triangulation; fuzz finding, docs/FUZZING.md).
bool is_face_index_list(const Element& e, const Property& p) {
  return e.name == "face" && (p.name == "vertex_indices" || p.name == "vertex_index");
}

}  // namespace

void walk_ply_body(const std::string& path, const PlyFile& file, const std::string& element,
                   PlyColumns* wanted_out) {
  BodyReader body(path, file.data, file.body_pos, file.format);
  const std::optional<size_t> vertices = vertex_count(file);
  for (const Element& e : file.elements) {
    const bool wanted = wanted_out && e.name == element;
    PlyColumns out;
    if (wanted) {
      out.count = e.count;
      for (const Property& p : e.properties)
        if (!p.is_list) out.columns[p.name].reserve(e.count);
    }
    for (size_t r = 0; r < (e.properties.empty() ? 0 : e.count); ++r) {
      body.begin_record();
      for (const Property& p : e.properties) {
        if (p.is_list) {
          const double n = body.next(p.count_type);
          if (!(n >= 0) || n > 1e9)
            throw IoError(path, fmt::format("PLY element '{}': bad list length", e.name));
          const bool face = is_face_index_list(e, p);
          if (face && n < 3)
            throw IoError(path, fmt::format("PLY face {} has {} vertex indices (a face needs at "
                                            "least 3)",
                                            r, n));
          for (size_t k = 0; k < static_cast<size_t>(n); ++k) {
            const double index = body.next(p.type);
            if (face && vertices && !(index >= 0 && index < static_cast<double>(*vertices)))
              throw IoError(path, fmt::format("PLY face {}: vertex index {} out of range ({} "
                                              "vertices)",
                                              r, index, *vertices));
          }
        } else {
          const double v = body.next(p.type);
          if (wanted) out.columns[p.name].push_back(v);
        }
      }
      body.end_record();
    }
    if (wanted) {
      *wanted_out = std::move(out);
      return;
    }
  }
  if (wanted_out) throw IoError(path, "PLY file has no '" + element + "' element");
  if (!body.only_whitespace_left())
    throw IoError(path,
                  "PLY body has more values than its header declares (a record with too "
                  "few values?)");
}

}  // namespace

PlyColumns read_ply_element(const std::string& path, const std::string& element) {
  const PlyFile file = read_ply_header(path);
  PlyColumns out;
  walk_ply_body(path, file, element, &out);
  return out;
}

void check_ply_structure(const std::string& path) {
  const PlyFile file = read_ply_header(path);
  walk_ply_body(path, file, "", nullptr);
}

}  // namespace orpe::detail
