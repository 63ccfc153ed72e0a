#include "orpe/eval/bop_pose_errors.h"
#include "orpe/core/parse_number.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>

#include "orpe/core/error.h"
#include "orpe/render/rasterizer.h"

namespace orpe {
namespace {

constexpr double kMmPerM = 1000.0;

/// `n` finite numbers from e[key]; throws std::runtime_error with the problem.
std::vector<double> numbers(const nlohmann::json& e, const char* key, size_t n) {
  if (!e.contains(key) || !e.at(key).is_array() || e.at(key).size() != n)
    throw std::runtime_error(fmt::format("'{}' must be a list of {} numbers", key, n));
  std::vector<double> v;
  for (const auto& x : e.at(key)) {
    if (!x.is_number() || !std::isfinite(x.get<double>()))
      throw std::runtime_error(fmt::format("'{}' must be a list of {} finite numbers", key, n));
    v.push_back(x.get<double>());
  }
  return v;
}

BopModelInfo parse_model_info(const nlohmann::json& e) {
  if (!e.is_object()) throw std::runtime_error("expected an object");
  BopModelInfo m;
  if (!e.contains("diameter") || !e.at("diameter").is_number() ||
      !(e.at("diameter").get<double>() > 0))
    throw std::runtime_error("'diameter' must be a positive number (mm)");
  m.diameter_m = e.at("diameter").get<double>() / kMmPerM;
  if (e.contains("symmetries_discrete")) {
    if (!e.at("symmetries_discrete").is_array())
      throw std::runtime_error("'symmetries_discrete' must be a list");
    for (const auto& s : e.at("symmetries_discrete")) {
      const auto v = numbers(nlohmann::json{{"m", s}}, "m", 16);
      Mat3 R;
      R << v[0], v[1], v[2], v[4], v[5], v[6], v[8], v[9], v[10];
      if ((R * R.transpose() - Mat3::Identity()).norm() > 1e-3 || R.determinant() < 0)
        throw std::runtime_error("a 'symmetries_discrete' entry is not a rotation");
      m.symmetries_discrete.emplace_back(R, Vec3(v[3], v[7], v[11]) / kMmPerM);
    }
  }
  if (e.contains("symmetries_continuous")) {
    if (!e.at("symmetries_continuous").is_array())
      throw std::runtime_error("'symmetries_continuous' must be a list");
    for (const auto& s : e.at("symmetries_continuous")) {
      const auto a = numbers(s, "axis", 3), o = numbers(s, "offset", 3);
      const Vec3 axis(a[0], a[1], a[2]);
      if (!(axis.norm() > 0)) throw std::runtime_error("a continuous symmetry axis is zero");
      m.symmetries_continuous.push_back({axis.normalized(), Vec3(o[0], o[1], o[2]) / kMmPerM});
    }
  }
  return m;
}

}  // namespace

std::map<int, BopModelInfo> read_bop_models_info(const std::string& path) {
  std::ifstream is(path);
  if (!is) throw IoError(path, "cannot open models_info.json");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(is);
  } catch (const nlohmann::json::exception& e) {
    throw IoError(path, std::string("malformed JSON: ") + e.what());
  }
  if (!j.is_object()) throw IoError(path, "expected an object {\"obj_id\": {...}}");
  std::map<int, BopModelInfo> out;
  for (const auto& [key, e] : j.items()) {
    if (key.empty() || !std::all_of(key.begin(), key.end(), ::isdigit))
      throw IoError(path, fmt::format("key '{}' is not an object id", key));
    const int id = parse_int_field(key, path, fmt::format("key '{}'", key), 0);
    try {
      out[id] = parse_model_info(e);
    } catch (const std::exception& ex) {
      throw IoError(path, fmt::format("object {}: {}", key, ex.what()));
    }
  }
  return out;
}

std::vector<SE3> bop_symmetry_transformations(const BopModelInfo& info, double max_sym_disc_step) {
  std::vector<SE3> discrete{SE3()};
  discrete.insert(discrete.end(), info.symmetries_discrete.begin(), info.symmetries_discrete.end());
  std::vector<SE3> continuous;
  for (const auto& c : info.symmetries_continuous) {
    const int steps = static_cast<int>(std::ceil(M_PI / max_sym_disc_step));
    for (int i = 0; i < steps; ++i) {
      const Mat3 R = Eigen::AngleAxisd(i * 2.0 * M_PI / steps, c.axis).toRotationMatrix();
      continuous.emplace_back(R, c.offset_m - R * c.offset_m);  // rotation about the axis
    }
  }
  if (continuous.empty()) return discrete;
  std::vector<SE3> out;
  for (const SE3& d : discrete)
    for (const SE3& c : continuous) out.push_back(c * d);
  return out;
}

