#include "orpe/pipeline/reconstruction_error.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <numeric>
#include <stdexcept>

#include "orpe/core/error.h"
#include "orpe/core/ply_format.h"
#include "orpe/io/model_io.h"
#include "orpe/pose/model_search.h"
#include "orpe/render/mesh.h"
#include "orpe/render/mesh_io.h"

namespace orpe {

Eigen::Vector3f closest_point_on_triangle(const Eigen::Vector3f& p, const Eigen::Vector3f& a,
                                          const Eigen::Vector3f& b, const Eigen::Vector3f& c) {
  const Eigen::Vector3f ab = b - a, ac = c - a, ap = p - a;
  const float d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Eigen::Vector3f bp = p - b;
  const float d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const float vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + (d1 / (d1 - d3)) * ab;
  const Eigen::Vector3f cp = p - c;
  const float d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const float vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + (d2 / (d2 - d6)) * ac;
  const float va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
    return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  const float denom = 1.0f / (va + vb + vc);
  if (!std::isfinite(denom)) return a;  // degenerate triangle
  return a + ab * (vb * denom) + ac * (vc * denom);
}

// ---------------------------------------------------------------------------------------------------
// ModelSurface: an AABB tree over triangles, or a kd-tree over points.

struct ModelSurface::Impl {
  struct Node {
    Eigen::AlignedBox3f box;
    int left = -1, right = -1;  // children (inner node)
    int first = 0, count = 0;   // range of `order` (leaf)
  };
  std::vector<Eigen::Vector3f> vertices;
  std::vector<Eigen::Vector3i> triangles;
  std::vector<int> order;
  std::vector<Node> nodes;
  std::unique_ptr<ModelSearchIndex> points;  // point mode
  Eigen::AlignedBox3f bounds;
  std::vector<Eigen::Vector3f> samples;

  int build(std::vector<Eigen::Vector3f>& centroids, int first, int count) {
    Node node;
    Eigen::AlignedBox3f centroid_box;
    for (int i = first; i < first + count; ++i) {
      const auto& t = triangles[order[i]];
      for (int k = 0; k < 3; ++k) node.box.extend(vertices[t[k]]);
      centroid_box.extend(centroids[order[i]]);
    }
    const int index = static_cast<int>(nodes.size());
    nodes.push_back(node);
    if (count <= 4) {
      nodes[index].first = first;
      nodes[index].count = count;
      return index;
    }
    int axis = 0;
    centroid_box.sizes().maxCoeff(&axis);
    const int mid = first + count / 2;
    std::nth_element(order.begin() + first, order.begin() + mid, order.begin() + first + count,
                     [&](int a, int b) { return centroids[a][axis] < centroids[b][axis]; });
    const int left = build(centroids, first, mid - first);
    const int right = build(centroids, mid, first + count - mid);
    nodes[index].left = left;
    nodes[index].right = right;
    return index;
  }

  double query(const Eigen::Vector3f& p, Eigen::Vector3f* closest) const {
    if (points) {
      float d2 = 0;
      const auto i = points->nearest(p, &d2);
      if (closest) *closest = points->points()[i];
      return std::sqrt(static_cast<double>(d2));
    }
    float best = std::numeric_limits<float>::infinity();
    Eigen::Vector3f best_point = Eigen::Vector3f::Zero();
    int stack[128];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const Node& n = nodes[stack[--top]];
      if (n.box.squaredExteriorDistance(p) >= best) continue;
      if (n.left < 0) {
        for (int i = n.first; i < n.first + n.count; ++i) {
          const auto& t = triangles[order[i]];
          const Eigen::Vector3f q =
              closest_point_on_triangle(p, vertices[t[0]], vertices[t[1]], vertices[t[2]]);
          const float d2 = (q - p).squaredNorm();
          if (d2 < best) {
            best = d2;
            best_point = q;
          }
        }
        continue;
      }
      const float dl = nodes[n.left].box.squaredExteriorDistance(p);
      const float dr = nodes[n.right].box.squaredExteriorDistance(p);
      // Push the farther child first so the nearer one is searched first.
      if (top + 2 > 128) continue;  // cannot happen for a median-split tree of < 2^60 triangles
      if (dl < dr) {
        stack[top++] = n.right;
        stack[top++] = n.left;
      } else {
        stack[top++] = n.left;
        stack[top++] = n.right;
      }
    }
    if (closest) *closest = best_point;
    return std::sqrt(static_cast<double>(best));
  }
};

