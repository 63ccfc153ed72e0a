#include "orpe/pipeline/model_cache.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <sys/stat.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <stdexcept>

#include "orpe/core/atomic_file.h"
#include "orpe/core/error.h"
#include "orpe/core/parse_number.h"
#include "orpe/pose/colour_score.h"

namespace orpe {
namespace fs = std::filesystem;
namespace {

const std::string kHeader = "# orpe model cache v" + std::to_string(kModelCacheVersion);
const std::string kChecksum = "# checksum ";

/// An input file as an entry records it: size -1 = the file did not exist.
struct FileStamp {
  std::string path;
  long long size = -1;
  long long mtime_ns = 0;
  bool operator==(const FileStamp&) const = default;
};

FileStamp stamp_of(const std::string& path) {
  FileStamp s;
  s.path = path;
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0) {
    s.size = static_cast<long long>(st.st_size);
    s.mtime_ns = static_cast<long long>(st.st_mtim.tv_sec) * 1000000000LL + st.st_mtim.tv_nsec;
  }
  return s;
}

std::string absolute_path(const std::string& path) {
  std::error_code ec;
  const fs::path a = fs::absolute(path, ec);
  return ec ? path : a.lexically_normal().string();
}

/// The inputs' stamps, sorted by path, with the running program's.
std::vector<FileStamp> stamps_of(const std::vector<std::string>& inputs) {
  std::vector<std::string> paths;
  for (const std::string& p : inputs) paths.push_back(absolute_path(p));
  std::error_code ec;
  const fs::path program = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) paths.push_back(program.string());
  std::sort(paths.begin(), paths.end());
  paths.erase(std::unique(paths.begin(), paths.end()), paths.end());
  std::vector<FileStamp> stamps;
  for (const std::string& p : paths) stamps.push_back(stamp_of(p));
  return stamps;
}

std::string hex64(std::uint64_t v) {
  return fmt::format("{:016x}", v);
}

template <class T>
void append_numbers(std::string& line, std::initializer_list<T> values) {
  for (T v : values) {
    line += ' ';
    append_exact(line, v);
  }
}

void write_symmetry(std::ostream& os, const ObjectSymmetry& sym) {
  std::string line = fmt::format("symmetry {}", sym.continuous ? 1 : 0);
  const Vec3 &a = sym.axis_obj, &p = sym.axis_point_obj;
  append_numbers(line, {a.x(), a.y(), a.z(), p.x(), p.y(), p.z()});
  os << line << ' ' << sym.discrete.size() << '\n';
  for (const SE3& S : sym.discrete) {
    line = "discrete";
    for (int r = 0; r < 3; ++r)
      append_numbers(line, {S.rotation()(r, 0), S.rotation()(r, 1), S.rotation()(r, 2)});
    append_numbers(line, {S.translation().x(), S.translation().y(), S.translation().z()});
    os << line << '\n';
  }
}

void write_points(std::ostream& os, const ObjectModel& m) {
  os << "points " << m.points.size() << ' ' << m.normals.size() << '\n';
  std::string line;
  for (size_t i = 0; i < m.points.size(); ++i) {
    const Eigen::Vector3f& p = m.points[i];
    line.clear();
    append_exact(line, p.x());
    append_numbers(line, {p.y(), p.z()});
    if (m.has_normals())
      append_numbers(line, {m.normals[i].x(), m.normals[i].y(), m.normals[i].z()});
    os << line << '\n';
  }
}

/// The entry's text, its checksum line last.
std::string entry_text(std::uint64_t identity_hash, std::uint64_t options_hash,
                       const std::vector<FileStamp>& inputs, const ObjectModel& m) {
  std::ostringstream os;
  os << kHeader << "\nkey " << hex64(identity_hash) << ' ' << hex64(options_hash) << '\n';
  for (const FileStamp& s : inputs)
    os << "input " << s.size << ' ' << s.mtime_ns << ' ' << s.path << '\n';
  std::string line = "diameter_m";
  append_numbers(line, {m.diameter_m});
  line += "\nmean_spacing_m";
  append_numbers(line, {m.mean_spacing_m});
  os << line << '\n';
  write_symmetry(os, m.symmetry);
  write_points(os, m);
  if (m.colour) {
    os << "colour " << m.colour->size() << '\n';
    write_model_colour(os, *m.colour);
  } else {
    os << "colour none\n";
  }
  std::string text = os.str();
  text += kChecksum + hex64(fnv1a64(text)) + '\n';
  return text;
}

