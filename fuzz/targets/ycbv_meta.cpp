// YCB-Video meta.mat (io/dataset_ycbv.cpp, libmatio): the input is data/0000/000001-meta.mat of a
// one-frame video; classes.txt lists two classes.
#include "support/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace orpe::fuzz;
  static const std::string video = [] {
    write_file(scratch_path("ycbv/classes.txt"), "002_master_chef_can\n003_cracker_box\n");
    return scratch_dir() + "/ycbv/data/0000";
  }();
  static const std::string meta = scratch_path("ycbv/data/0000/000001-meta.mat");
  write_file(meta, std::string_view(reinterpret_cast<const char*>(data), size));
  expect_clean_refusal([&] { read_dataset_annotations(video, "ycbv"); });
  return 0;
}
