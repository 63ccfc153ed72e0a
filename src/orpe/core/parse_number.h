// Strict number parsing for every reader (issue 12): the whole field is the number, in base 10,
// within a range; no prefix reading ("1.5" or "14abc" is not 1 or 14), no silent overflow.
#pragma once

#include <climits>
#include <string>
#include <string_view>

namespace orpe {

/// Parses all of `text` as a decimal integer (an optional leading '-', digits, nothing else) in
/// [min, max]. Returns false and, when `why` is set, says what is wrong ("'1.5' is not an integer",
/// "'99999999999' is out of range [0, 2147483647]").
bool parse_integer(std::string_view text, long long min, long long max, long long* out,
                   std::string* why);

/// Parses all of `text` as a decimal floating-point number ("1", "-2.5e3", "inf", "nan"; an
/// optional leading '+'). `finite`: refuse inf and nan. Returns false and sets `why` otherwise.
bool parse_real(std::string_view text, bool finite, double* out, std::string* why);

/// Splits `line` at blanks (spaces, tabs, carriage returns) and parses each field as parse_real
/// does (non-finite values included: the caller checks), read straight into the field's type so
/// that append_exact's text reads back bit for bit. True when `line` has exactly `n` fields, all
/// numbers in the type's range.
bool parse_number_fields(std::string_view line, float* out, size_t n);
bool parse_number_fields(std::string_view line, double* out, size_t n);

/// Appends the shortest decimal text of `v` that reads back (parse_number_fields, parse_real) to
/// exactly `v`: lossless and locale-independent.
void append_exact(std::string& out, float v);
void append_exact(std::string& out, double v);

/// parse_integer for an int in [min, max]; throws IoError(path, where + ": " + why), where `where`
/// names the line and field (e.g. "line 3, field im_id").
int parse_int_field(std::string_view text, const std::string& path, const std::string& where,
                    long long min = INT_MIN, long long max = INT_MAX);
/// parse_real, finite only; throws IoError(path, where + ": " + why).
double parse_finite_field(std::string_view text, const std::string& path, const std::string& where);

}  // namespace orpe
