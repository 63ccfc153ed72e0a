#include "orpe/render/obj_format.h"

#include <fmt/format.h>

#include <cctype>
#include <fstream>
#include <iterator>
#include <string_view>

#include "orpe/core/error.h"

namespace orpe::detail {
namespace {

/// assimp's IsSpace.
bool is_space(char c) {
  return c == ' ' || c == '\t';
}

std::string read_all(const std::string& path) {
  std::ifstream is(path, std::ios::binary);
  if (!is) throw IoError(path, "cannot open the file");
  return {std::istreambuf_iterator<char>(is), std::istreambuf_iterator<char>()};
}

/// assimp ends a line at \r, \n, NUL and form feed, and joins a line ending in '\' to the next (its
/// IOStreamBuffer::getNextDataLine). A text file has no NUL or form feed, and a continuation is
/// refused, so the lines split at \r and \n alone are assimp's.
void check_bytes(const std::string& path, const std::string& text) {
  size_t line = 1;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\n') ++line;
    if (c == '\0' || c == '\f')
      throw IoError(path, fmt::format("line {}: a {} byte (not a text file)", line,
                                      c == '\0' ? "NUL" : "form-feed"));
    if (c == '\\' && (i + 1 == text.size() || text[i + 1] == '\r' || text[i + 1] == '\n'))
      throw IoError(path, fmt::format("line {}: a line continuation ('\\' at the end of the line) "
                                      "is not supported",
                                      line));
  }
}

/// The next word of `s` from `pos` (words are separated by spaces and tabs); empty at the end.
std::string_view next_word(std::string_view s, size_t& pos) {
  while (pos < s.size() && is_space(s[pos])) ++pos;
  const size_t start = pos;
  while (pos < s.size() && !is_space(s[pos])) ++pos;
  return s.substr(start, pos - start);
}

/// The coordinates assimp counts on a `v` line (getNumComponentsInDataDefinition): the words that
/// start with a digit, '+' or '-' (IsNumeric), or with nan or inf in any case.
size_t numeric_words(std::string_view rest) {
  size_t count = 0, pos = 0;
  for (auto w = next_word(rest, pos); !w.empty(); w = next_word(rest, pos)) {
    const char c = w[0];
    std::string head(w.substr(0, 3));
    for (char& h : head) h = static_cast<char>(std::tolower(static_cast<unsigned char>(h)));
    if ((c >= '0' && c <= '9') || c == '+' || c == '-' || head == "nan" || head == "inf") ++count;
  }
  return count;
}

/// An index of a corner: '-'? [1-9][0-9]{0,8} at `pos` (assimp's atoi then steps by exactly its
/// digits); 0 when there is none.
long parse_index(std::string_view w, size_t& pos) {
  const size_t start = pos;
  if (pos < w.size() && w[pos] == '-') ++pos;
  long value = 0;
  size_t digits = 0;
  for (; pos < w.size() && w[pos] >= '0' && w[pos] <= '9'; ++pos, ++digits)
    if (digits < 9) value = value * 10 + (w[pos] - '0');  // more digits are refused below
  if (digits == 0 || digits > 9 || w[pos - digits] == '0') {
    pos = start;
    return 0;
  }
  return w[start] == '-' ? -value : value;
}

/// The vertex index of a corner v, v/vt, v//vn or v/vt/vn (the others may be empty); 0 when the
/// word is not one.
long corner_vertex(std::string_view w) {
  size_t pos = 0;
  const long v = parse_index(w, pos);
  if (v == 0) return 0;
  for (int part = 0; part < 2 && pos < w.size() && w[pos] == '/'; ++part) {
    ++pos;
    if (pos < w.size() && w[pos] != '/' && parse_index(w, pos) == 0) return 0;
  }
  return pos == w.size() ? v : 0;
}

/// What assimp counts of the file: its vertices, and the largest positive vertex index with its
/// line (assimp checks the indices against every vertex of the file, after reading it).
struct ObjCounts {
  long vertices = 0;
  long max_index = 0;
  size_t max_index_line = 0;
};

/// A face (f), line (l) or point (p) statement: every corner well formed; a negative index within
/// the vertices before it; a line of at least 2 vertices.
void check_face(const std::string& path, size_t line, std::string_view s, ObjCounts& counts) {
  size_t pos = 0;
  next_word(s, pos);  // the statement (assimp takes any word starting with f, l or p)
  size_t corners = 0;
  for (auto w = next_word(s, pos); !w.empty(); w = next_word(s, pos), ++corners) {
    const long v = corner_vertex(w);
    if (v == 0)
      throw IoError(path, fmt::format("line {}: the corner '{}' is not v, v/vt, v//vn or v/vt/vn "
                                      "(whole numbers other than 0, at most 9 digits)",
                                      line, w.substr(0, 32)));
    if (v < 0 && -v > counts.vertices)
      throw IoError(path, fmt::format("line {}: vertex index {} is out of range ({} vertices "
                                      "before it)",
                                      line, v, counts.vertices));
    if (v > counts.max_index) {
      counts.max_index = v;
      counts.max_index_line = line;
    }
  }
  if (s[0] == 'l' && corners == 1)
    throw IoError(path, fmt::format("line {}: a line statement of one vertex (it needs 2)", line));
}

/// One line as assimp's ObjFileParser::parseFile dispatches it on its first character.
void check_statement(const std::string& path, size_t line, std::string_view s, ObjCounts& counts) {
  if (s.empty()) return;
  if (s.substr(0, 6) == "cstype")  // assimp skips every line up to `end`
    throw IoError(path, fmt::format("line {}: free-form geometry (cstype) is not supported", line));
  if (s[0] == 'v' && s.size() > 1 && is_space(s[1])) {
    const size_t n = numeric_words(s.substr(1));
    if (n != 3 && n != 4 && n != 6)  // assimp would skip it, and count the vertices after it wrong
      throw IoError(path, fmt::format("line {}: a vertex of {} numbers (x y z, x y z w or "
                                      "x y z r g b)",
                                      line, n));
    ++counts.vertices;
  } else if (s[0] == 'f' || s[0] == 'l' || s[0] == 'p') {
    check_face(path, line, s, counts);
  }
}

bool is_line_end(char c) {
  return c == '\r' || c == '\n' || c == '\0' || c == '\f';
}

/// The texture statements assimp's MTL reader (ObjFileMtlImporter::getTexture) writes into the
/// current material, matched as it matches them: at the start of the line, in any case.
constexpr std::string_view kTextureStatements[] = {
    "map_kd", "map_ka", "map_ks",   "map_d", "map_emissive", "map_ke", "map_bump", "bump",
    "map_kn", "norm",   "map_disp", "disp",  "map_ns",       "map_pr", "map_pm",   "map_ps"};

bool starts_with_any_case(std::string_view s, std::string_view prefix) {
  if (s.size() < prefix.size()) return false;
  for (size_t i = 0; i < prefix.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(s[i])) != prefix[i]) return false;
  return true;
}

