#include "orpe/core/parse_number.h"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>

#include "orpe/core/error.h"

namespace orpe {
namespace {

bool fail(std::string* why, const std::string& message) {
  if (why) *why = message;
  return false;
}

bool is_blank(char c) {
  return c == ' ' || c == '\t' || c == '\r';
}

template <class T>
bool parse_fields(std::string_view line, T* out, size_t n) {
  const char* p = line.data();
  const char* const end = p + line.size();
  for (size_t i = 0;; ++i) {
    while (p != end && is_blank(*p)) ++p;
    if (p == end) return i == n;
    if (i == n) return false;  // an extra field
    if (*p == '+' && end - p > 1 && p[1] != '-') ++p;
    const auto r = std::from_chars(p, end, out[i]);
    if (r.ec != std::errc() || (r.ptr != end && !is_blank(*r.ptr))) return false;
    p = r.ptr;
  }
}

template <class T>
void append_shortest(std::string& out, T v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof(buf), v);
  out.append(buf, r.ptr);
}

}  // namespace

bool parse_number_fields(std::string_view line, float* out, size_t n) {
  return parse_fields(line, out, n);
}
bool parse_number_fields(std::string_view line, double* out, size_t n) {
  return parse_fields(line, out, n);
}
void append_exact(std::string& out, float v) {
  append_shortest(out, v);
}
void append_exact(std::string& out, double v) {
  append_shortest(out, v);
}

bool parse_integer(std::string_view text, long long min, long long max, long long* out,
                   std::string* why) {
  if (text.empty()) return fail(why, "empty field where an integer is expected");
  const char* end = text.data() + text.size();
  long long v = 0;
  const auto r = std::from_chars(text.data(), end, v);
  if (r.ec == std::errc::result_out_of_range ||
      (r.ec == std::errc() && r.ptr == end && (v < min || v > max)))
    return fail(why, fmt::format("'{}' is out of range [{}, {}]", text, min, max));
  if (r.ec != std::errc() || r.ptr != end)
    return fail(why, fmt::format("'{}' is not an integer", text));
  *out = v;
  return true;
}

bool parse_real(std::string_view text, bool finite, double* out, std::string* why) {
  if (text.empty()) return fail(why, "empty field where a number is expected");
  std::string_view s = text;
  const bool plus = s.front() == '+';
  if (plus) s.remove_prefix(1);
  if (s.empty() || (plus && s.front() == '-'))
    return fail(why, fmt::format("'{}' is not a number", text));
  const char* end = s.data() + s.size();
  double v = 0;
  const auto r = std::from_chars(s.data(), end, v);
  if (r.ec == std::errc::result_out_of_range && r.ptr == end)
    return fail(why, fmt::format("'{}' is out of the range of a double", text));
  if (r.ec != std::errc() || r.ptr != end)
    return fail(why, fmt::format("'{}' is not a number", text));
  if (finite && !std::isfinite(v))
    return fail(why, fmt::format("'{}' is not a finite number", text));
  *out = v;
  return true;
}

int parse_int_field(std::string_view text, const std::string& path, const std::string& where,
                    long long min, long long max) {
  long long v = 0;
  std::string why;
  if (!parse_integer(text, std::max<long long>(min, INT_MIN), std::min<long long>(max, INT_MAX), &v,
                     &why))
    throw IoError(path, where + ": " + why);
  return static_cast<int>(v);
}

double parse_finite_field(std::string_view text, const std::string& path,
                          const std::string& where) {
  double v = 0;
  std::string why;
  if (!parse_real(text, true, &v, &why)) throw IoError(path, where + ": " + why);
  return v;
}

}  // namespace orpe
