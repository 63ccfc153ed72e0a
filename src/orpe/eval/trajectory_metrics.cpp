#include "orpe/eval/trajectory_metrics.h"

#include <fmt/format.h>

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <numeric>
#include <tuple>

#include "orpe/core/error.h"

namespace orpe {
namespace {

/// Rotation angle of R in radians, accurate near 0 and pi (atan2 of sin and cos).
double rotation_angle_rad(const Mat3& R) {
  const Vec3 axis_sin(R(2, 1) - R(1, 2), R(0, 2) - R(2, 0), R(1, 0) - R(0, 1));
  const double sin_angle = 0.5 * axis_sin.norm();
  const double cos_angle = 0.5 * (R.trace() - 1.0);
  return std::atan2(sin_angle, cos_angle);
}

/// Distinct timestamps, each with the index of its last occurrence (TUM reads a file into a dict).
std::vector<std::pair<double, size_t>> unique_stamps_keep_last(const std::vector<double>& stamps) {
  std::map<double, size_t> last;
  for (size_t i = 0; i < stamps.size(); ++i) last[stamps[i]] = i;
  return {last.begin(), last.end()};
}

nlohmann::json stats_json(const ErrorStats& s) {
  return {{"count", s.count}, {"rmse", s.rmse}, {"mean", s.mean}, {"median", s.median},
          {"std", s.std},     {"min", s.min},   {"max", s.max}};
}

}  // namespace

bool TrajectoryMetricsParams::IsValid(std::string* why) const {
  auto fail = [&](const std::string& msg) {
    if (why) *why = msg;
    return false;
  };
  if (!(max_time_difference_s > 0) || !std::isfinite(max_time_difference_s))
    return fail("max_time_difference_s must be a positive number of seconds");
  if (rpe_delta_frames < 1) return fail("rpe_delta_frames must be >= 1");
  return true;
}

std::vector<TimestampMatch> associate_timestamps(const std::vector<double>& gt_stamps_s,
                                                 const std::vector<double>& est_stamps_s,
                                                 double max_difference_s) {
  if (!(max_difference_s > 0)) throw ConfigError("association window must be positive");
  const auto gt = unique_stamps_keep_last(gt_stamps_s);
  const auto est = unique_stamps_keep_last(est_stamps_s);

  // Candidates (|a - b|, a, b) with |a - b| < max, found by a sorted sweep instead of TUM's
  // all-pairs loop; the widened search bounds only collect candidates, the test itself is TUM's
  // expression.
  struct Candidate {
    double diff;
    size_t gt_pos, est_pos;
  };
  std::vector<Candidate> candidates;
  size_t lo = 0;
  for (size_t g = 0; g < gt.size(); ++g) {
    const double a = gt[g].first;
    while (lo < est.size() && est[lo].first < a - 2 * max_difference_s) ++lo;
    for (size_t e = lo; e < est.size() && est[e].first <= a + 2 * max_difference_s; ++e) {
      const double diff = std::abs(a - est[e].first);
      if (diff < max_difference_s) candidates.push_back({diff, g, e});
    }
  }
  // Positions in the sorted unique lists order like the stamps themselves, so this is Python's
  // tuple order (diff, a, b).
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& x, const Candidate& y) {
    return std::tie(x.diff, x.gt_pos, x.est_pos) < std::tie(y.diff, y.gt_pos, y.est_pos);
  });
  std::vector<char> gt_used(gt.size(), 0), est_used(est.size(), 0);
  std::vector<std::pair<size_t, size_t>> chosen;
  for (const auto& c : candidates) {
    if (gt_used[c.gt_pos] || est_used[c.est_pos]) continue;
    gt_used[c.gt_pos] = est_used[c.est_pos] = 1;
    chosen.emplace_back(c.gt_pos, c.est_pos);
  }
  std::sort(chosen.begin(), chosen.end());
  std::vector<TimestampMatch> matches;
  matches.reserve(chosen.size());
  for (const auto& [g, e] : chosen) matches.push_back({gt[g].second, est[e].second});
  return matches;
}

SimilarityAlignment align_umeyama(const std::vector<Vec3>& est, const std::vector<Vec3>& gt,
                                  bool with_scale) {
  if (est.size() != gt.size() || est.empty())
    throw std::invalid_argument("align_umeyama: need two equally long, non-empty point lists");
  const double n = static_cast<double>(est.size());
  Vec3 mean_est = Vec3::Zero(), mean_gt = Vec3::Zero();
  for (size_t i = 0; i < est.size(); ++i) {
    mean_est += est[i];
    mean_gt += gt[i];
  }
  mean_est /= n;
  mean_gt /= n;
  // cross_covariance = sum (q - mean_q)(p - mean_p)^T  (TUM's W^T), est variance for the scale.
  Mat3 cross_covariance = Mat3::Zero();
  double est_sq_spread = 0;
  for (size_t i = 0; i < est.size(); ++i) {
    const Vec3 p = est[i] - mean_est;
    cross_covariance += (gt[i] - mean_gt) * p.transpose();
    est_sq_spread += p.squaredNorm();
  }
  Eigen::JacobiSVD<Mat3> svd(cross_covariance, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Vec3 signs(1, 1, 1);
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0) signs(2) = -1;
  SimilarityAlignment a;
  a.R = svd.matrixU() * signs.asDiagonal() * svd.matrixV().transpose();
  if (with_scale && est_sq_spread > 0) a.scale = svd.singularValues().dot(signs) / est_sq_spread;
  a.t = mean_gt - a.scale * (a.R * mean_est);
  return a;
}

