// PLY meshes (render/mesh_io.h load_mesh: BOP models, synth objects, colour models).
#include "orpe/render/mesh_io.h"
#include "support/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace orpe::fuzz;
  static const std::string path = scratch_path("mesh.ply");
  write_file(path, std::string_view(reinterpret_cast<const char*>(data), size));
  orpe::MeshLoadOptions options;
  options.metres_per_unit = 0.001;
  options.warn_missing_texture = false;
  expect_clean_refusal([&] { (void)orpe::load_mesh(path, options); });
  return 0;
}