ModelSurface::ModelSurface() : impl_(std::make_unique<Impl>()) {}
ModelSurface::ModelSurface(ModelSurface&&) noexcept = default;
ModelSurface& ModelSurface::operator=(ModelSurface&&) noexcept = default;
ModelSurface::~ModelSurface() = default;

ModelSurface ModelSurface::from_mesh(const TriangleMesh& mesh) {
  if (mesh.triangles.empty())
    throw std::invalid_argument("model surface: mesh '" + mesh.name + "' has no triangles");
  ModelSurface s;
  Impl& m = *s.impl_;
  m.vertices = mesh.vertices;
  for (const auto& t : mesh.triangles) {
    if (t.minCoeff() < 0 || t.maxCoeff() >= static_cast<int>(m.vertices.size()))
      throw std::invalid_argument("model surface: mesh '" + mesh.name + "' has a bad vertex index");
    m.triangles.push_back(t);
  }
  for (const auto& v : m.vertices) m.bounds.extend(v);
  std::vector<Eigen::Vector3f> centroids;
  centroids.reserve(m.triangles.size());
  for (const auto& t : m.triangles)
    centroids.push_back((m.vertices[t[0]] + m.vertices[t[1]] + m.vertices[t[2]]) / 3.0f);
  m.order.resize(m.triangles.size());
  std::iota(m.order.begin(), m.order.end(), 0);
  m.nodes.reserve(2 * m.triangles.size() / 2 + 8);
  m.build(centroids, 0, static_cast<int>(m.triangles.size()));
  constexpr double kSampleSpacingM = 0.002;
  const double count = mesh.surface_area() / (kSampleSpacingM * kSampleSpacingM);
  for (const auto& p : sample_surface_points(
           mesh, static_cast<size_t>(std::clamp(count, 2000.0, 100000.0)), /*seed=*/1))
    m.samples.push_back(p.cast<float>());
  return s;
}

ModelSurface ModelSurface::from_points(const std::vector<Eigen::Vector3f>& points) {
  if (points.empty()) throw std::invalid_argument("model surface: no points");
  ModelSurface s;
  for (const auto& p : points) s.impl_->bounds.extend(p);
  s.impl_->samples = points;
  s.impl_->points = std::make_unique<ModelSearchIndex>(points);
  return s;
}

double ModelSurface::distance_m(const Eigen::Vector3f& p, Eigen::Vector3f* closest) const {
  return impl_->query(p, closest);
}
bool ModelSurface::has_triangles() const {
  return !impl_->triangles.empty();
}
Eigen::Vector3f ModelSurface::centre() const {
  return impl_->bounds.center();
}
const std::vector<Eigen::Vector3f>& ModelSurface::samples() const {
  return impl_->samples;
}

// ---------------------------------------------------------------------------------------------------
// Evaluation

namespace {

/// Rigid transform (R, t) minimising sum |R a_i + t - b_i|^2 (Kabsch / Umeyama without scale).
SE3 fit_rigid(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b) {
  Eigen::Vector3d ca = Eigen::Vector3d::Zero(), cb = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < a.size(); ++i) {
    ca += a[i];
    cb += b[i];
  }
  ca /= static_cast<double>(a.size());
  cb /= static_cast<double>(b.size());
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < a.size(); ++i) H += (a[i] - ca) * (b[i] - cb).transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  if ((svd.matrixV() * svd.matrixU().transpose()).determinant() < 0) D(2, 2) = -1;
  const Eigen::Matrix3d R = svd.matrixV() * D * svd.matrixU().transpose();
  return SE3(R, cb - R * ca);
}

