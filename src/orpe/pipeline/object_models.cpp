#include "orpe/pipeline/object_models.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <random>

#include "orpe/core/error.h"
#include "orpe/io/model_io.h"
#include "orpe/pipeline/model_cache.h"
#include "orpe/pose/colour_score.h"
#include "orpe/render/mesh_io.h"

namespace orpe {
namespace {

std::string class_name_of(const DatasetInfo& info, int class_id) {
  const auto it = info.class_names.find(class_id);
  return it != info.class_names.end() ? it->second : fmt::format("class {}", class_id);
}

std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return ext;
}

/// Area-weighted uniform samples on the triangles with the face normals (deterministic).
void sample_mesh_surface(const TriangleMesh& mesh, int count, ObjectModel& model) {
  std::vector<double> cumulative_area;
  std::vector<Eigen::Vector3f> face_normal;
  cumulative_area.reserve(mesh.triangles.size());
  double total = 0;
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3f a = mesh.vertices[t[0]], b = mesh.vertices[t[1]], c = mesh.vertices[t[2]];
    const Eigen::Vector3f n = (b - a).cross(c - a);
    total += 0.5 * n.norm();
    cumulative_area.push_back(total);
    face_normal.push_back(n.norm() > 0 ? Eigen::Vector3f(n.normalized())
                                       : Eigen::Vector3f::UnitZ());
  }
  if (!(total > 0)) return;
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  model.points.reserve(count);
  model.normals.reserve(count);
  for (int i = 0; i < count; ++i) {
    const double r = uni(rng) * total;
    const size_t k =
        std::min<size_t>(std::lower_bound(cumulative_area.begin(), cumulative_area.end(), r) -
                             cumulative_area.begin(),
                         mesh.triangles.size() - 1);
    double s = uni(rng), t = uni(rng);
    if (s + t > 1) {
      s = 1 - s;
      t = 1 - t;
    }
    const auto& tri = mesh.triangles[k];
    const Eigen::Vector3f a = mesh.vertices[tri[0]], b = mesh.vertices[tri[1]],
                          c = mesh.vertices[tri[2]];
    model.points.push_back(a + static_cast<float>(s) * (b - a) + static_cast<float>(t) * (c - a));
    model.normals.push_back(face_normal[k]);
  }
}

/// The annotated symmetry group of one object in a BOP models_info.json (translations in the
/// file's units, divided by units_per_m), or nullopt when the file or the entry has none.
std::optional<ObjectSymmetry> read_bop_symmetry(const std::string& path, int class_id,
                                                double units_per_m) {
  if (!std::filesystem::exists(path)) return std::nullopt;
  std::ifstream is(path);
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(is);
  } catch (const std::exception& e) {
    throw IoError(path, std::string("not valid JSON: ") + e.what());
  }
  const std::string key = std::to_string(class_id);
  if (!j.is_object() || !j.contains(key) || !j.at(key).is_object()) return std::nullopt;
  const nlohmann::json& m = j.at(key);
  ObjectSymmetry sym;
  try {
    if (m.contains("symmetries_discrete"))
      for (const auto& d : m.at("symmetries_discrete")) {
        if (!d.is_array() || d.size() != 16)
          throw IoError(path, "a discrete symmetry needs 16 numbers");
        Mat3 R;
        Vec3 t;
        for (int r = 0; r < 3; ++r) {
          for (int c = 0; c < 3; ++c) R(r, c) = d.at(4 * r + c).get<double>();
          t[r] = d.at(4 * r + 3).get<double>() / units_per_m;
        }
        sym.discrete.emplace_back(orthonormalize(R), t);
      }
    if (m.contains("symmetries_continuous") && !m.at("symmetries_continuous").empty()) {
      const auto& c = m.at("symmetries_continuous").at(0);
      for (int k = 0; k < 3; ++k) {
        sym.axis_obj[k] = c.at("axis").at(k).get<double>();
        sym.axis_point_obj[k] = c.at("offset").at(k).get<double>() / units_per_m;
      }
      if (!(sym.axis_obj.norm() > 1e-9)) throw IoError(path, "zero continuous symmetry axis");
      sym.axis_obj.normalize();
      sym.continuous = true;
    }
  } catch (const nlohmann::json::exception& e) {
    throw IoError(path, fmt::format("object {}: malformed symmetry: {}", class_id, e.what()));
  }
  if (!sym.continuous && sym.discrete.empty()) return std::nullopt;
  return sym;
}

