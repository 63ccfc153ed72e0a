#include "support/fuzz_support.h"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>

#include <spdlog/spdlog.h>

#include "orpe/core/error.h"
#include "orpe/io/dataset.h"

namespace orpe::fuzz {
namespace fs = std::filesystem;

namespace {

/// $TMPDIR when set, else /dev/shm (tmpfs: every input is written and read back without disk
/// traffic), else the system's temporary folder.
fs::path scratch_parent() {
  if (const char* env = std::getenv("TMPDIR"); env && *env) return env;
  std::error_code ec;
  if (fs::is_directory("/dev/shm", ec)) return "/dev/shm";
  return fs::temp_directory_path();
}

struct Scratch {
  std::string dir;
  Scratch() {
    spdlog::set_level(spdlog::level::off);
    dir = (scratch_parent() / ("orpe_fuzz_" + std::to_string(getpid()))).string();
    std::error_code ec;
    fs::remove_all(dir, ec);
    fs::create_directories(dir);
  }
  ~Scratch() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
};

[[noreturn]] void finding(const char* kind, const char* what) {
  std::fprintf(stderr, "FUZZ FINDING: %s escaped the parser: %s\n", kind, what);
  std::abort();
}

RefusalCount g_count;
// ORPE_FUZZ_PRINT_REFUSALS=1: a libFuzzer binary prints them too (to see why an input is refused).
bool g_print_refusals = [] {
  const char* env = std::getenv("ORPE_FUZZ_PRINT_REFUSALS");
  return env && *env == '1';
}();

void refused(const char* what) {
  ++g_count.refused;
  if (g_print_refusals) std::fprintf(stderr, "  refused: %s\n", what);
}

}  // namespace

RefusalCount refusal_count() {
  return g_count;
}

void set_print_refusals(bool on) {
  g_print_refusals = on;
}

const std::string& scratch_dir() {
  static Scratch scratch;
  return scratch.dir;
}

std::string scratch_path(const std::string& relative) {
  const fs::path p = fs::path(scratch_dir()) / relative;
  fs::create_directories(p.parent_path());
  return p.string();
}

void write_file(const std::string& path, std::string_view bytes) {
  std::ofstream os(path, std::ios::binary | std::ios::trunc);
  os.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (!os) finding("a scratch-file write error", path.c_str());
}

void write_or_remove(const std::string& path, std::string_view bytes, bool present) {
  if (present) {
    write_file(path, bytes);
  } else {
    std::error_code ec;
    fs::remove(path, ec);
  }
}

std::vector<std::string_view> split_parts(const uint8_t* data, size_t size, size_t max_parts) {
  std::string_view rest(reinterpret_cast<const char*>(data), size);
  constexpr std::string_view kSeparator = "\n--\n";
  std::vector<std::string_view> parts;
  while (parts.size() + 1 < max_parts) {
    const size_t at = rest.find(kSeparator);
    if (at == std::string_view::npos) break;
    parts.push_back(rest.substr(0, at + 1));  // keeps the part's last newline
    rest.remove_prefix(at + kSeparator.size());
  }
  parts.push_back(rest);
  return parts;
}

void expect_clean_refusal(void (*fn)(void*), void* context) {
  ++g_count.calls;
  try {
    fn(context);
  } catch (const IoError& e) {
    refused(e.what());
    if (std::string_view(e.what()).empty()) finding("an IoError without a message", "");
  } catch (const ConfigError& e) {
    refused(e.what());
    if (std::string_view(e.what()).empty()) finding("a ConfigError without a message", "");
  } catch (const std::exception& e) {
    finding("an exception other than IoError / ConfigError", e.what());
  } catch (...) {
    finding("a non-std exception", "");
  }
}

void read_dataset_annotations(const std::string& path, const std::string& format) {
  DatasetParams params;
  params.format = format;
  const auto reader = open_dataset(path, params);
  for (size_t i = 0; i < reader->size(); ++i) {
    try {
      (void)reader->read_annotations(i);
    } catch (const IoError& e) {
      // One bad frame is skipped by the pipeline (FrameStream); the other frames still parse.
      ++g_count.calls;
      refused(e.what());
    }
  }
  (void)reader->ground_truth_trajectory();
}

}  // namespace orpe::fuzz