struct Stats {
  double mean = 0, median = 0, rms = 0;
};
Stats distance_stats(std::vector<double> d) {
  Stats s;
  if (d.empty()) return s;
  double sum = 0, sum2 = 0;
  for (double x : d) {
    sum += x;
    sum2 += x * x;
  }
  s.mean = sum / static_cast<double>(d.size());
  s.rms = std::sqrt(sum2 / static_cast<double>(d.size()));
  std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
  s.median = d[d.size() / 2];
  return s;
}

/// The share of the distances `d` (not empty) above `limit`.
double far_share(const std::vector<double>& d, double limit) {
  return static_cast<double>(
             std::count_if(d.begin(), d.end(), [&](double x) { return x > limit; })) /
         static_cast<double>(d.size());
}

std::vector<double> surface_distances(const std::vector<Eigen::Vector3f>& points_world,
                                      const SE3& T_world_obj, const ModelSurface& surface) {
  const SE3 T_obj_world = T_world_obj.inverse();
  const Eigen::Matrix3f R = T_obj_world.rotation().cast<float>();
  const Eigen::Vector3f t = T_obj_world.translation().cast<float>();
  std::vector<double> d(points_world.size());
#pragma omp parallel for schedule(dynamic, 256)
  for (long i = 0; i < static_cast<long>(points_world.size()); ++i)
    d[i] = surface.distance_m(R * points_world[i] + t);
  return d;
}

/// ICP from the ground-truth pose: point-to-closest-surface-point, trimmed at max_distance.
SE3 register_model(const std::vector<Eigen::Vector3f>& points_world, SE3 T_world_obj,
                   const ModelSurface& surface, const ReconstructionErrorParams& params) {
  for (int it = 0; it < params.icp_iterations; ++it) {
    const SE3 T_obj_world = T_world_obj.inverse();
    std::vector<Eigen::Vector3d> src, dst;  // surfel (world) -> closest surface point (world)
    std::vector<Eigen::Vector3f> closest(points_world.size());
    std::vector<char> use(points_world.size(), 0);
#pragma omp parallel for schedule(dynamic, 256)
    for (long i = 0; i < static_cast<long>(points_world.size()); ++i) {
      const Eigen::Vector3f p_obj = (T_obj_world * points_world[i].cast<double>()).cast<float>();
      use[i] = surface.distance_m(p_obj, &closest[i]) <= params.icp_max_distance_m;
    }
    for (size_t i = 0; i < points_world.size(); ++i)
      if (use[i]) {
        src.push_back(T_world_obj * closest[i].cast<double>());
        dst.push_back(points_world[i].cast<double>());
      }
    if (src.size() < 10) break;
    const SE3 delta = fit_rigid(src, dst);  // moves the model's closest points onto the surfels
    T_world_obj = delta * T_world_obj;
    if (delta.translation().norm() < 1e-6 && delta.rotation_angle_deg() < 1e-4) break;
  }
  return T_world_obj;
}

/// Share of `seen_obj` (object frame) within `limit` of a point of `points_world`.
double covered_share(const std::vector<Eigen::Vector3f>& points_world, const SE3& T_world_obj,
                     const std::vector<Eigen::Vector3f>& seen_obj, double limit) {
  const ModelSearchIndex index(points_world);
  const Eigen::Matrix3f R = T_world_obj.rotation().cast<float>();
  const Eigen::Vector3f t = T_world_obj.translation().cast<float>();
  const float limit_sq = static_cast<float>(limit * limit);
  long covered = 0;
#pragma omp parallel for schedule(static) reduction(+ : covered)
  for (long i = 0; i < static_cast<long>(seen_obj.size()); ++i) {
    float d2 = 0;
    index.nearest(R * seen_obj[i] + t, &d2);
    if (d2 <= limit_sq) ++covered;
  }
  return static_cast<double>(covered) / static_cast<double>(seen_obj.size());
}

/// The trajectory pose at `timestamp_s` (within 1 ms), or null.
const StampedPose* pose_at(const std::vector<StampedPose>& trajectory, double timestamp_s) {
  for (const auto& p : trajectory)
    if (std::abs(p.timestamp_s - timestamp_s) < 1e-3) return &p;
  return nullptr;
}

}  // namespace