/// A models folder's stated symmetry (symmetry.yaml) as the pose stage's group: axes through the
/// object frame's origin.
ObjectSymmetry symmetry_from_spec(const ModelSymmetrySpec& spec) {
  ObjectSymmetry sym;
  if (spec.none) return sym;
  if (spec.continuous) {
    sym.continuous = true;
    sym.axis_obj = spec.axis;
    return sym;
  }
  for (const Eigen::Vector3d& axis : spec.flip_axes)
    sym.discrete.emplace_back(Eigen::AngleAxisd(M_PI, axis).toRotationMatrix(), Vec3::Zero());
  return sym;
}

}  // namespace

namespace {

/// What the class's model files give (points, normals, diameter, spacing, detected symmetry,
/// colour); the paths of the files read or looked for go to `files_read`.
ObjectModel load_model_files(const DatasetInfo& info, int class_id, int surface_points,
                             std::vector<std::string>* files_read) {
  const std::string& points = info.model_points_paths.at(class_id);
  const auto mesh = info.model_mesh_paths.find(class_id);
  const std::string name = class_name_of(info, class_id);
  if (lower_extension(points) == ".xyz") {
    ModelLoadOptions mo;
    mo.units_per_m = info.model_units_per_m;
    if (mesh != info.model_mesh_paths.end() && lower_extension(mesh->second) != ".xyz")
      mo.mesh_path = mesh->second;
    mo.files_read = files_read;
    return load_object_model(points, mo, class_id, name);
  }
  // A mesh: BOP / orpe synth PLY, a models folder.
  MeshLoadOptions mo;
  mo.metres_per_unit = 1.0 / info.model_units_per_m;
  mo.warn_missing_texture = false;
  mo.files_read = files_read;
  const TriangleMesh m = load_mesh(points, mo);
  ObjectModel model;
  model.colour = model_colour_from_mesh(m);
  model.class_id = class_id;
  model.name = name;
  if (!m.triangles.empty()) sample_mesh_surface(m, surface_points, model);
  if (model.points.empty()) {  // a point cloud PLY: its vertices, PCA normals
    model.points = m.vertices;
    model.normals.clear();
  }
  try {
    prepare_object_model(model);
  } catch (const std::invalid_argument& e) {
    throw IoError(points, e.what());
  }
  model.symmetry = detect_symmetry(model);
  return model;
}

/// What the dataset says of the class beyond its files: name, metric symmetry, stated symmetry.
void apply_dataset_annotations(const DatasetInfo& info, int class_id, ObjectModel& model) {
  model.class_id = class_id;
  model.name = class_name_of(info, class_id);
  model.symmetric_for_metric =
      std::count(info.symmetric_classes.begin(), info.symmetric_classes.end(), class_id) > 0;
  if (const auto spec = info.model_symmetry.find(class_id);
      spec != info.model_symmetry.end() && !spec->second.detected)
    model.symmetry = symmetry_from_spec(spec->second);
}

std::string absolute_or_empty(const std::string& path) {
  return path.empty() ? path : std::filesystem::absolute(path).lexically_normal().string();
}

/// The model's files, as the cache tells models apart: its points file (first line) and mesh.
std::string model_identity(const DatasetInfo& info, int class_id) {
  const auto mesh = info.model_mesh_paths.find(class_id);
  return absolute_or_empty(info.model_points_paths.at(class_id)) + "\n" +
         absolute_or_empty(mesh != info.model_mesh_paths.end() ? mesh->second : "");
}

/// Every option of load_model_files that changes its result.
std::uint64_t model_options_hash(const DatasetInfo& info, int surface_points) {
  return fnv1a64(fmt::format("version {} units_per_m {:a} surface_points {}", kModelCacheVersion,
                             info.model_units_per_m, surface_points));
}

}  // namespace

ObjectModel load_dataset_object_model(const DatasetInfo& info, int class_id, int surface_points,
                                      const ModelCache* cache) {
  if (!info.model_points_paths.count(class_id))
    throw IoError(info.root, fmt::format("the dataset has no model for class {}", class_id));
  std::optional<ObjectModel> model;
  const bool cached = cache && cache->enabled();
  const std::string identity = cached ? model_identity(info, class_id) : "";
  const std::uint64_t options = model_options_hash(info, surface_points);
  if (cached) model = cache->load(identity, options);
  if (!model) {
    std::vector<std::string> files;
    model = load_model_files(info, class_id, surface_points, cached ? &files : nullptr);
    if (cached) cache->store(identity, options, files, *model);
  }
  apply_dataset_annotations(info, class_id, *model);
  return std::move(*model);
}

ObjectModelLibrary::~ObjectModelLibrary() = default;

