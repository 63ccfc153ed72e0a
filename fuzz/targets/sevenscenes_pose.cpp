// 7-Scenes pose files (io/dataset_7scenes.cpp): part 1 = frame-000000.pose.txt (4x4 matrix),
// optional part 2 = camera-intrinsics.txt (3x3 matrix), separated by a line "--".
#include "support/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace orpe::fuzz;
  static const std::string root = [] {
    const std::string depth = scratch_path("7scenes/frame-000000.depth.png");
    write_file(depth, "");  // only its name is read when the folder is opened
    return scratch_dir() + "/7scenes";
  }();
  const auto parts = split_parts(data, size, 2);
  write_file(root + "/frame-000000.pose.txt", parts[0]);
  write_or_remove(root + "/camera-intrinsics.txt", parts.size() > 1 ? parts[1] : "",
                  parts.size() > 1);
  expect_clean_refusal([&] { read_dataset_annotations(root, "7scenes"); });
  return 0;
}
