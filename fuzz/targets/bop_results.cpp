// BOP results CSV (io/bop_results.h: orpe's poses.csv, the input of `orpe eval poses`).
#include "orpe/io/bop_results.h"
#include "support/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace orpe::fuzz;
  static const std::string path = scratch_path("poses.csv");
  write_file(path, std::string_view(reinterpret_cast<const char*>(data), size));
  expect_clean_refusal([&] { (void)orpe::read_bop_results(path); });
  return 0;
}
