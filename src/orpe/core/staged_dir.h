// A folder of outputs that appears whole or not at all: files are written into a hidden staging
// folder next to the destination, which replaces the destination in one rename at the end. An
// existing destination is replaced only when asked to (and only when it is empty or holds a
// previous run, recognised by `marker_file`).
#pragma once

#include <string>

namespace orpe {

class StagedDir {
 public:
  /// Checks `dest` before any work is done: not a file, and empty / absent unless `overwrite` (then it
  /// must hold `marker_file`, so that a folder that is not a previous run is never replaced). Creates
  /// the staging folder (which also proves the place is writable). Throws ConfigError / IoError
  /// naming `dest`.
  StagedDir(const std::string& dest, bool overwrite, const std::string& marker_file);
  /// Removes the staging folder unless commit() succeeded.
  ~StagedDir();
  StagedDir(const StagedDir&) = delete;
  StagedDir& operator=(const StagedDir&) = delete;

  /// Where to write (the staging folder until commit(), `dest` afterwards).
  const std::string& dir() const { return committed_ ? dest_ : staging_; }
  const std::string& dest() const { return dest_; }
  /// Moves the staging folder onto `dest` (the previous content, if any, is removed). Throws IoError.
  void commit();

 private:
  std::string dest_;
  std::string staging_;
  bool committed_ = false;
};

}  // namespace orpe
