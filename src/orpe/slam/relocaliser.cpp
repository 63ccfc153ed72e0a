#include "orpe/slam/relocaliser.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <numeric>
#include <random>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

namespace orpe::slam {

bool RelocaliserParams::IsValid(std::string* why) const {
  auto fail = [&](const char* msg) {
    if (why) *why = msg;
    return false;
  };
  if (!(keyframe_min_translation_m > 0) || !(keyframe_min_rotation_deg > 0))
    return fail("keyframe_min_translation_m and keyframe_min_rotation_deg must be > 0");
  if (max_keyframes < 1 || max_keyframes > 100000) return fail("max_keyframes must be in [1, 1e5]");
  if (orb_features < 10 || orb_features > 20000) return fail("orb_features must be in [10, 20000]");
  if (!(match_ratio > 0 && match_ratio <= 1)) return fail("match_ratio must be in (0, 1]");
  if (candidates < 1 || candidates > 50) return fail("candidates must be in [1, 50]");
  if (min_inliers < 3) return fail("min_inliers must be >= 3");
  if (!(inlier_distance_m > 0 && inlier_distance_m < 1))
    return fail("inlier_distance_m must be in (0, 1) m");
  if (ransac_iterations < 1 || ransac_iterations > 100000)
    return fail("ransac_iterations must be in [1, 1e5]");
  if (verify_rounds < 1 || verify_rounds > 10) return fail("verify_rounds must be in [1, 10]");
  return true;
}

SE3 fit_rigid(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  Eigen::Matrix3Xd A(3, a.size()), B(3, b.size());
  for (size_t i = 0; i < a.size(); ++i) A.col(static_cast<Eigen::Index>(i)) = a[i];
  for (size_t i = 0; i < b.size(); ++i) B.col(static_cast<Eigen::Index>(i)) = b[i];
  const Eigen::Matrix4d M = Eigen::umeyama(B, A, false);  // maps b onto a
  return SE3::from_matrix(M);
}

namespace {

/// ORB features of one frame with a valid 3D point each (camera frame, m).
struct Features {
  cv::Mat descriptors;  // one row per point
  std::vector<Vec3> points;
};

Features extract(const FrameLevel& level0, int n_features) {
  const IntensityImage& I = level0.intensity;
  cv::Mat grey(I.height(), I.width(), CV_8UC1);
  for (int v = 0; v < I.height(); ++v)
    for (int u = 0; u < I.width(); ++u)
      grey.at<std::uint8_t>(v, u) = cv::saturate_cast<std::uint8_t>(I.at(u, v));
  auto orb = cv::ORB::create(n_features);
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  orb->detectAndCompute(grey, cv::noArray(), keypoints, descriptors);
  Features f;
  for (size_t k = 0; k < keypoints.size(); ++k) {
    const int u = static_cast<int>(std::lround(keypoints[k].pt.x));
    const int v = static_cast<int>(std::lround(keypoints[k].pt.y));
    if (u < 0 || v < 0 || u >= I.width() || v >= I.height()) continue;
    const Vec3f& p = level0.vertex.at(u, v);
    if (!(p.z() > 0)) continue;
    f.points.push_back(p.cast<double>());
    f.descriptors.push_back(descriptors.row(static_cast<int>(k)));
  }
  return f;
}

/// Ratio-test matches (query index, train index) of `q` against `t`.
std::vector<std::pair<int, int>> match(const Features& q, const Features& t, double ratio) {
  std::vector<std::pair<int, int>> out;
  if (q.descriptors.rows < 2 || t.descriptors.rows < 2) return out;
  cv::BFMatcher matcher(cv::NORM_HAMMING);
  std::vector<std::vector<cv::DMatch>> knn;
  matcher.knnMatch(q.descriptors, t.descriptors, knn, 2);
  for (const auto& m : knn)
    if (m.size() == 2 && m[0].distance < ratio * m[1].distance)
      out.emplace_back(m[0].queryIdx, m[0].trainIdx);
  return out;
}

}  // namespace

TrackingVerification verify_by_tracking(const SE3& T_world_guess, int rounds,
                                        const TrackerParams& gates, const TrackFrom& track_from) {
  TrackingVerification v;
  SE3 T_world_ref = T_world_guess;
  for (v.rounds = 1;; ++v.rounds) {
    v.alignment = track_from(T_world_ref);
    v.T_world_cam = T_world_ref * v.alignment.T_ref_cam;
    if (v.ok() || v.rounds >= rounds) break;
    // Render again at the estimate only when it moved the reference (else the round repeats
    // itself) and stays within the tracker's jump limits of the guess.
    const SE3& step = v.alignment.T_ref_cam;
    const double step_norm =
        std::hypot(step.translation().norm(), step.rotation_angle_deg() * M_PI / 180.0);
    const SE3 total = T_world_guess.inverse() * v.T_world_cam;
    if (step_norm <= gates.max_final_step ||
        total.translation().norm() > gates.max_translation_update_m ||
        total.rotation_angle_deg() > gates.max_rotation_update_deg)
      break;
    T_world_ref = v.T_world_cam;
  }
  return v;
}

struct Relocaliser::Impl {
  struct Keyframe {
    Features features;
    SE3 T_world_cam;
    int frame_index = -1;
    std::int32_t time = -1;
  };
  std::deque<Keyframe> keyframes;