namespace {

/// The map's object surfels per instance (above min_confidence when the map has confidences), and
/// each instance's class (the majority of its surfels' class ids).
struct MapInstances {
  std::map<int, std::vector<Eigen::Vector3f>> points;
  std::map<int, int> class_id;
};

MapInstances map_instances(const PointCloudData& map, const ReconstructionErrorParams& params) {
  const bool use_confidence = map.confidences.size() == map.size();
  MapInstances out;
  std::map<int, std::map<int, int>> votes;
  for (size_t i = 0; i < map.size(); ++i) {
    const int id = map.instance_ids[i];
    if (id <= 0) continue;
    if (use_confidence && map.confidences[i] < params.min_confidence) continue;
    out.points[id].push_back(map.positions_m[i]);
    ++votes[id][map.class_ids[i]];
  }
  for (const auto& [id, v] : votes)
    out.class_id[id] = std::max_element(v.begin(), v.end(), [](const auto& a, const auto& b) {
                         return a.second < b.second;
                       })->first;
  return out;
}

/// Each instance assigned to the nearest ground-truth object of its class (by its centroid and
/// the model surface's centre); instances of no object's class go to `unmatched`.
std::map<size_t, std::vector<int>> assign_instances(
    const MapInstances& instances, const std::vector<GroundTruthObjectPose>& objects,
    const std::map<int, const ModelSurface*>& surfaces, std::vector<int>* unmatched) {
  std::map<size_t, std::vector<int>> assigned;  // object index -> instances
  for (const auto& [id, pts] : instances.points) {
    const int cls = instances.class_id.at(id);
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (const auto& p : pts) centroid += p.cast<double>();
    centroid /= static_cast<double>(pts.size());
    double best = std::numeric_limits<double>::infinity();
    long best_object = -1;
    for (size_t k = 0; k < objects.size(); ++k) {
      if (objects[k].class_id != cls) continue;
      const auto s = surfaces.find(cls);
      const Eigen::Vector3d centre_obj = s != surfaces.end() && s->second
                                             ? Eigen::Vector3d(s->second->centre().cast<double>())
                                             : Eigen::Vector3d::Zero();
      const Eigen::Vector3d centre = objects[k].T_world_obj * centre_obj;
      const double d = (centre - centroid).norm();
      if (d < best) {
        best = d;
        best_object = static_cast<long>(k);
      }
    }
    if (best_object < 0)
      unmatched->push_back(id);
    else
      assigned[static_cast<size_t>(best_object)].push_back(id);
  }
  return assigned;
}

/// The error figures of one object whose surfels `pts` exist and whose model surface is known.
void measure_object(const GroundTruthObjectPose& o, const std::vector<Eigen::Vector3f>& pts,
                    const ModelSurface& surface, const ReconstructionErrorParams& params,
                    ObjectReconstructionError& e) {
  const std::vector<double> d = surface_distances(pts, o.T_world_obj, surface);
  e.far_near_fraction = far_share(d, params.far_near_m);
  e.far_fraction = far_share(d, params.far_m);
  if (!o.seen_surface_obj.empty()) {
    e.completeness =
        covered_share(pts, o.T_world_obj, o.seen_surface_obj, params.completeness_distance_m);
    e.seen_surface_samples = static_cast<int>(o.seen_surface_obj.size());
  }
  const Stats st = distance_stats(d);
  e.mean_m = st.mean;
  e.median_m = st.median;
  e.rms_m = st.rms;
  if (params.register_model) {
    const SE3 T = register_model(pts, o.T_world_obj, surface, params);
    e.mean_registered_m = distance_stats(surface_distances(pts, T, surface)).mean;
    const SE3 delta = T * o.T_world_obj.inverse();
    e.registration_shift_m = (T.translation() - o.T_world_obj.translation()).norm();
    e.registration_angle_deg = delta.rotation_angle_deg();
  }
}

}  // namespace

