// Load time of the 21 YCB-Video meshes (models/<class>/textured_simple.obj, textures included)
// through load_mesh(). Prints per model: vertices, triangles, textured, and the median over
// `--repeat` passes of the whole set. Compare two builds in the same run (the machine is shared).
// Run: build/bin/orpe_bench_mesh_load [--repeat 5] [--no-textures]   (data: $ORPE_DATA_DIR or ../shared/data)
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "orpe/render/mesh_io.h"

int main(int argc, char** argv) {
  namespace fs = std::filesystem;
  int repeat = 5;
  bool textures = true;
  for (int i = 1; i < argc; ++i) {
    if (std::string(argv[i]) == "--repeat" && i + 1 < argc) repeat = std::max(1, std::atoi(argv[i + 1]));
    if (std::string(argv[i]) == "--no-textures") textures = false;
  }
  const char* env = std::getenv("ORPE_DATA_DIR");
  const fs::path models = fs::path(env && *env ? env : "../shared/data") / "ycbv" / "models";
  std::vector<fs::path> files;
  for (const auto& d : fs::directory_iterator(models))
    if (fs::exists(d.path() / "textured_simple.obj"))
      files.push_back(d.path() / "textured_simple.obj");
  std::sort(files.begin(), files.end());
  if (files.empty()) {
    std::fprintf(stderr, "mesh_load: no models under %s\n", models.c_str());
    return 1;
  }
  std::vector<double> pass_s;
  orpe::MeshLoadOptions opt;
  opt.warn_missing_texture = false;
  opt.load_texture = textures;
  for (int r = 0; r < repeat; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    for (const auto& f : files) {
      const orpe::TriangleMesh m = orpe::load_mesh(f.string(), opt);
      if (r == 0)
        std::printf("%-28s %7zu vertices %7zu triangles %s\n", f.parent_path().filename().c_str(),
                    m.num_vertices(), m.num_triangles(), m.has_texture() ? "textured" : "");
    }
    pass_s.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  std::sort(pass_s.begin(), pass_s.end());
  std::printf("%zu models, median over %d passes: %.3f s per pass (min %.3f)\n", files.size(),
              repeat, pass_s[pass_s.size() / 2], pass_s.front());
  return 0;
}
