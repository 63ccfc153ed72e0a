#include "orpe/io/models_folder.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <filesystem>
#include <set>
#include <sstream>
#include <stdexcept>

#include "orpe/core/error.h"
#include "orpe/render/mesh_io.h"

namespace orpe {
namespace fs = std::filesystem;
namespace {

struct FolderModel {
  std::string name;
  std::string mesh_path;
  std::string points_path;  // points.xyz in a per-object folder, else the mesh
};

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

bool is_mesh_file(const fs::path& p) {
  static const std::set<std::string> kMesh = {".obj", ".ply", ".stl", ".gltf", ".glb",
                                              ".dae", ".off", ".fbx", ".3ds"};
  return fs::is_regular_file(p) && kMesh.count(lower(p.extension().string())) > 0;
}

std::vector<fs::path> sorted_entries(const fs::path& dir) {
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(dir)) out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}

/// The mesh of a per-object folder: textured_simple.obj / textured.obj, else the only mesh file.
std::optional<FolderModel> object_folder_model(const fs::path& dir) {
  std::vector<fs::path> meshes;
  for (const auto& p : sorted_entries(dir))
    if (is_mesh_file(p)) meshes.push_back(p);
  if (meshes.empty()) return std::nullopt;
  fs::path mesh;
  for (const char* preferred : {"textured_simple.obj", "textured.obj"})
    if (fs::exists(dir / preferred)) mesh = dir / preferred;
  if (mesh.empty()) {
    if (meshes.size() > 1)
      throw IoError(dir.string(),
                    fmt::format("{} mesh files in one object folder; keep one, or name the one to "
                                "use textured.obj",
                                meshes.size()));
    mesh = meshes.front();
  }
  FolderModel m{dir.filename().string(), mesh.string(), mesh.string()};
  if (fs::exists(dir / "points.xyz")) m.points_path = (dir / "points.xyz").string();
  return m;
}

std::vector<FolderModel> scan_models(const fs::path& dir) {
  if (!fs::is_directory(dir)) throw IoError(dir.string(), "models folder not found");
  std::vector<FolderModel> models;
  for (const auto& p : sorted_entries(dir)) {
    if (fs::is_directory(p)) {
      if (auto m = object_folder_model(p)) models.push_back(*m);
    } else if (is_mesh_file(p)) {
      models.push_back({p.stem().string(), p.string(), p.string()});
    }
  }
  if (models.empty())
    throw IoError(dir.string(),
                  "no object meshes (.obj, .ply, .stl, .gltf, ...) in the models "
                  "folder or its sub-folders");
  std::set<std::string> names;
  for (const auto& m : models)
    if (!names.insert(m.name).second)
      throw IoError(dir.string(), "two models named '" + m.name + "' (class names must differ)");
  return models;
}

/// Units per metre of the files: stated, or detected from bounding-box diagonals.
double models_units_per_m(const std::vector<FolderModel>& models, const std::string& unit,
                          const std::string& dir) {
  if (unit == "m") return 1.0;
  if (unit == "mm") return 1000.0;
  double lo = INFINITY, hi = 0;
  std::string lo_name, hi_name;
  MeshLoadOptions opt;
  opt.load_texture = false;
  for (const auto& m : models) {
    const TriangleMesh mesh = load_mesh(m.mesh_path, opt);
    const double d = mesh.bounds().diagonal().norm();
    if (d < lo) lo = d, lo_name = m.name;
    if (d > hi) hi = d, hi_name = m.name;
  }
  if (lo >= 0.01 && hi <= 5.0) return 1.0;
  if (lo >= 10.0 && hi <= 5000.0) return 1000.0;
  throw IoError(dir, fmt::format("cannot tell whether the models are in metres or millimetres "
                                 "(bounding-box diagonals {:.4g} ({}) to {:.4g} ({}) file units); "
                                 "set dataset.models_unit=m or mm",
                                 lo, lo_name, hi, hi_name));
}

/// obj_000005 / 000005 -> 5; else nullopt.
std::optional<int> numeric_name(const std::string& name) {
  std::string digits = name.rfind("obj_", 0) == 0 ? name.substr(4) : name;
  if (digits.empty() || digits.size() > 9 ||
      !std::all_of(digits.begin(), digits.end(), [](unsigned char c) { return std::isdigit(c); }))
    return std::nullopt;
  const int id = std::stoi(digits);
  return id > 0 ? std::optional<int>(id) : std::nullopt;
}

std::map<std::string, int> assign_class_ids(const std::vector<FolderModel>& models,
                                            const DatasetInfo& info) {
  std::map<std::string, int> ids;
  std::set<int> used;
  for (const auto& m : models) {
    for (const auto& [id, name] : info.class_names)
      if (name == m.name) ids[m.name] = id;
    if (!ids.count(m.name))
      if (auto n = numeric_name(m.name)) ids[m.name] = *n;
    if (ids.count(m.name) && !used.insert(ids[m.name]).second)
      throw IoError(m.mesh_path, fmt::format("class id {} given to two models", ids[m.name]));
  }
  int next = 1;
  for (const auto& m : models) {
    if (ids.count(m.name)) continue;
    while (used.count(next) || info.class_names.count(next)) ++next;
    ids[m.name] = next;
    used.insert(next);
    if (!info.class_names.empty())
      spdlog::warn("{}: model '{}' matches no class of the dataset; it is class {}", m.mesh_path,
                   m.name, next);
  }
  return ids;
}

Eigen::Vector3d axis_of(const std::string& word) {
  if (word == "x") return Eigen::Vector3d::UnitX();
  if (word == "y") return Eigen::Vector3d::UnitY();
  if (word == "z") return Eigen::Vector3d::UnitZ();
  throw std::invalid_argument("axis '" + word + "' must be x, y or z");
}

std::map<std::string, std::optional<ModelSymmetrySpec>> read_symmetry_file(
    const std::string& path, const std::map<std::string, int>& ids) {
  std::map<std::string, std::optional<ModelSymmetrySpec>> out;
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    throw IoError(path, fmt::format("line {}: not valid YAML: {}", e.mark.line + 1, e.msg));
  }
  if (root.IsNull()) return out;
  if (!root.IsMap()) throw IoError(path, "expected 'model name: symmetry' lines");
  for (const auto& kv : root) {
    const int line = kv.first.Mark().line + 1;
    // A sequence or map as the key made as<std::string>() throw a bare YAML::BadConversion (fuzz).
    if (!kv.first.IsScalar())
      throw IoError(path, fmt::format("line {}: a model name must be a plain word, not a list or "
                                      "a map",
                                      line));
    const std::string name = kv.first.as<std::string>();
    if (!ids.count(name))
      throw IoError(path, fmt::format("line {}: no model named '{}' in the folder", line, name));
    if (!kv.second.IsScalar())
      throw IoError(path, fmt::format("line {}: '{}': expected none | auto | continuous x|y|z | "
                                      "flip x [y] [z]",
                                      line, name));
    try {
      out[name] = parse_symmetry_spec(kv.second.as<std::string>());
    } catch (const std::invalid_argument& e) {
      throw IoError(path, fmt::format("line {}: '{}': {}", line, name, e.what()));
    }
  }
  return out;
}

}  // namespace

