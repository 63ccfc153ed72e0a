// Locating the shared real data (../shared/data) and scratch folders for tests.
//
// Real data: $ORPE_DATA_DIR, else <source>/../shared/data. A test that needs it starts with
// ORPE_REQUIRE_DATA: without the data it skips with a message, unless $ORPE_REQUIRE_DATA=1 (set by
// .ci/run), where a missing data folder is a test failure naming the path.
//
// Scratch folders: under <temp>/orpe_test_<pid>/ (one root per test process, so that two suites
// running at once never share a folder), one per test and name; a test that passes has its folders
// removed when it ends (ScratchCleaner in test_main.cpp), a failing test's folders are kept and
// named; process_scratch_dir() folders live until the process ends.
#pragma once

#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <string>
#include <vector>

namespace orpe::test {

/// $ORPE_DATA_DIR, else <source>/../shared/data. Empty when the folder does not exist.
inline std::string data_dir() {
  std::string dir;
  if (const char* env = std::getenv("ORPE_DATA_DIR"); env && *env)
    dir = env;
  else
    dir = std::string(ORPE_SOURCE_DIR) + "/../shared/data";
  return std::filesystem::is_directory(dir) ? dir : std::string();
}

/// The folder data_dir() looks at (also when it does not exist), for messages.
inline std::string data_dir_setting() {
  if (const char* env = std::getenv("ORPE_DATA_DIR"); env && *env) return env;
  return std::string(ORPE_SOURCE_DIR) + "/../shared/data";
}

/// True when $ORPE_REQUIRE_DATA is set to 1: missing real data fails instead of skipping.
inline bool data_required() {
  const char* env = std::getenv("ORPE_REQUIRE_DATA");
  return env && std::string(env) == "1";
}

/// This process's scratch root, <temp>/orpe_test_<pid>.
inline std::filesystem::path scratch_root() {
  return std::filesystem::temp_directory_path() / ("orpe_test_" + std::to_string(::getpid()));
}

/// Scratch folders made by the running test (removed by ScratchCleaner when it passes).
struct ScratchRegistry {
  std::mutex mutex;
  std::vector<std::filesystem::path> dirs;          // the running test's
  std::vector<std::filesystem::path> process_dirs;  // the whole process's
  static ScratchRegistry& get() {
    static ScratchRegistry r;
    return r;
  }
};

/// A fresh empty folder under this process's scratch root, unique per test and `name`.
inline std::string scratch_dir(const std::string& name) {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string test = info ? std::string(info->test_suite_name()) + "_" + info->name() : "global";
  for (char& c : test)
    if (c == '/') c = '_';  // parameterised tests: "Suite/Name/0"
  const std::filesystem::path p = scratch_root() / (test + "_" + name);
  std::filesystem::remove_all(p);
  std::filesystem::create_directories(p);
  auto& reg = ScratchRegistry::get();
  std::lock_guard<std::mutex> lock(reg.mutex);
  reg.dirs.push_back(p);
  return p.string();
}

/// A fresh empty folder under this process's scratch root that lives for the whole test process
/// (data made once and shared by several tests); removed at the end when every test passed.
inline std::string process_scratch_dir(const std::string& name) {
  const std::filesystem::path p = scratch_root() / ("process_" + name);
  std::filesystem::remove_all(p);
  std::filesystem::create_directories(p);
  auto& reg = ScratchRegistry::get();
  std::lock_guard<std::mutex> lock(reg.mutex);
  reg.process_dirs.push_back(p);
  return p.string();
}

/// A measured figure that a test bounds: printed as "FIGURE name = value" when $ORPE_PRINT_FIGURES
/// is set (to re-measure the bounds after a change that moves them on purpose), and recorded as a
/// test property (ctest --output-junit / gtest --gtest_output=xml).
inline void print_figure(const std::string& name, double value) {
  if (std::getenv("ORPE_PRINT_FIGURES")) std::printf("FIGURE %s = %.4f\n", name.c_str(), value);
  ::testing::Test::RecordProperty(name, std::to_string(value));
}

/// gtest listener: removes the scratch folders of each passing test, names those of a failing one,
/// and removes the process's scratch root at the end when it is empty.
class ScratchCleaner : public ::testing::EmptyTestEventListener {
 public:
  void OnTestEnd(const ::testing::TestInfo& info) override {
    auto& reg = ScratchRegistry::get();
    std::lock_guard<std::mutex> lock(reg.mutex);
    for (const auto& d : reg.dirs) {
      std::error_code ec;
      if (info.result()->Failed())
        std::fprintf(stderr, "kept scratch folder %s\n", d.c_str());
      else
        std::filesystem::remove_all(d, ec);
    }
    reg.dirs.clear();
  }
  void OnTestProgramEnd(const ::testing::UnitTest& unit) override {
    std::error_code ec;
    auto& reg = ScratchRegistry::get();
    for (const auto& d : reg.process_dirs) {
      if (unit.Passed())
        std::filesystem::remove_all(d, ec);
      else
        std::fprintf(stderr, "kept scratch folder %s\n", d.c_str());
    }
    std::filesystem::remove(scratch_root(), ec);  // only when empty
  }
};

}  // namespace orpe::test

/// Skips the current test with a clear message when the shared data (or a sub-path) is absent;
/// fails it instead when $ORPE_REQUIRE_DATA=1 (CI).
#define ORPE_REQUIRE_DATA(var, subpath)                                                          \
  const std::string var = ::orpe::test::data_dir();                                              \
  if (var.empty() || !std::filesystem::exists(var + "/" + std::string(subpath))) {               \
    if (::orpe::test::data_required())                                                           \
      GTEST_FAIL() << "real data not found at '" << ::orpe::test::data_dir_setting() << "/"      \
                   << (subpath) << "' and ORPE_REQUIRE_DATA=1: set ORPE_DATA_DIR to the shared " \
                   << "data folder";                                                             \
    GTEST_SKIP() << "real data not found: set ORPE_DATA_DIR to the shared data folder (needs '"  \
                 << (subpath) << "'; looked in '" << ::orpe::test::data_dir_setting() << "')";   \
  }                                                                                              \
  static_assert(true, "")
