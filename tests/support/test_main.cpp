#include <gtest/gtest.h>
#include <spdlog/spdlog.h>

#include "support/test_data.h"

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  spdlog::set_level(spdlog::level::warn);
  // Takes ownership: removes each passing test's scratch folders (support/test_data.h).
  ::testing::UnitTest::GetInstance()->listeners().Append(new orpe::test::ScratchCleaner);
  return RUN_ALL_TESTS();
}
