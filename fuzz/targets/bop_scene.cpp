// BOP scene JSON files (io/dataset_bop.cpp): part 1 = scene_camera.json, optional part 2 =
// scene_gt.json, optional part 3 = scene_gt_info.json (parts separated by a line "--").
#include "support/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace orpe::fuzz;
  static const std::string scene = [] {
    (void)scratch_path("bop/000000/x");
    return scratch_dir() + "/bop/000000";
  }();
  const auto parts = split_parts(data, size, 3);
  write_file(scene + "/scene_camera.json", parts[0]);
  write_or_remove(scene + "/scene_gt.json", parts.size() > 1 ? parts[1] : "", parts.size() > 1);
  write_or_remove(scene + "/scene_gt_info.json", parts.size() > 2 ? parts[2] : "",
                  parts.size() > 2);
  expect_clean_refusal([&] { read_dataset_annotations(scene, "bop"); });
  return 0;
}