ReconstructionEvaluation evaluate_reconstruction(const PointCloudData& map,
                                                 const std::vector<GroundTruthObjectPose>& objects,
                                                 const std::map<int, const ModelSurface*>& surfaces,
                                                 const std::map<int, std::string>& class_names,
                                                 const ReconstructionErrorParams& params) {
  if (map.instance_ids.size() != map.size() || map.class_ids.size() != map.size())
    throw std::invalid_argument(
        "reconstruction error: the map needs per-surfel instance and class ids");
  ReconstructionEvaluation ev;
  const MapInstances instances = map_instances(map, params);
  std::map<size_t, std::vector<int>> assigned =
      assign_instances(instances, objects, surfaces, &ev.unmatched_instances);
  double sum = 0, sum_registered = 0, sum_completeness = 0;
  int n = 0, n_registered = 0, n_completeness = 0;
  for (size_t k = 0; k < objects.size(); ++k) {
    const GroundTruthObjectPose& o = objects[k];
    ObjectReconstructionError e;
    e.object_id = o.object_id;
    e.class_id = o.class_id;
    const auto name = class_names.find(o.class_id);
    e.name = name != class_names.end() ? name->second : fmt::format("class {}", o.class_id);
    e.instances = assigned[k];
    std::vector<Eigen::Vector3f> pts;
    for (int id : e.instances)
      pts.insert(pts.end(), instances.points.at(id).begin(), instances.points.at(id).end());
    e.surfels = static_cast<int>(pts.size());
    const auto s = surfaces.find(o.class_id);
    if (pts.empty() || s == surfaces.end() || !s->second) {
      e.surfels = 0;
      if (!o.seen_surface_obj.empty()) {  // seen but not reconstructed: nothing is covered
        e.completeness = 0;
        e.seen_surface_samples = static_cast<int>(o.seen_surface_obj.size());
        ++n_completeness;
      }
      ++ev.objects_without_surfels;
      ev.objects.push_back(e);
      continue;
    }
    measure_object(o, pts, *s->second, params, e);
    ev.max_far_fraction = std::max(ev.max_far_fraction, e.far_fraction);
    if (!o.seen_surface_obj.empty()) sum_completeness += e.completeness, ++n_completeness;
    sum += e.mean_m;
    ++n;
    if (params.register_model) sum_registered += e.mean_registered_m, ++n_registered;
    ev.objects.push_back(e);
  }
  std::sort(ev.objects.begin(), ev.objects.end(), [](const auto& a, const auto& b) {
    return std::tie(a.class_id, a.object_id) < std::tie(b.class_id, b.object_id);
  });
  ev.mean_m = n ? sum / n : 0;
  ev.objects_measured = n;
  ev.mean_registered_m = n_registered ? sum_registered / n_registered : -1;
  ev.mean_completeness = n_completeness ? sum_completeness / n_completeness : -1;
  return ev;
}

namespace {
std::string percent(double share) {
  return share >= 0 ? fmt::format("{:.1f}", share * 100) : std::string("-");
}
}  // namespace

std::string ReconstructionEvaluation::report() const {
  std::string s =
      fmt::format("{:<24} {:>6} {:>9} {:>10} {:>8} {:>7} {:>7} {:>9} {:>11}\n", "object", "class",
                  "surfels", "mean (mm)", "median", ">1cm %", ">2cm %", "complete %", "registered");
  for (const auto& o : objects) {
    if (o.surfels == 0) {
      s += fmt::format("{:<24} {:>6} {:>9} {:>10} {:>8} {:>7} {:>7} {:>9}\n", o.name, o.class_id, 0,
                       "-", "-", "-", "-", percent(o.completeness));
      continue;
    }
    s += fmt::format("{:<24} {:>6} {:>9} {:>10.2f} {:>8.2f} {:>7.2f} {:>7.2f} {:>9} {:>11}\n",
                     o.name, o.class_id, o.surfels, o.mean_m * 1000, o.median_m * 1000,
                     o.far_near_fraction * 100, o.far_fraction * 100, percent(o.completeness),
                     o.mean_registered_m >= 0 ? fmt::format("{:.2f}", o.mean_registered_m * 1000)
                                              : std::string("-"));
  }
  s += fmt::format(
      "{:<24} {:>6} {:>9} {:>10} {:>8} {:>7} {:>7.2f} {:>9} {:>11}\n", "MEAN (objects)", "", "",
      objects_measured > 0 ? fmt::format("{:.2f}", mean_m * 1000) : std::string("-"), "", "",
      max_far_fraction * 100, percent(mean_completeness),
      mean_registered_m >= 0 ? fmt::format("{:.2f}", mean_registered_m * 1000) : std::string("-"));
  s += "(>2cm column of the MEAN row: the largest share of an object)\n";
  if (objects_without_surfels)
    s += fmt::format("{} object(s) without reconstructed surfels\n", objects_without_surfels);
  if (!unmatched_instances.empty())
    s += fmt::format("{} map instance(s) of a class with no ground-truth object\n",
                     unmatched_instances.size());
  return s;
}