/// Reads an entry's lines in order; a line missing or malformed throws IoError naming the file.
class EntryReader {
 public:
  EntryReader(std::string_view text, std::string path) : text_(text), path_(std::move(path)) {}
  std::string_view line() {
    if (pos_ >= text_.size()) throw corrupt("ends early");
    const size_t end = text_.find('\n', pos_);
    const std::string_view l = text_.substr(pos_, end - pos_);
    pos_ = end == std::string_view::npos ? text_.size() : end + 1;
    return l;
  }
  /// The rest of a line that starts with `key` and a blank.
  std::string_view field(std::string_view key) {
    const std::string_view l = line();
    if (l.substr(0, key.size()) != key || l.size() <= key.size() || l[key.size()] != ' ')
      throw corrupt(fmt::format("expected '{}'", key));
    return l.substr(key.size() + 1);
  }
  template <class T>
  void numbers(std::string_view key, T* out, size_t n) {
    if (!parse_number_fields(key.empty() ? line() : field(key), out, n))
      throw corrupt(fmt::format("expected {} numbers{}{}", n, key.empty() ? "" : " after ", key));
  }
  bool peek(std::string_view key) const { return text_.substr(pos_, key.size()) == key; }
  std::string_view rest() const { return text_.substr(pos_); }
  IoError corrupt(const std::string& why) const {
    return IoError(path_, "corrupt model cache entry: " + why);
  }

 private:
  std::string_view text_;
  std::string path_;
  size_t pos_ = 0;
};

/// The entry's text without its checksum line; throws IoError when the checksum does not match.
std::string_view checked_body(const std::string& text, const std::string& path) {
  const size_t at = text.rfind(kChecksum);
  const std::string_view body = std::string_view(text).substr(0, at);
  if (at == std::string::npos || text.substr(at) != kChecksum + hex64(fnv1a64(body)) + '\n')
    throw IoError(path, "corrupt model cache entry: truncated or altered (checksum)");
  return body;
}

/// Reads the entry's inputs; true when every one still has its size and modification time.
bool inputs_unchanged(EntryReader& r) {
  bool same = true;
  while (r.peek("input ")) {
    const std::string_view l = r.field("input");
    const size_t a = l.find(' ');
    const size_t b = a == std::string_view::npos ? a : l.find(' ', a + 1);
    FileStamp s;
    if (b == std::string_view::npos ||
        !parse_integer(l.substr(0, a), -1, LLONG_MAX, &s.size, nullptr) ||
        !parse_integer(l.substr(a + 1, b - a - 1), LLONG_MIN, LLONG_MAX, &s.mtime_ns, nullptr))
      throw r.corrupt("expected 'input <size> <mtime ns> <path>'");
    s.path = std::string(l.substr(b + 1));
    same = same && stamp_of(s.path) == s;
  }
  return same;
}

/// A count written as a number: a whole number in [0, max].
size_t count_of(double v, double max, const EntryReader& r) {
  if (!(v >= 0 && v <= max && v == std::floor(v))) throw r.corrupt("bad count");
  return static_cast<size_t>(v);
}

void read_symmetry(EntryReader& r, ObjectSymmetry& sym) {
  double v[8];
  r.numbers("symmetry", v, 8);  // continuous, axis, axis point, number of discrete elements
  if (v[0] != 0 && v[0] != 1) throw r.corrupt("bad symmetry");
  sym.continuous = v[0] == 1;
  sym.axis_obj = Vec3(v[1], v[2], v[3]);
  sym.axis_point_obj = Vec3(v[4], v[5], v[6]);
  const size_t n = count_of(v[7], 1000, r);
  for (size_t k = 0; k < n; ++k) {
    double d[12];
    r.numbers("discrete", d, 12);
    Mat3 R;
    R << d[0], d[1], d[2], d[3], d[4], d[5], d[6], d[7], d[8];
    sym.discrete.emplace_back(R, Vec3(d[9], d[10], d[11]));
  }
}

void read_points(EntryReader& r, ObjectModel& m) {
  double v[2];
  r.numbers("points", v, 2);
  const size_t n = count_of(v[0], 1e8, r), normals = count_of(v[1], 1e8, r);
  if (normals != 0 && normals != n) throw r.corrupt("points and normals differ in number");
  m.points.resize(n);
  m.normals.resize(normals);
  float p[6];
  for (size_t i = 0; i < n; ++i) {
    r.numbers("", p, normals ? 6 : 3);
    m.points[i] = Eigen::Vector3f(p[0], p[1], p[2]);
    if (normals) m.normals[i] = Eigen::Vector3f(p[3], p[4], p[5]);
  }
}

void read_colour(EntryReader& r, ObjectModel& m, const std::string& path) {
  const std::string_view c = r.field("colour");
  if (c == "none") return;
  double v = 0;
  if (!parse_number_fields(c, &v, 1)) throw r.corrupt("expected 'colour none' or 'colour <n>'");
  const size_t n = count_of(v, 1e8, r);
  std::istringstream is{std::string(r.rest())};
  m.colour = read_model_colour(is, path);
  if (m.colour->size() != n) throw r.corrupt("colour samples missing");
}

/// The model an entry's body holds (after its key and inputs).
ObjectModel read_model(EntryReader& r, const std::string& path) {
  ObjectModel m;
  r.numbers("diameter_m", &m.diameter_m, 1);
  r.numbers("mean_spacing_m", &m.mean_spacing_m, 1);
  read_symmetry(r, m.symmetry);
  read_points(r, m);
  read_colour(r, m, path);
  try {
    prepare_object_model(m);  // builds the search index only: the rest is there
  } catch (const std::invalid_argument& e) {
    throw r.corrupt(e.what());
  }
  return m;
}

