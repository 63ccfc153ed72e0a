// Camera files (io/camera_file.h read_camera_file: `--camera FILE`, `dataset.camera_file`, a plain
// folder's camera.yaml), YAML read with cv::FileStorage: the input is the file.
#include "orpe/io/camera_file.h"
#include "support/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace orpe::fuzz;
  static const std::string path = scratch_path("camera.yaml");
  write_file(path, std::string_view(reinterpret_cast<const char*>(data), size));
  expect_clean_refusal([&] { (void)orpe::read_camera_file(path); });
  return 0;
}