std::string ReconstructionEvaluation::markdown() const {
  std::string s =
      "| object | class | surfels | error (mm) | median (mm) | > 1 cm (%) | > 2 cm (%) | "
      "completeness (%) | registered (mm) |\n"
      "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n";
  for (const auto& o : objects)
    s += o.surfels == 0
             ? fmt::format("| {} | {} | 0 | - | - | - | - | {} | - |\n", o.name, o.class_id,
                           percent(o.completeness))
             : fmt::format("| {} | {} | {} | {:.1f} | {:.1f} | {:.2f} | {:.2f} | {} | {} |\n",
                           o.name, o.class_id, o.surfels, o.mean_m * 1000, o.median_m * 1000,
                           o.far_near_fraction * 100, o.far_fraction * 100, percent(o.completeness),
                           o.mean_registered_m >= 0
                               ? fmt::format("{:.1f}", o.mean_registered_m * 1000)
                               : std::string("-"));
  s += fmt::format(
      "| **mean** | | | {} | | | max {:.2f} | {} | {} |\n",
      objects_measured > 0 ? fmt::format("{:.1f}", mean_m * 1000) : std::string("-"),
      max_far_fraction * 100, percent(mean_completeness),
      mean_registered_m >= 0 ? fmt::format("{:.1f}", mean_registered_m * 1000) : std::string("-"));
  return s;
}

std::string ReconstructionEvaluation::to_json() const {
  nlohmann::json j;
  j["mean_mm"] = objects_measured > 0 ? nlohmann::json(mean_m * 1000) : nlohmann::json(nullptr);
  j["objects_measured"] = objects_measured;
  j["mean_registered_mm"] =
      mean_registered_m >= 0 ? nlohmann::json(mean_registered_m * 1000) : nlohmann::json(nullptr);
  j["mean_completeness"] =
      mean_completeness >= 0 ? nlohmann::json(mean_completeness) : nlohmann::json(nullptr);
  j["max_far_2cm_fraction"] = max_far_fraction;
  j["objects_without_surfels"] = objects_without_surfels;
  j["unmatched_instances"] = unmatched_instances;
  j["objects"] = nlohmann::json::array();
  for (const auto& o : objects) {
    nlohmann::json r;
    r["object_id"] = o.object_id;
    r["class_id"] = o.class_id;
    r["name"] = o.name;
    r["instances"] = o.instances;
    r["surfels"] = o.surfels;
    auto mm = [&](double v, bool ok) {
      return ok ? nlohmann::json(v * 1000) : nlohmann::json(nullptr);
    };
    r["mean_mm"] = mm(o.mean_m, o.surfels > 0);
    r["median_mm"] = mm(o.median_m, o.surfels > 0);
    r["rms_mm"] = mm(o.rms_m, o.surfels > 0);
    r["mean_registered_mm"] = mm(o.mean_registered_m, o.mean_registered_m >= 0);
    r["far_1cm_fraction"] = o.far_near_fraction;
    r["far_2cm_fraction"] = o.far_fraction;
    r["completeness"] =
        o.completeness >= 0 ? nlohmann::json(o.completeness) : nlohmann::json(nullptr);
    r["seen_surface_samples"] = o.seen_surface_samples;
    r["registration_shift_mm"] = mm(o.registration_shift_m, o.registration_shift_m >= 0);
    r["registration_angle_deg"] = o.registration_angle_deg >= 0
                                      ? nlohmann::json(o.registration_angle_deg)
                                      : nlohmann::json(nullptr);
    j["objects"].push_back(r);
  }
  return j.dump(2);
}

