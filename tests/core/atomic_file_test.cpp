#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "orpe/core/atomic_file.h"
#include "orpe/core/error.h"
#include "support/test_data.h"

namespace orpe {
namespace {

TEST(AtomicFile, WritesAndLeavesNoTemporaries) {
  const std::string dir = test::scratch_dir("a");
  const std::string path = dir + "/sub/out.txt";
  write_file_atomic(path, [](std::ostream& os) { os << "hello"; });
  std::ifstream is(path);
  std::string s;
  is >> s;
  EXPECT_EQ(s, "hello");
  int files = 0;
  for (auto& e : std::filesystem::directory_iterator(dir + "/sub")) (void)e, ++files;
  EXPECT_EQ(files, 1);
}

TEST(AtomicFile, FailureKeepsThePreviousFile) {
  const std::string dir = test::scratch_dir("b");
  const std::string path = dir + "/out.txt";
  write_file_atomic(path, [](std::ostream& os) { os << "old"; });
  EXPECT_THROW(write_file_atomic(path,
                                 [](std::ostream& os) {
                                   os << "half";
                                   throw IoError("x", "simulated failure");
                                 }),
               IoError);
  std::ifstream is(path);
  std::string s;
  is >> s;
  EXPECT_EQ(s, "old");
  int files = 0;
  for (auto& e : std::filesystem::directory_iterator(dir)) (void)e, ++files;
  EXPECT_EQ(files, 1);
}

}  // namespace
}  // namespace orpe
