// TUM RGB-D index files (io/dataset_tum.cpp): one part = associations.txt; two or three parts =
// rgb.txt, depth.txt and optionally groundtruth.txt (parts separated by a line "--").
#include "support/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace orpe::fuzz;
  static const std::string root = [] {
    (void)scratch_path("tum/x");  // creates the folder
    return scratch_dir() + "/tum";
  }();
  const auto parts = split_parts(data, size, 3);
  const bool associations = parts.size() == 1;
  write_or_remove(root + "/associations.txt", parts[0], associations);
  write_or_remove(root + "/rgb.txt", parts[0], !associations);
  write_or_remove(root + "/depth.txt", associations ? "" : parts[1], !associations);
  write_or_remove(root + "/groundtruth.txt", parts.size() > 2 ? parts[2] : "", parts.size() > 2);
  expect_clean_refusal([&] { read_dataset_annotations(root, "tum"); });
  return 0;
}
