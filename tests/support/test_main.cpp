#include <gtest/gtest.h>
#include <spdlog/spdlog.h>

#include <cstdlib>
#include <mutex>

#include "support/test_data.h"

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  spdlog::set_level(spdlog::level::warn);
  // Takes ownership: removes each passing test's scratch folders (support/test_data.h).
  ::testing::UnitTest::GetInstance()->listeners().Append(new orpe::test::ScratchCleaner);
  // The pipeline's model cache (pipeline.model_cache_dir=auto) of this process and the CLI runs it
  // starts: a scratch folder (made when first written), never the user's ~/.cache.
  if (!std::getenv("ORPE_CACHE_DIR")) {
    const auto dir = orpe::test::scratch_root() / "process_model_cache";
    ::setenv("ORPE_CACHE_DIR", dir.c_str(), 1);
    auto& reg = orpe::test::ScratchRegistry::get();
    std::lock_guard<std::mutex> lock(reg.mutex);
    reg.process_dirs.push_back(dir);
  }
  return RUN_ALL_TESTS();
}
