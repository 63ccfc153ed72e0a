#include "orpe/pose/object_model.h"
#include "orpe/core/parse_number.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <fstream>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "orpe/core/error.h"
#include "orpe/io/model_io.h"
#include "orpe/pose/colour_score.h"
#include "orpe/pose/model_search.h"
#include "orpe/render/mesh_io.h"

namespace orpe {

SE3 ObjectSymmetry::continuous_element(double theta_rad) const {
  const Mat3 C = so3_exp(axis_obj.normalized() * theta_rad);
  return SE3(C, axis_point_obj - C * axis_point_obj);
}

std::string ObjectSymmetry::describe() const {
  std::ostringstream os;
  os.precision(3);
  if (continuous) {
    os << "continuous about (" << axis_obj.x() << "," << axis_obj.y() << "," << axis_obj.z() << ")";
    if (!discrete.empty()) os << " x " << discrete.size() + 1 << " discrete";
  } else if (!discrete.empty()) {
    os << "discrete, " << discrete.size() + 1 << " elements";
  } else {
    os << "none";
  }
  return os.str();
}

MeshVerticesNormals read_obj_vertices_normals(const std::string& path) {
  MeshLoadOptions opt;  // file units: the caller scales
  opt.load_texture = false;
  const TriangleMesh mesh = load_mesh(path, opt);
  return {mesh.vertices, mesh.normals};
}

double model_diameter_m(const std::vector<Eigen::Vector3f>& points) {
  const size_t max_points = 20000;
  const size_t step =
      points.size() > max_points ? (points.size() + max_points - 1) / max_points : 1;
  std::vector<Eigen::Vector3f> sub;
  for (size_t i = 0; i < points.size(); i += step) sub.push_back(points[i]);
  float best = 0;
#pragma omp parallel for reduction(max : best) schedule(dynamic, 64)
  for (size_t i = 0; i < sub.size(); ++i)
    for (size_t j = i + 1; j < sub.size(); ++j)
      best = std::max(best, (sub[i] - sub[j]).squaredNorm());
  return std::sqrt(static_cast<double>(best));
}

namespace {

Eigen::Vector3f centroid_of(const std::vector<Eigen::Vector3f>& pts) {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const auto& p : pts) c += p.cast<double>();
  return (c / static_cast<double>(pts.size())).cast<float>();
}

/// Mean distance from each point of `points`, moved by S, to the nearest model point.
double mean_distance_under(const ModelSearchIndex& index,
                           const std::vector<Eigen::Vector3f>& points, const SE3& S,
                           size_t stride) {
  const Eigen::Matrix3f R = S.rotation().cast<float>();
  const Eigen::Vector3f t = S.translation().cast<float>();
  double sum = 0;
  size_t n = 0;
  for (size_t i = 0; i < points.size(); i += stride, ++n) {
    float d2 = 0;
    index.nearest(R * points[i] + t, &d2);
    sum += std::sqrt(d2);
  }
  return n ? sum / static_cast<double>(n) : 0.0;
}

SE3 rotation_about(const Vec3& axis, double angle, const Vec3& point) {
  const Mat3 C = so3_exp(axis.normalized() * angle);
  return SE3(C, point - C * point);
}

}  // namespace

void prepare_object_model(ObjectModel& model) {
  if (model.points.size() < 4)
    throw std::invalid_argument("object model '" + model.name + "' has fewer than 4 points");
  for (const auto& p : model.points)
    if (!p.allFinite())
      throw std::invalid_argument("object model '" + model.name + "' has a non-finite point");
  if (!model.search_index || model.search_index->size() != model.points.size())
    model.search_index = std::make_shared<ModelSearchIndex>(model.points);
  if (model.diameter_m <= 0) model.diameter_m = model_diameter_m(model.points);
  if (model.mean_spacing_m <= 0) {
    const size_t stride = std::max<size_t>(1, model.points.size() / 2000);
    double sum = 0;
    size_t n = 0;
    for (size_t i = 0; i < model.points.size(); i += stride, ++n) {
      std::uint32_t idx[2];
      float d2[2];
      if (model.search_index->knn(model.points[i], 2, idx, d2) == 2) sum += std::sqrt(d2[1]);
    }
    model.mean_spacing_m = sum / static_cast<double>(std::max<size_t>(n, 1));
  }
  if (!model.has_normals()) {
    // PCA normals over the nearest neighbours, oriented away from the centroid (wrong inside
    // concave parts such as a bowl's inside; a mesh gives correct orientation).
    const Eigen::Vector3f c = centroid_of(model.points);
    model.normals.assign(model.points.size(), Eigen::Vector3f::UnitZ());
    const int k = static_cast<int>(std::min<size_t>(12, model.points.size()));
#pragma omp parallel for schedule(static)
    for (size_t i = 0; i < model.points.size(); ++i) {
      std::uint32_t idx[12];
      float d2[12];
      const int found = model.search_index->knn(model.points[i], k, idx, d2);
      Eigen::Vector3f mean = Eigen::Vector3f::Zero();
      for (int j = 0; j < found; ++j) mean += model.points[idx[j]];
      mean /= static_cast<float>(found);
      Eigen::Matrix3f cov = Eigen::Matrix3f::Zero();
      for (int j = 0; j < found; ++j) {
        const Eigen::Vector3f d = model.points[idx[j]] - mean;
        cov += d * d.transpose();
      }
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3f> es(cov);
      Eigen::Vector3f n = es.eigenvectors().col(0);
      if (n.dot(model.points[i] - c) < 0) n = -n;
      model.normals[i] = n.normalized();
    }
  }
}

