// BOP models_info.json, read by both readers: the dataset's symmetric classes (io/dataset_bop.cpp,
// a scene with models/obj_000001.ply) and the BOP pose evaluation's diameters and symmetries
// (eval/bop_pose_errors.h).
#include "orpe/eval/bop_pose_errors.h"
#include "support/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace orpe::fuzz;
  static const std::string scene = [] {
    write_file(scratch_path("bopm/000000/scene_camera.json"),
               R"({"0": {"cam_K": [500, 0, 320, 0, 500, 240, 0, 0, 1], "depth_scale": 1.0}})");
    write_file(scratch_path("bopm/models/obj_000001.ply"), "");  // only its name is read
    return scratch_dir() + "/bopm/000000";
  }();
  static const std::string info = scratch_dir() + "/bopm/models/models_info.json";
  write_file(info, std::string_view(reinterpret_cast<const char*>(data), size));
  expect_clean_refusal([&] { (void)orpe::read_bop_models_info(info); });
  expect_clean_refusal([&] { read_dataset_annotations(scene, "bop"); });
  return 0;
}
