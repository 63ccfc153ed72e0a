#include "orpe/core/atomic_file.h"

#include <atomic>
#include <filesystem>
#include <fstream>
#include <system_error>
#include <unistd.h>

#include "orpe/core/error.h"

namespace orpe {
namespace fs = std::filesystem;

std::string temp_path_for(const std::string& path) {
  static std::atomic<unsigned> counter{0};
  const fs::path p(path);
  const std::string stem = p.stem().string();
  const std::string name = "." + stem + ".tmp" + std::to_string(::getpid()) + "_" +
                           std::to_string(counter++) + p.extension().string();
  return (p.parent_path() / name).string();
}

void commit_temp_file(const std::string& tmp, const std::string& path) {
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw IoError(path, "cannot move temporary file into place: " + ec.message());
  }
}

void write_file_atomic(const std::string& path, const std::function<void(std::ostream&)>& write,
                       bool binary) {
  const fs::path p(path);
  std::error_code ec;
  if (p.has_parent_path()) {
    fs::create_directories(p.parent_path(), ec);
    if (ec) throw IoError(path, "cannot create parent folder: " + ec.message());
  }
  const std::string tmp = temp_path_for(path);
  try {
    {
      std::ofstream os(tmp, binary ? std::ios::binary | std::ios::out : std::ios::out);
      if (!os) throw IoError(path, "cannot open for writing");
      write(os);
      os.flush();
      if (!os) throw IoError(path, "write failed (disk full?)");
    }
    commit_temp_file(tmp, path);
  } catch (...) {
    fs::remove(tmp, ec);
    throw;
  }
}

}  // namespace orpe
