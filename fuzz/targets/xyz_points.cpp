// YCB-Video points.xyz model points (io/model_io.h).
#include "orpe/io/model_io.h"
#include "support/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace orpe::fuzz;
  static const std::string path = scratch_path("points.xyz");
  write_file(path, std::string_view(reinterpret_cast<const char*>(data), size));
  expect_clean_refusal([&] { (void)orpe::read_model_points(path, 1.0); });
  return 0;
}