void ObjectModelLibrary::set_cache_dir(std::string dir) {
  cache_ = std::make_unique<ModelCache>(std::move(dir));
}

std::unique_ptr<ObjectModel> ObjectModelLibrary::load(int class_id) const {
  auto model = std::make_unique<ObjectModel>(
      load_dataset_object_model(info_, class_id, surface_points_, cache_.get()));
  if (!colour_dir_.empty()) {
    const std::string path = colour_dir_ + "/" + class_name(class_id) + ".colour";
    if (std::filesystem::is_regular_file(path)) model->colour = read_model_colour(path);
  }
  return model;
}

const ObjectModel& ObjectModelLibrary::get(int class_id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto& slot = models_[class_id];
  if (!slot) slot = load(class_id);
  return *slot;
}

void ObjectModelLibrary::preload(const std::vector<int>& class_ids, int threads) const {
  std::vector<int> todo;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (int id : class_ids)
      if (!models_[id] && std::find(todo.begin(), todo.end(), id) == todo.end()) todo.push_back(id);
  }
  std::vector<std::unique_ptr<ObjectModel>> loaded(todo.size());
  std::vector<std::exception_ptr> errors(todo.size());
  const int n = static_cast<int>(todo.size());
#pragma omp parallel for schedule(dynamic, 1) num_threads(std::max(1, threads))
  for (int i = 0; i < n; ++i) {
    try {
      loaded[i] = load(todo[i]);
    } catch (...) {  // an exception must not leave the parallel loop
      errors[i] = std::current_exception();
    }
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (size_t i = 0; i < todo.size(); ++i)
      if (loaded[i] && !models_[todo[i]]) models_[todo[i]] = std::move(loaded[i]);
  }
  for (const std::exception_ptr& e : errors)
    if (e) std::rethrow_exception(e);
}

ObjectSymmetry ObjectModelLibrary::ekf_symmetry(int class_id, const std::string& mode) const {
  if (mode == "none") return {};
  const ObjectModel& model = get(class_id);
  if (mode == "geometric") return model.symmetry;
  if (!model.symmetric_for_metric) return {};
  if (info_.format == "bop") {
    const auto mesh = info_.model_mesh_paths.find(class_id);
    if (mesh != info_.model_mesh_paths.end()) {
      const std::string path =
          (std::filesystem::path(mesh->second).parent_path() / "models_info.json").string();
      if (auto annotated = read_bop_symmetry(path, class_id, info_.model_units_per_m))
        return *annotated;
    }
  }
  return model.symmetry;
}

std::string ObjectModelLibrary::class_name(int class_id) const {
  return class_name_of(info_, class_id);
}

namespace {

/// Extent of every `stride`-th model point along the unit direction (theta, phi) (m).
double extent_along(const ObjectModel& model, size_t stride, double theta, double phi) {
  const Eigen::Vector3f dir(static_cast<float>(std::sin(theta) * std::cos(phi)),
                            static_cast<float>(std::sin(theta) * std::sin(phi)),
                            static_cast<float>(std::cos(theta)));
  float lo = std::numeric_limits<float>::infinity(), hi = -lo;
  for (size_t i = 0; i < model.points.size(); i += stride) {
    const float t = dir.dot(model.points[i]);
    lo = std::min(lo, t);
    hi = std::max(hi, t);
  }
  return hi - lo;
}

}  // namespace

double model_min_width_m(const ObjectModel& model) {
  if (model.points.empty()) return 0;
  // Coarse: 1000 directions on a Fibonacci half-sphere (a direction and its opposite give one
  // extent); then a pattern search in (theta, phi) around the best, halving the step 12 times.
  constexpr int kDirections = 1000;
  const size_t stride = std::max<size_t>(1, model.points.size() / 4000);
  double best = std::numeric_limits<double>::infinity(), theta = 0, phi = 0;
  for (int k = 0; k < kDirections; ++k) {
    const double t = std::acos(1.0 - (k + 0.5) / kDirections);
    const double f = k * M_PI * (3.0 - std::sqrt(5.0));
    const double e = extent_along(model, stride, t, f);
    if (e < best) best = e, theta = t, phi = f;
  }
  for (double step = 0.1; step > 1e-4; step /= 2) {
    bool moved = true;
    while (moved) {
      moved = false;
      for (const auto& [dt, dp] : {std::pair{step, 0.0}, {-step, 0.0}, {0.0, step}, {0.0, -step}}) {
        const double e = extent_along(model, stride, theta + dt, phi + dp);
        if (e < best - 1e-9) best = e, theta += dt, phi += dp, moved = true;
      }
    }
  }
  return best;
}

}  // namespace orpe