/// The problem of one MTL line before the first material, or nullopt.
std::optional<std::string> mtl_line_problem(size_t line, std::string_view s) {
  size_t pos = 0;
  const std::string word(next_word(s, pos).substr(0, 32));
  constexpr const char* kWhy = "before the first newmtl (assimp writes it into no material)";
  if (!s.empty() && (s[0] == 'a' || s[0] == 'A'))
    return fmt::format("line {}: '{}' {}", line, word, kWhy);
  for (const std::string_view t : kTextureStatements)
    if (starts_with_any_case(s, t))
      return fmt::format("line {}: a texture map ('{}') {}", line, word, kWhy);
  return std::nullopt;
}

/// assimp converts a file with a UTF-16 or UTF-32 byte-order mark, and drops a UTF-8 one from a
/// file of 8 bytes or more (BaseImporter::ConvertToUTF8).
bool has_utf16_or_utf32_mark(const std::string& text) {
  const auto starts = [&](std::string_view mark) {
    return text.compare(0, mark.size(), mark) == 0;
  };
  using namespace std::string_view_literals;
  return starts("\xFF\xFE"sv) || starts("\xFE\xFF"sv) || starts("\0\0\xFE\xFF"sv);
}

}  // namespace

std::optional<std::string> mtl_problem(const std::string& text) {
  // assimp throws on a text of 1 to 7 bytes before it closes the file it opened for it (a leak of
  // the stream: fuzz mesh_obj finding 34); an empty one it reads.
  if (!text.empty() && text.size() < 8)
    return fmt::format("{} bytes, too short for assimp's reader (it reads 8 or more)", text.size());
  if (has_utf16_or_utf32_mark(text))
    return "a UTF-16 or UTF-32 file (orpe reads OBJ and MTL files as UTF-8)";
  size_t start = text.size() >= 8 && text.compare(0, 3, "\xEF\xBB\xBF") == 0 ? 3 : 0;
  size_t line = 1;
  bool first = true;
  for (size_t i = start; i <= text.size(); ++i) {
    if (i < text.size() && !is_line_end(text[i])) continue;
    std::string_view s = std::string_view(text).substr(start, i - start);
    // assimp skips the spaces that start a line, but not on the first line of the file.
    while (!first && !s.empty() && is_space(s[0])) s.remove_prefix(1);
    first = false;
    if (s.size() >= 2 && (s[0] == 'n' || s[0] == 'N') && s[1] == 'e') return std::nullopt;
    if (auto problem = mtl_line_problem(line, s)) return problem;
    if (i < text.size() && text[i] == '\n') ++line;
    start = i + 1;
  }
  return std::nullopt;
}

void check_obj_structure(const std::string& path) {
  const std::string text = read_all(path);
  check_bytes(path, text);
  ObjCounts counts;
  size_t line = 1, start = 0;
  for (size_t i = 0; i <= text.size(); ++i) {
    if (i < text.size() && text[i] != '\r' && text[i] != '\n') continue;
    check_statement(path, line, std::string_view(text).substr(start, i - start), counts);
    if (i < text.size() && text[i] == '\n') ++line;
    start = i + 1;
  }
  if (counts.max_index > counts.vertices)
    throw IoError(path, fmt::format("line {}: vertex index {} is out of range (the file has {} "
                                    "vertices)",
                                    counts.max_index_line, counts.max_index, counts.vertices));
}

}  // namespace orpe::detail
