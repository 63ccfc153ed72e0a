// Atomic file output: write to a temporary file in the destination folder, then rename, so that a
// crash or an error never leaves a half-written result behind.
#pragma once

#include <functional>
#include <iosfwd>
#include <string>

namespace orpe {

/// Calls `write` with a stream on a temporary file next to `path`, then renames it onto `path`.
/// Creates missing parent folders. Throws IoError (naming `path`) on any failure; the temporary
/// file is removed on failure. `binary` selects binary mode.
void write_file_atomic(const std::string& path, const std::function<void(std::ostream&)>& write,
                       bool binary = false);

/// Returns a temporary path in the same folder as `path` with the same extension (so that
/// extension-sniffing writers such as image encoders choose the right format).
std::string temp_path_for(const std::string& path);

/// Renames `tmp` onto `path` (atomic within one filesystem). Throws IoError on failure.
void commit_temp_file(const std::string& tmp, const std::string& path);

}  // namespace orpe
