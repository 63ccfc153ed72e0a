// PLY point clouds (io/ply_format.cpp): model points (io/model_io.h, BOP models) and orpe's own
// map / object clouds (io/point_cloud_io.h); ascii and binary, both endians.
#include "orpe/io/model_io.h"
#include "orpe/io/point_cloud_io.h"
#include "support/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace orpe::fuzz;
  static const std::string path = scratch_path("points.ply");
  write_file(path, std::string_view(reinterpret_cast<const char*>(data), size));
  expect_clean_refusal([&] { (void)orpe::read_model_points(path, 1000.0); });
  expect_clean_refusal([&] { (void)orpe::read_point_cloud_ply(path); });
  return 0;
}
