// TUM trajectory files (io/trajectory_io.h: groundtruth.txt, orpe's trajectory.txt, eval traj).
#include "orpe/io/trajectory_io.h"
#include "support/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace orpe::fuzz;
  static const std::string path = scratch_path("trajectory.txt");
  write_file(path, std::string_view(reinterpret_cast<const char*>(data), size));
  expect_clean_refusal([&] { (void)orpe::read_tum_trajectory(path); });
  return 0;
}