std::optional<ModelSymmetrySpec> parse_symmetry_spec(const std::string& text) {
  std::istringstream is(text);
  std::vector<std::string> words;
  for (std::string w; is >> w;) words.push_back(lower(w));
  const std::string expected =
      "expected none | auto | symmetric | continuous x|y|z | flip x [y] [z], got '" + text + "'";
  if (words.empty()) throw std::invalid_argument(expected);
  ModelSymmetrySpec spec;
  spec.text = text;
  if (words[0] == "auto" && words.size() == 1) return std::nullopt;
  if (words[0] == "none" && words.size() == 1) {
    spec.none = true;
  } else if (words[0] == "symmetric" && words.size() == 1) {
    spec.detected = true;
  } else if (words[0] == "continuous" && words.size() == 2) {
    spec.continuous = true;
    spec.axis = axis_of(words[1]);
  } else if (words[0] == "flip" && words.size() >= 2 && words.size() <= 4) {
    for (size_t i = 1; i < words.size(); ++i) spec.flip_axes.push_back(axis_of(words[i]));
  } else {
    throw std::invalid_argument(expected);
  }
  return spec;
}

void apply_models_folder(DatasetInfo& info, const std::string& dir, const std::string& unit) {
  const std::vector<FolderModel> models = scan_models(dir);
  const double units_per_m = models_units_per_m(models, unit, dir);
  const std::map<std::string, int> ids = assign_class_ids(models, info);
  std::map<std::string, std::optional<ModelSymmetrySpec>> symmetry;
  const fs::path sidecar = fs::path(dir) / "symmetry.yaml";
  if (fs::exists(sidecar)) symmetry = read_symmetry_file(sidecar.string(), ids);

  const std::vector<int> dataset_symmetric = info.symmetric_classes;
  info.model_points_paths.clear();
  info.model_mesh_paths.clear();
  info.symmetric_classes.clear();
  info.model_symmetry.clear();
  info.model_units_per_m = units_per_m;
  info.models_dir = dir;
  for (const auto& m : models) {
    const int id = ids.at(m.name);
    info.class_names[id] = m.name;
    info.model_points_paths[id] = m.points_path;
    info.model_mesh_paths[id] = m.mesh_path;
    bool symmetric = std::count(dataset_symmetric.begin(), dataset_symmetric.end(), id) > 0;
    if (auto it = symmetry.find(m.name); it != symmetry.end() && it->second) {
      info.model_symmetry[id] = *it->second;
      symmetric = !it->second->none;
    }
    if (symmetric) info.symmetric_classes.push_back(id);
  }
  spdlog::info("models: {} objects from {} ({})", models.size(), dir,
               units_per_m == 1.0 ? "metres" : "millimetres");
}

}  // namespace orpe