std::vector<GroundTruthObjectPose> ground_truth_objects_in_map(
    const DatasetReader& reader, const std::vector<StampedPose>& trajectory) {
  std::vector<GroundTruthObjectPose> out;
  std::map<int, size_t> seen;  // object id -> index in out
  for (size_t i = 0; i < reader.size(); ++i) {
    const RgbdFrame frame = reader.read(i);
    if (frame.objects_gt.empty()) continue;
    const StampedPose* pose = pose_at(trajectory, frame.timestamp_s);
    if (!pose) continue;
    for (const auto& g : frame.objects_gt) {
      if (seen.count(g.instance_id)) continue;
      seen[g.instance_id] = out.size();
      out.push_back({g.instance_id, g.class_id, pose->T_world_cam * g.T_cam_obj, {}});
    }
  }
  return out;
}

void mark_seen_surface(const DatasetReader& reader, const std::vector<StampedPose>& trajectory,
                       const std::map<int, const ModelSurface*>& surfaces,
                       std::vector<GroundTruthObjectPose>* objects,
                       const SeenSurfaceParams& params) {
  std::map<int, std::vector<char>> seen;  // object index -> per sample
  for (size_t i = 0; i < reader.size(); ++i) {
    const RgbdFrame frame = reader.read(i);
    if (frame.objects_gt.empty() || frame.labels_gt.empty() || frame.depth.empty() ||
        !pose_at(trajectory, frame.timestamp_s))
      continue;
    const PinholeIntrinsics& K = frame.intrinsics;
    const int W = frame.depth.width(), H = frame.depth.height();
    for (size_t g = 0; g < frame.objects_gt.size(); ++g) {
      const ObjectGroundTruth& gt = frame.objects_gt[g];
      const auto s = surfaces.find(gt.class_id);
      const auto o = std::find_if(objects->begin(), objects->end(),
                                  [&](const auto& x) { return x.object_id == gt.instance_id; });
      if (s == surfaces.end() || !s->second || o == objects->end()) continue;
      const auto& samples = s->second->samples();
      auto& flags = seen[static_cast<size_t>(o - objects->begin())];
      flags.resize(samples.size(), 0);
      const Eigen::Matrix3f R = gt.T_cam_obj.rotation().cast<float>();
      const Eigen::Vector3f t = gt.T_cam_obj.translation().cast<float>();
      const auto label = static_cast<std::int32_t>(g + 1);
      for (size_t k = 0; k < samples.size(); ++k) {
        const Eigen::Vector3f p = R * samples[k] + t;
        if (p.z() <= 0) continue;
        const long u = std::lround(K.fx * p.x() / p.z() + K.cx);
        const long v = std::lround(K.fy * p.y() / p.z() + K.cy);
        if (u < 0 || v < 0 || u >= W || v >= H) continue;
        const float z = frame.depth.at(static_cast<int>(u), static_cast<int>(v));
        if (frame.labels_gt.at(static_cast<int>(u), static_cast<int>(v)) == label && z > 0 &&
            std::abs(z - p.z()) <= params.depth_tolerance_m)
          flags[k] = 1;
      }
    }
  }
  for (const auto& [index, flags] : seen) {
    GroundTruthObjectPose& o = (*objects)[index];
    const auto& samples = surfaces.at(o.class_id)->samples();
    o.seen_surface_obj.clear();
    for (size_t k = 0; k < flags.size(); ++k)
      if (flags[k]) o.seen_surface_obj.push_back(samples[k]);
  }
}

