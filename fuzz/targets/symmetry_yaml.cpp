// A models folder's symmetry.yaml (io/models_folder.h apply_models_folder, `--models DIR`;
// yaml-cpp): the input is the file, beside four empty mesh files (mug, box, obj_000005,
// 002_master_chef_can) that the unit given as "m" keeps from being loaded.
#include "orpe/io/models_folder.h"
#include "support/fuzz_support.h"

namespace {

const std::string& models_dir() {
  static const std::string dir = [] {
    for (const char* mesh : {"mug.ply", "box.obj", "obj_000005.ply", "002_master_chef_can.ply"})
      orpe::fuzz::write_file(orpe::fuzz::scratch_path(std::string("models/") + mesh), "");
    return orpe::fuzz::scratch_path("models");
  }();
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace orpe::fuzz;
  const std::string& dir = models_dir();
  write_file(dir + "/symmetry.yaml", std::string_view(reinterpret_cast<const char*>(data), size));
  expect_clean_refusal([&] {
    orpe::DatasetInfo info;
    orpe::apply_models_folder(info, dir, "m");
  });
  return 0;
}