ObjectModel load_object_model(const std::string& points_path, const ModelLoadOptions& options,
                              int class_id, const std::string& name) {
  ObjectModel model;
  model.class_id = class_id;
  model.name = name;
  if (!(options.units_per_m > 0)) throw IoError(points_path, "model units_per_m must be > 0");
  if (options.files_read) options.files_read->push_back(points_path);
  for (const Vec3& p : read_xyz_points(points_path, options.units_per_m))
    model.points.push_back(p.cast<float>());
  // The mesh is read once (assimp parses a YCB-Video OBJ in ~100 ms): its vertices' normals and,
  // when wanted, its colour come from the same TriangleMesh.
  std::optional<TriangleMesh> mesh;
  if (!options.mesh_path.empty()) {
    MeshLoadOptions mo;  // in metres, as the point file
    mo.metres_per_unit = 1.0 / options.units_per_m;
    mo.load_texture = options.load_colour;
    mo.warn_missing_texture = false;
    mo.files_read = options.files_read;
    mesh = load_mesh(options.mesh_path, mo);
    // Keep only vertices with a normal (faces reference them).
    std::vector<Eigen::Vector3f> verts, norms;
    for (size_t i = 0; i < mesh->vertices.size(); ++i)
      if (mesh->normals[i].squaredNorm() > 0.5f) {
        verts.push_back(mesh->vertices[i]);
        norms.push_back(mesh->normals[i]);
      }
    if (verts.empty()) throw IoError(options.mesh_path, "no vertex is used by a face");
    if (options.use_mesh_vertices) {
      model.points = verts;
      model.normals = norms;
    } else {
      const ModelSearchIndex mesh_index(verts);
      model.normals.resize(model.points.size());
      for (size_t i = 0; i < model.points.size(); ++i) {
        float d2;
        model.normals[i] = norms[mesh_index.nearest(model.points[i], &d2)];
      }
    }
  }
  try {
    prepare_object_model(model);
  } catch (const std::invalid_argument& e) {
    throw IoError(points_path, e.what());
  }
  if (options.detect_symmetry) model.symmetry = detect_symmetry(model);
  if (options.load_colour && mesh) model.colour = model_colour_from_mesh(*mesh);
  return model;
}

ObjectSymmetry detect_symmetry(const ObjectModel& model, double tolerance_m) {
  ObjectSymmetry sym;
  if (!model.search_index || model.points.size() < 4) return sym;
  const ModelSearchIndex& index = *model.search_index;
  const size_t stride = std::max<size_t>(1, model.points.size() / 1500);

  const double threshold = tolerance_m + model.mean_spacing_m;

  const Eigen::Vector3f c = centroid_of(model.points);
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : model.points) {
    const Eigen::Vector3d d = (p - c).cast<double>();
    cov += d * d.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  const Vec3 centre = c.cast<double>();
  auto maps_onto_itself = [&](const SE3& S) {
    return mean_distance_under(index, model.points, S, stride) < threshold;
  };

  // Continuous symmetry about a principal axis.
  for (int k = 0; k < 3 && !sym.continuous; ++k) {
    const Vec3 axis = es.eigenvectors().col(k);
    bool all = true;
    for (int deg = 30; deg <= 180 && all; deg += 30)
      all = maps_onto_itself(rotation_about(axis, deg * M_PI / 180.0, centre));
    if (all) {
      sym.continuous = true;
      sym.axis_obj = axis;
      sym.axis_point_obj = centre;
      for (int j = 0; j < 3; ++j) {
        if (j == k) continue;
        const SE3 flip = rotation_about(es.eigenvectors().col(j), M_PI, centre);
        if (maps_onto_itself(flip)) {
          sym.discrete.push_back(flip);
          break;
        }
      }
    }
  }
  if (sym.continuous) return sym;

  // Discrete generators: the highest order n in {6, 4, 3, 2} about each principal axis.
  std::vector<SE3> generators;
  for (int k = 0; k < 3; ++k) {
    const Vec3 axis = es.eigenvectors().col(k);
    for (int order : {6, 4, 3, 2}) {
      const SE3 g = rotation_about(axis, 2.0 * M_PI / order, centre);
      if (maps_onto_itself(g)) {
        generators.push_back(g);
        break;
      }
    }
  }
  // Closure of the group (small: at most 48 elements kept).
  std::vector<SE3> group = {SE3()};
  auto contains = [&](const SE3& T) {
    for (const auto& G : group)
      if (rotation_distance_rad(G.rotation(), T.rotation()) < 1e-3 &&
          (G.translation() - T.translation()).norm() < 1e-6)
        return true;
    return false;
  };
  for (bool grew = true; grew && group.size() < 48;) {
    grew = false;
    const size_t count = group.size();
    for (size_t i = 0; i < count && group.size() < 48; ++i)
      for (const auto& g : generators) {
        const SE3 T = group[i] * g;
        if (!contains(T)) {
          group.push_back(T);
          grew = true;
        }
      }
  }
  sym.discrete.assign(group.begin() + 1, group.end());
  return sym;
}

}  // namespace orpe
