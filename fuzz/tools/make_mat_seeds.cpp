// Writes the seed meta.mat files of the ycbv_meta fuzz target into the folder given (MAT v5, a few
// hundred bytes each, made up here: no dataset file is copied). docs/FUZZING.md.
#include <matio.h>

#include <cstdio>
#include <string>
#include <vector>

namespace {

struct Var {
  const char* name;
  std::vector<size_t> dims;
  std::vector<double> values;
};

bool write_mat(const std::string& path, const std::vector<Var>& vars, matio_compression z) {
  mat_t* mat = Mat_CreateVer(path.c_str(), nullptr, MAT_FT_MAT5);
  if (!mat) return false;
  for (const Var& v : vars) {
    std::vector<double> d = v.values;
    std::vector<size_t> dims = v.dims;
    matvar_t* var = Mat_VarCreate(v.name, MAT_C_DOUBLE, MAT_T_DOUBLE, static_cast<int>(dims.size()),
                                  dims.data(), d.data(), 0);
    if (!var || Mat_VarWrite(mat, var, z) != 0) return false;
    Mat_VarFree(var);
  }
  Mat_Close(mat);
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s OUT_DIR\n", argv[0]);
    return 2;
  }
  const std::string dir = argv[1];
  const std::vector<double> K = {1066.8, 0, 0, 0, 1067.5, 0, 313.0, 241.3, 1};
  const std::vector<double> Rt = {1, 0, 0, 0, 1, 0, 0, 0, 1, 0.1, -0.2, 0.5};
  std::vector<double> two_poses = Rt;
  two_poses.insert(two_poses.end(), {0, 1, 0, -1, 0, 0, 0, 0, 1, 0.0, 0.1, 0.7});
  const std::vector<Var> full = {{"cls_indexes", {2, 1}, {1, 2}},
                                 {"factor_depth", {1, 1}, {10000}},
                                 {"intrinsic_matrix", {3, 3}, K},
                                 {"rotation_translation_matrix", {3, 4}, Rt},
                                 {"poses", {3, 4, 2}, two_poses}};
  const std::vector<Var> one = {
      {"cls_indexes", {1, 1}, {2}}, {"factor_depth", {1, 1}, {10000}}, {"poses", {3, 4}, Rt}};
  const std::vector<Var> no_objects = {{"factor_depth", {1, 1}, {10000}},
                                       {"intrinsic_matrix", {3, 3}, K}};
  bool ok = write_mat(dir + "/full.mat", full, MAT_COMPRESSION_NONE);
  ok = ok && write_mat(dir + "/full_zlib.mat", full, MAT_COMPRESSION_ZLIB);
  ok = ok && write_mat(dir + "/one_object.mat", one, MAT_COMPRESSION_NONE);
  ok = ok && write_mat(dir + "/no_objects.mat", no_objects, MAT_COMPRESSION_NONE);
  if (!ok) std::fprintf(stderr, "cannot write the seeds into %s\n", dir.c_str());
  return ok ? 0 : 1;
}
