// The fixtures of tests/nets/data, written by scripts/nets/maskrcnn_export.py fixtures, and the
// comparison every equivalence test uses.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "orpe/nets/maskrcnn.h"

namespace orpe::test {

inline std::string nets_data(const std::string& file) {
  return std::string(ORPE_SOURCE_DIR) + "/tests/nets/data/" + file;
}

/// Skips the test when orpe was built without LibTorch (ORPE_WITH_TORCH=OFF).
#define ORPE_REQUIRE_TORCH()                                                            \
  do {                                                                                  \
    if (!::orpe::nets::torch_built()) GTEST_SKIP() << "built with ORPE_WITH_TORCH=OFF"; \
  } while (0)

/// Largest |a - b| / max(|b|, 1) over the values (the equivalence tolerance of issue 16 is 1e-4:
/// relative for values above 1, absolute below, where a relative error is meaningless near 0).
template <class A, class B>
double max_relative_error(const A& a, const B& b, size_t n) {
  double worst = 0;
  for (size_t i = 0; i < n; ++i)
    worst = std::max(worst,
                     std::abs(double(a[i]) - double(b[i])) / std::max(std::abs(double(b[i])), 1.0));
  return worst;
}

}  // namespace orpe::test
