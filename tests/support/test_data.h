// Locating the shared real data (../shared/data) and scratch folders for tests.
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>

namespace orpe::test {

/// $ORPE_DATA_DIR, else <source>/../shared/data. Empty when the folder does not exist.
inline std::string data_dir() {
  std::string dir;
  if (const char* env = std::getenv("ORPE_DATA_DIR"); env && *env) dir = env;
  else dir = std::string(ORPE_SOURCE_DIR) + "/../shared/data";
  return std::filesystem::is_directory(dir) ? dir : std::string();
}

/// A fresh empty folder under the system temp dir, unique per test.
inline std::string scratch_dir(const std::string& name) {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::filesystem::path p = std::filesystem::temp_directory_path() /
                            ("orpe_test_" + std::string(info->test_suite_name()) + "_" + info->name() + "_" + name);
  std::filesystem::remove_all(p);
  std::filesystem::create_directories(p);
  return p.string();
}

}  // namespace orpe::test

/// Skips the current test with a clear message when the shared data (or a sub-path) is absent.
#define ORPE_REQUIRE_DATA(var, subpath)                                                           \
  const std::string var = ::orpe::test::data_dir();                                               \
  if (var.empty() || !std::filesystem::exists(var + "/" + std::string(subpath)))                   \
  GTEST_SKIP() << "real data not found: set ORPE_DATA_DIR to the shared data folder (needs '"      \
               << (subpath) << "')"