ModelSurface load_model_surface(const DatasetInfo& info, int class_id) {
  const auto mesh = info.model_mesh_paths.find(class_id);
  if (mesh != info.model_mesh_paths.end()) {
    MeshLoadOptions mo;
    mo.metres_per_unit = 1.0 / info.model_units_per_m;
    mo.load_texture = false;
    const TriangleMesh m = load_mesh(mesh->second, mo);
    if (!m.triangles.empty()) return ModelSurface::from_mesh(m);
  }
  const auto points = info.model_points_paths.find(class_id);
  if (points == info.model_points_paths.end())
    throw IoError(info.root, fmt::format("the dataset has no model for class {}", class_id));
  std::vector<Eigen::Vector3f> pts;
  for (const auto& p : read_model_points(points->second, info.model_units_per_m))
    pts.push_back(p.cast<float>());
  return ModelSurface::from_points(pts);
}

PointCloudData read_semantic_map_ply(const std::string& path) {
  PointCloudData cloud = read_point_cloud_ply(path);
  if (cloud.instance_ids.size() == cloud.size() && cloud.class_ids.size() == cloud.size())
    return cloud;
  // semantic/semantic_output.h writes `instance` and `class`.
  const detail::PlyColumns v = detail::read_ply_element(path, "vertex");
  auto ints = [&](const char* name, std::vector<std::int32_t>& out) {
    if (!v.has(name) || v.count != cloud.size()) return;
    out.resize(cloud.size());
    const auto& col = v.columns.at(name);
    for (size_t i = 0; i < cloud.size(); ++i)
      out[i] = static_cast<std::int32_t>(std::lround(col[i]));
  };
  if (cloud.instance_ids.size() != cloud.size()) ints("instance", cloud.instance_ids);
  if (cloud.class_ids.size() != cloud.size()) ints("class", cloud.class_ids);
  if (cloud.instance_ids.size() != cloud.size() || cloud.class_ids.size() != cloud.size())
    throw IoError(path, "no per-surfel instance and class ids (expected an orpe semantic_map.ply)");
  return cloud;
}

MapSurfaceError evaluate_map_surface(const PointCloudData& map, const ModelSurface& surface,
                                     const ReconstructionErrorParams& params) {
  std::vector<Eigen::Vector3f> pts;
  pts.reserve(map.size());
  const bool conf = map.confidences.size() == map.size();
  for (size_t i = 0; i < map.size(); ++i)
    if (!conf || map.confidences[i] >= params.min_confidence) pts.push_back(map.positions_m[i]);
  if (pts.empty())
    throw std::invalid_argument(
        fmt::format("map error: none of the {} surfels has confidence >= {}", map.size(),
                    params.min_confidence));
  const std::vector<double> d = surface_distances(pts, SE3(), surface);
  MapSurfaceError e;
  e.surfels = static_cast<int>(pts.size());
  e.min_confidence = params.min_confidence;
  e.far_near_m = params.far_near_m;
  e.far_m = params.far_m;
  e.far_near_fraction = far_share(d, params.far_near_m);
  e.far_fraction = far_share(d, params.far_m);
  const Stats st = distance_stats(d);
  e.mean_m = st.mean;
  e.median_m = st.median;
  e.rms_m = st.rms;
  return e;
}

std::string MapSurfaceError::report() const {
  return fmt::format(
      "map against the scene surface: {} surfels (confidence >= {}), distance mean {:.2f} mm, "
      "median {:.2f} mm, RMS {:.2f} mm; beyond {:.0f} mm: {:.2f} %, beyond {:.0f} mm: {:.2f} %\n",
      surfels, min_confidence, mean_m * 1000, median_m * 1000, rms_m * 1000, far_near_m * 1000,
      far_near_fraction * 100, far_m * 1000, far_fraction * 100);
}

std::string MapSurfaceError::to_json() const {
  nlohmann::ordered_json j = {{"surfels", surfels},
                              {"min_confidence", min_confidence},
                              {"mean_mm", mean_m * 1000},
                              {"median_mm", median_m * 1000},
                              {"rms_mm", rms_m * 1000},
                              {"far_near_mm", far_near_m * 1000},
                              {"far_near_fraction", far_near_fraction},
                              {"far_mm", far_m * 1000},
                              {"far_fraction", far_fraction}};
  return j.dump(2) + "\n";
}

}  // namespace orpe