ErrorStats compute_error_stats(const std::vector<double>& errors) {
  ErrorStats s;
  s.count = errors.size();
  if (errors.empty()) return s;
  const double n = static_cast<double>(errors.size());
  double sum = 0, sum_sq = 0;
  for (double e : errors) {
    sum += e;
    sum_sq += e * e;
  }
  s.mean = sum / n;
  s.rmse = std::sqrt(sum_sq / n);
  double var = 0;
  for (double e : errors) var += (e - s.mean) * (e - s.mean);
  s.std = std::sqrt(var / n);
  std::vector<double> sorted = errors;
  std::sort(sorted.begin(), sorted.end());
  s.min = sorted.front();
  s.max = sorted.back();
  const size_t mid = sorted.size() / 2;
  s.median = sorted.size() % 2 ? sorted[mid] : 0.5 * (sorted[mid - 1] + sorted[mid]);
  return s;
}

TrajectoryEvaluation evaluate_trajectory(const std::vector<StampedPose>& gt,
                                         const std::vector<StampedPose>& est,
                                         const TrajectoryMetricsParams& params) {
  std::string why;
  if (!params.IsValid(&why)) throw ConfigError("trajectory metrics: " + why);
  TrajectoryEvaluation ev;
  ev.gt_poses = gt.size();
  ev.est_poses = est.size();
  ev.scale_aligned = params.align_scale;
  ev.rpe.delta_frames = params.rpe_delta_frames;
  ev.rpe.all_pairs = params.rpe_all_pairs;

  std::vector<double> gt_stamps, est_stamps;
  for (const auto& p : gt) gt_stamps.push_back(p.timestamp_s);
  for (const auto& p : est) est_stamps.push_back(p.timestamp_s);
  ev.matches = associate_timestamps(gt_stamps, est_stamps, params.max_time_difference_s);
  if (ev.matches.empty()) return ev;

  // ATE.
  std::vector<Vec3> gt_xyz, est_xyz;
  for (const auto& m : ev.matches) {
    gt_xyz.push_back(gt[m.gt_index].T_world_cam.translation());
    est_xyz.push_back(est[m.est_index].T_world_cam.translation());
  }
  ev.ate.alignment = align_umeyama(est_xyz, gt_xyz, params.align_scale);
  for (size_t i = 0; i < gt_xyz.size(); ++i)
    ev.ate.errors_m.push_back((gt_xyz[i] - ev.ate.alignment.apply(est_xyz[i])).norm());
  ev.ate.translation_m = compute_error_stats(ev.ate.errors_m);

  // RPE. The rigid part of the alignment cancels in P_i^-1 P_j; only a scale changes it.
  const size_t n = ev.matches.size();
  const size_t d = static_cast<size_t>(params.rpe_delta_frames);
  std::vector<double> rpe_trans, rpe_rot;
  const size_t step = params.rpe_all_pairs ? 1 : d;
  for (size_t i = 0; i + d < n; i += step) {
    const SE3& Qi = gt[ev.matches[i].gt_index].T_world_cam;
    const SE3& Qj = gt[ev.matches[i + d].gt_index].T_world_cam;
    SE3 Pi = est[ev.matches[i].est_index].T_world_cam;
    SE3 Pj = est[ev.matches[i + d].est_index].T_world_cam;
    Pi.translation() *= ev.ate.alignment.scale;
    Pj.translation() *= ev.ate.alignment.scale;
    const SE3 E = (Qi.inverse() * Qj).inverse() * (Pi.inverse() * Pj);
    rpe_trans.push_back(E.translation().norm());
    rpe_rot.push_back(rotation_angle_rad(E.rotation()) * 180.0 / M_PI);
  }
  ev.rpe.translation_m = compute_error_stats(rpe_trans);
  ev.rpe.rotation_deg = compute_error_stats(rpe_rot);
  return ev;
}

std::string TrajectoryEvaluation::report() const {
  std::string out = fmt::format("poses: {} ground truth, {} estimated, {} associated\n", gt_poses,
                                est_poses, matches.size());
  const ErrorStats& a = ate.translation_m;
  out += fmt::format(
      "ATE ({} alignment{}): rmse {:.6f} m, mean {:.6f} m, median {:.6f} m, std {:.6f} m, "
      "min {:.6f} m, max {:.6f} m ({} pairs)\n",
      scale_aligned ? "Sim3" : "rigid",
      scale_aligned ? fmt::format(", scale {:.6f}", ate.alignment.scale) : std::string(), a.rmse,
      a.mean, a.median, a.std, a.min, a.max, a.count);
  const ErrorStats& t = rpe.translation_m;
  const ErrorStats& r = rpe.rotation_deg;
  out += fmt::format(
      "RPE (delta {} frames, {}): translation rmse {:.6f} m, mean {:.6f} m, median {:.6f} m, "
      "max {:.6f} m; rotation rmse {:.6f} deg, mean {:.6f} deg, max {:.6f} deg ({} pairs)\n",
      rpe.delta_frames, rpe.all_pairs ? "all pairs" : "consecutive pairs", t.rmse, t.mean, t.median,
      t.max, r.rmse, r.mean, r.max, t.count);
  return out;
}

std::string TrajectoryEvaluation::to_json() const {
  nlohmann::json j;
  j["gt_poses"] = gt_poses;
  j["est_poses"] = est_poses;
  j["pairs"] = matches.size();
  j["ate"] = {{"alignment", scale_aligned ? "sim3" : "se3"},
              {"scale", ate.alignment.scale},
              {"translation_m", stats_json(ate.translation_m)}};
  j["rpe"] = {{"delta_frames", rpe.delta_frames},
              {"all_pairs", rpe.all_pairs},
              {"translation_m", stats_json(rpe.translation_m)},
              {"rotation_deg", stats_json(rpe.rotation_deg)}};
  return j.dump(2);
}

}  // namespace orpe
