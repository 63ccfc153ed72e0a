// OBJ meshes (render/mesh_io.h load_mesh: YCB-Video textured_simple.obj): part 1 = mesh.obj,
// optional part 2 = m.mtl (the material library an OBJ names with "mtllib m.mtl").
#include "orpe/render/mesh_io.h"
#include "support/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace orpe::fuzz;
  static const std::string path = scratch_path("obj/mesh.obj");
  static const std::string mtl = scratch_path("obj/m.mtl");
  const auto parts = split_parts(data, size, 2);
  write_file(path, parts[0]);
  write_or_remove(mtl, parts.size() > 1 ? parts[1] : "", parts.size() > 1);
  orpe::MeshLoadOptions options;
  options.warn_missing_texture = false;
  expect_clean_refusal([&] { (void)orpe::load_mesh(path, options); });
  return 0;
}
