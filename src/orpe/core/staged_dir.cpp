#include "orpe/core/staged_dir.h"

#include <unistd.h>

#include <filesystem>
#include <system_error>

#include "orpe/core/error.h"

namespace orpe {
namespace fs = std::filesystem;
namespace {

// dest without a trailing separator ("out/" -> "out"), so that its parent and name are defined.
fs::path normalised(const std::string& dest) {
  fs::path p = fs::path(dest).lexically_normal();
  if (!p.has_filename() && p.has_parent_path()) p = p.parent_path();
  return p;
}

fs::path sibling(const fs::path& dest, const std::string& tag) {
  return dest.parent_path() / ("." + dest.filename().string() + "." + tag + std::to_string(::getpid()));
}

}  // namespace

StagedDir::StagedDir(const std::string& dest, bool overwrite, const std::string& marker_file) {
  const fs::path d = normalised(dest);
  if (d.empty() || d.filename() == "." || d.filename() == "..")
    throw ConfigError(dest + ": name the output folder itself (not '.' or '..')");
  dest_ = d.string();
  std::error_code ec;
  const fs::file_status st = fs::status(d, ec);
  if (fs::exists(st)) {
    if (!fs::is_directory(st)) throw IoError(dest_, "exists and is not a folder");
    const bool empty = fs::is_empty(d, ec);
    if (ec) throw IoError(dest_, "cannot read the folder: " + ec.message());
    if (!empty && !overwrite)
      throw ConfigError(dest_ + ": the output folder is not empty (a previous run?); pass --overwrite to "
                        "replace it, or choose another --out");
    if (!empty && !fs::exists(d / marker_file))
      throw ConfigError(dest_ + ": not replaced: the folder is not empty and holds no " + marker_file +
                        " (it does not look like a previous run)");
  }
  const fs::path staging = sibling(d, "staging-");
  fs::remove_all(staging, ec);  // a leftover of a killed run with the same process id
  fs::create_directories(staging, ec);
  if (ec) throw IoError(dest_, "cannot create the output folder next to it: " + ec.message());
  staging_ = staging.string();
}

StagedDir::~StagedDir() {
  if (committed_) return;
  std::error_code ec;
  fs::remove_all(staging_, ec);
}

void StagedDir::commit() {
  const fs::path d(dest_);
  std::error_code ec;
  fs::path old;
  if (fs::exists(d, ec)) {
    old = sibling(d, "old-");
    fs::remove_all(old, ec);
    fs::rename(d, old, ec);
    if (ec) throw IoError(dest_, "cannot move the previous folder aside: " + ec.message());
  }
  fs::rename(staging_, d, ec);
  if (ec) {
    std::error_code ec2;
    if (!old.empty()) fs::rename(old, d, ec2);  // put the previous run back
    throw IoError(dest_, "cannot move the outputs into place: " + ec.message());
  }
  committed_ = true;
  if (!old.empty()) fs::remove_all(old, ec);
}

}  // namespace orpe