double mssd_m(const std::vector<Vec3>& pts, const SE3& T_est, const SE3& T_gt,
              const std::vector<SE3>& syms) {
  double best = std::numeric_limits<double>::infinity();
  for (const SE3& S : syms) {
    const SE3 T_gt_sym = T_gt * S;
    double worst = 0;
    for (const Vec3& x : pts) {
      worst = std::max(worst, (T_est * x - T_gt_sym * x).squaredNorm());
      if (worst >= best * best) break;  // cannot beat the best symmetry any more
    }
    best = std::min(best, std::sqrt(worst));
  }
  return best;
}

double mspd_px(const std::vector<Vec3>& pts, const PinholeIntrinsics& K, const SE3& T_est,
               const SE3& T_gt, const std::vector<SE3>& syms) {
  std::vector<Eigen::Vector2d> proj_est;
  proj_est.reserve(pts.size());
  for (const Vec3& x : pts) proj_est.push_back(K.project(T_est * x));
  double best = std::numeric_limits<double>::infinity();
  for (const SE3& S : syms) {
    const SE3 T_gt_sym = T_gt * S;
    double worst = 0;
    for (size_t i = 0; i < pts.size(); ++i) {
      worst = std::max(worst, (proj_est[i] - K.project(T_gt_sym * pts[i])).squaredNorm());
      if (worst >= best * best) break;
    }
    best = std::min(best, std::sqrt(worst));
  }
  return best;
}

DepthImage depth_to_distance(const DepthImage& depth, const PinholeIntrinsics& K) {
  DepthImage dist(depth.width(), depth.height(), 0.0f);
  for (int v = 0; v < depth.height(); ++v)
    for (int u = 0; u < depth.width(); ++u) {
      const double z = depth.at(u, v);
      if (z > 0) dist.at(u, v) = static_cast<float>(K.backproject(u, v, z).norm());
    }
  return dist;
}

std::vector<double> vsd_errors(const DepthImage& depth_test, const DepthImage& depth_est,
                               const DepthImage& depth_gt, const PinholeIntrinsics& K,
                               double delta_m, const std::vector<double>& taus_m) {
  if (depth_est.size() != depth_test.size() || depth_gt.size() != depth_test.size())
    throw std::invalid_argument("vsd_errors: depth images of different sizes");
  const DepthImage d_test = depth_to_distance(depth_test, K);
  const DepthImage d_est = depth_to_distance(depth_est, K);
  const DepthImage d_gt = depth_to_distance(depth_gt, K);
  std::vector<double> dists;  // |D_est - D_gt| over the intersection of the visibility masks
  size_t union_count = 0;
  for (size_t p = 0; p < d_test.size(); ++p) {
    const double t = d_test[p];
    // bop19 visibility: in front of the test surface within delta, or no test depth.
    const bool visib_gt = d_gt[p] > 0 && (d_gt[p] - t <= delta_m || t == 0);
    const bool visib_est = d_est[p] > 0 && (d_est[p] - t <= delta_m || t == 0 || visib_gt);
    if (visib_gt || visib_est) ++union_count;
    if (visib_gt && visib_est) dists.push_back(std::abs(double(d_est[p]) - d_gt[p]));
  }
  std::vector<double> errors;
  for (double tau : taus_m) {
    if (union_count == 0) {
      errors.push_back(1.0);
      continue;
    }
    const size_t over =
        std::count_if(dists.begin(), dists.end(), [&](double d) { return d >= tau; });
    errors.push_back(static_cast<double>(over + union_count - dists.size()) / union_count);
  }
  return errors;
}

DepthImage render_model_depth(const TriangleMesh& mesh, const SE3& T_cam_obj,
                              const PinholeIntrinsics& K) {
  RasterizerParams rp;
  rp.threads = 1;  // callers parallelise over estimates
  Rasterizer rast(rp);
  const RenderItem item{&mesh, T_cam_obj, 1};
  RenderBuffers buf;
  rast.render(K, std::span<const RenderItem>(&item, 1), buf, kRenderDepth);
  return std::move(buf.depth);
}

}  // namespace orpe
