// Error types. Every I/O error names the file and the problem.
#pragma once

#include <stdexcept>
#include <string>

namespace orpe {

/// A file could not be read or written, or its content is malformed.
class IoError : public std::runtime_error {
 public:
  IoError(const std::string& path, const std::string& problem)
      : std::runtime_error(path + ": " + problem), path_(path) {}
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

/// A parameter or option is invalid.
class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The user asked the program to stop (SIGINT / SIGTERM); the CLI exits with code 3.
class Interrupted : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace orpe
