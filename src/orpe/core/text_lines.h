// Line-oriented text files (file lists, trajectories, point files, keyframe lists): their data
// lines.
#pragma once

#include <fstream>
#include <string>

#include "orpe/core/error.h"

namespace orpe {

/// Calls fn(line_no, line) for every data line of the text file `path`: not empty, not only blanks,
/// not a comment (a '#' as its first non-blank character). A trailing '\r' (CRLF files) is removed
/// first; `line_no` counts every line from 1, for messages. Throws IoError(path, "cannot open
/// <what>") when the file cannot be opened; what `fn` throws passes through.
template <class Fn>
void for_each_data_line(const std::string& path, const std::string& what, Fn&& fn) {
  std::ifstream is(path);
  if (!is) throw IoError(path, "cannot open " + what);
  std::string line;
  int line_no = 0;
  while (std::getline(is, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    fn(line_no, line);
  }
}

}  // namespace orpe