/// The model of an entry's text; nullopt when the entry is of another format version or for other
/// files or options, or (`check_inputs`) one of its inputs changed. Throws IoError when it is
/// corrupt.
std::optional<ObjectModel> parse_entry(const std::string& text, const std::string& path,
                                       std::uint64_t identity_hash, std::uint64_t options_hash,
                                       bool check_inputs) {
  if (text.rfind(kHeader + '\n', 0) != 0 && text.rfind("# orpe model cache v", 0) == 0)
    return std::nullopt;  // another format version: rewritten
  EntryReader r(checked_body(text, path), path);
  if (r.line() != kHeader) throw r.corrupt("expected '" + kHeader + "'");
  if (r.field("key") != hex64(identity_hash) + ' ' + hex64(options_hash)) return std::nullopt;
  if (!inputs_unchanged(r) && check_inputs) return std::nullopt;
  return read_model(r, path);
}

bool same_symmetry(const ObjectSymmetry& a, const ObjectSymmetry& b) {
  if (a.continuous != b.continuous || a.axis_obj != b.axis_obj ||
      a.axis_point_obj != b.axis_point_obj || a.discrete.size() != b.discrete.size())
    return false;
  for (size_t k = 0; k < a.discrete.size(); ++k)
    if (a.discrete[k].rotation() != b.discrete[k].rotation() ||
        a.discrete[k].translation() != b.discrete[k].translation())
      return false;
  return true;
}

bool same_colour(const ModelColour* a, const ModelColour* b) {
  if (!a || !b) return a == b;
  return a->points == b->points && a->normals == b->normals && a->grey == b->grey &&
         a->weight == b->weight && a->chroma == b->chroma && a->source == b->source;
}

/// True when the entry holds exactly `m` (what a cache may store).
bool reads_back_the_same(const ObjectModel& m, const std::optional<ObjectModel>& back) {
  return back && back->points == m.points && back->normals == m.normals &&
         back->diameter_m == m.diameter_m && back->mean_spacing_m == m.mean_spacing_m &&
         same_symmetry(back->symmetry, m.symmetry) &&
         same_colour(back->colour.get(), m.colour.get());
}

}  // namespace

std::uint64_t fnv1a64(std::string_view text, std::uint64_t seed) {
  std::uint64_t h = seed;
  for (const char c : text) {
    h ^= static_cast<unsigned char>(c);
    h *= 0x100000001b3ULL;
  }
  return h;
}

std::string resolve_model_cache_dir(const std::string& setting) {
  if (setting.empty() || setting == "none") return "";
  if (setting != "auto") return setting;
  if (const char* env = std::getenv("ORPE_CACHE_DIR")) return env;
  if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg)
    return std::string(xdg) + "/orpe/models";
  if (const char* home = std::getenv("HOME"); home && *home)
    return std::string(home) + "/.cache/orpe/models";
  return "";
}

std::optional<ObjectModel> ModelCache::load(const std::string& identity,
                                            std::uint64_t options_hash) const {
  if (!enabled()) return std::nullopt;
  const std::string path = entry_path(identity, options_hash);
  std::ifstream is(path, std::ios::binary);
  if (!is) return std::nullopt;  // no entry yet
  const std::string text{std::istreambuf_iterator<char>(is), std::istreambuf_iterator<char>()};
  try {
    return parse_entry(text, path, fnv1a64(identity), options_hash, true);
  } catch (const IoError& e) {
    spdlog::warn("{}; the model is loaded afresh", e.what());
    return std::nullopt;
  }
}

void ModelCache::store(const std::string& identity, std::uint64_t options_hash,
                       const std::vector<std::string>& inputs, const ObjectModel& model) const {
  if (!enabled() || write_failed_) return;
  for (const std::string& p : inputs)
    if (p.find('\n') != std::string::npos) return;  // a path an entry cannot record
  const std::string path = entry_path(identity, options_hash);
  const std::string text = entry_text(fnv1a64(identity), options_hash, stamps_of(inputs), model);
  try {  // an entry that would not read back bit for bit is not written
    if (!reads_back_the_same(model,
                             parse_entry(text, path, fnv1a64(identity), options_hash, false)))
      return;
  } catch (const IoError&) {
    return;
  }
  try {
    write_file_atomic(
        path, [&](std::ostream& os) { os << text; }, true);
  } catch (const IoError& e) {
    if (!write_failed_.exchange(true))
      spdlog::warn("model cache {}: cannot write an entry ({}); models are not cached", dir_,
                   e.what());
  }
}

std::string ModelCache::entry_path(const std::string& identity, std::uint64_t options_hash) const {
  // <points folder>_<points file stem>-<hash>.model: a name a person can find.
  const fs::path points(identity.substr(0, identity.find('\n')));
  std::string stem;
  for (const char c : points.parent_path().filename().string() + "_" + points.stem().string())
    stem += std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' ? c : '_';
  const std::uint64_t key = fnv1a64(hex64(options_hash), fnv1a64(identity));
  return (fs::path(dir_) / fmt::format("{}-{}.model", stem, hex64(key))).string();
}

}  // namespace orpe