  /// T_kf_cam from matches by RANSAC; inliers counted. Deterministic (fixed seed per call).
  RelocCandidate estimate(const Features& cur, const Keyframe& kf,
                          const std::vector<std::pair<int, int>>& m,
                          const RelocaliserParams& p) const;
};

RelocCandidate Relocaliser::Impl::estimate(const Features& cur, const Keyframe& kf,
                                           const std::vector<std::pair<int, int>>& m,
                                           const RelocaliserParams& p) const {
  RelocCandidate best;
  best.keyframe_frame_index = kf.frame_index;
  best.keyframe_time = kf.time;
  best.matches = static_cast<int>(m.size());
  const double tol2 = p.inlier_distance_m * p.inlier_distance_m;
  auto inliers_of = [&](const SE3& T, std::vector<int>* idx) {
    int n = 0;
    for (size_t k = 0; k < m.size(); ++k)
      if ((kf.features.points[m[k].second] - T * cur.points[m[k].first]).squaredNorm() < tol2) {
        ++n;
        if (idx) idx->push_back(static_cast<int>(k));
      }
    return n;
  };
  std::mt19937 rng(12345u);
  std::uniform_int_distribution<size_t> pick(0, m.size() - 1);
  SE3 best_T;
  int best_n = 0;
  for (int it = 0; it < p.ransac_iterations; ++it) {
    const size_t i = pick(rng), j = pick(rng), k = pick(rng);
    if (i == j || j == k || i == k) continue;
    std::vector<Vec3> a, b;
    for (size_t s : {i, j, k}) {
      a.push_back(kf.features.points[m[s].second]);
      b.push_back(cur.points[m[s].first]);
    }
    if ((a[1] - a[0]).cross(a[2] - a[0]).norm() < 1e-4) continue;  // near-collinear sample
    const SE3 T = fit_rigid(a, b);
    const int n = inliers_of(T, nullptr);
    if (n > best_n) best_n = n, best_T = T;
  }
  if (best_n < 3) return best;
  std::vector<int> idx;
  inliers_of(best_T, &idx);
  std::vector<Vec3> a, b;
  for (int k : idx) {
    a.push_back(kf.features.points[m[k].second]);
    b.push_back(cur.points[m[k].first]);
  }
  const SE3 T_kf_cam = fit_rigid(a, b);
  best.inliers = inliers_of(T_kf_cam, nullptr);
  best.T_kf_cam = T_kf_cam;
  best.T_world_cam = kf.T_world_cam * T_kf_cam;
  return best;
}

Relocaliser::Relocaliser(const RelocaliserParams& params)
    : params_(params), impl_(std::make_unique<Impl>()) {}
Relocaliser::~Relocaliser() = default;
Relocaliser::Relocaliser(Relocaliser&&) noexcept = default;
Relocaliser& Relocaliser::operator=(Relocaliser&&) noexcept = default;

size_t Relocaliser::size() const {
  return impl_->keyframes.size();
}
void Relocaliser::clear() {
  impl_->keyframes.clear();
}

void Relocaliser::update_poses(const std::function<SE3(std::int32_t, const SE3&)>& f) {
  for (auto& kf : impl_->keyframes) kf.T_world_cam = f(kf.time, kf.T_world_cam);
}

bool Relocaliser::maybe_add(const FrameLevel& level0, const SE3& T_world_cam, int frame_index,
                            std::int32_t time) {
  const double max_rot = params_.keyframe_min_rotation_deg * M_PI / 180.0;
  for (const auto& kf : impl_->keyframes) {
    const SE3 d = kf.T_world_cam.inverse() * T_world_cam;
    if (d.translation().norm() < params_.keyframe_min_translation_m &&
        so3_log(d.rotation()).norm() < max_rot)
      return false;
  }
  Impl::Keyframe kf;
  kf.features = extract(level0, params_.orb_features);
  if (static_cast<int>(kf.features.points.size()) < params_.min_inliers) return false;
  kf.T_world_cam = T_world_cam;
  kf.frame_index = frame_index;
  kf.time = time >= 0 ? time : frame_index;
  impl_->keyframes.push_back(std::move(kf));
  while (static_cast<int>(impl_->keyframes.size()) > params_.max_keyframes)
    impl_->keyframes.pop_front();
  return true;
}

std::vector<RelocCandidate> Relocaliser::query(const FrameLevel& level0,
                                               std::int32_t max_time) const {
  std::vector<RelocCandidate> out;
  if (impl_->keyframes.empty()) return out;
  const Features cur = extract(level0, params_.orb_features);
  if (static_cast<int>(cur.points.size()) < params_.min_inliers) return out;
  std::vector<std::vector<std::pair<int, int>>> matches(impl_->keyframes.size());
  std::vector<size_t> order(impl_->keyframes.size());
  for (size_t k = 0; k < impl_->keyframes.size(); ++k)
    if (impl_->keyframes[k].time <= max_time)
      matches[k] = match(cur, impl_->keyframes[k].features, params_.match_ratio);
  std::iota(order.begin(), order.end(), size_t{0});
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return matches[a].size() > matches[b].size(); });
  for (size_t r = 0; r < order.size() && static_cast<int>(r) < params_.candidates; ++r) {
    const auto& m = matches[order[r]];
    if (static_cast<int>(m.size()) < params_.min_inliers) break;
    const RelocCandidate c = impl_->estimate(cur, impl_->keyframes[order[r]], m, params_);
    if (c.inliers >= params_.min_inliers) out.push_back(c);
  }
  std::stable_sort(out.begin(), out.end(), [](const RelocCandidate& a, const RelocCandidate& b) {
    return a.inliers > b.inliers;
  });
  return out;
}

}  // namespace orpe::slam
