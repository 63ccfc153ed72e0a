// The gt back-end: ground-truth masks, optionally degraded like a real detector.
//
// Soft-mask model (per detection, boundary shift e = per-object base in [shift_min, shift_max], the
// same in every frame, + per-frame jitter in [-jitter, jitter], px):
// with d_in the Euclidean distance of an object pixel to the nearest background pixel (>= 1) and
// d_out that of a background pixel to the nearest object pixel (>= 1),
//   object pixel, d_in > e       -> 0.5 + (core - 0.5) * min(1, (d_in - e) / ramp)   (kept, >= 0.5)
//   object pixel, d_in <= e      -> band_min .. 0.5 rising inwards                     (eroded, <
//   0.5) background,   d_out <= -e    -> 0.5 + (core - 0.5) * min(1, (-e - d_out + 1) / ramp)
//   (dilated) background otherwise         -> edge * exp(-(d_out - max(0, -e) - 1) / decay) (far
//   below 0.5)
// so misclassified object boundary pixels sit just below 0.5 while true background is far below,
// the observation the paper's boundary refinement exploits.
#include <opencv2/imgproc.hpp>

#include <spdlog/spdlog.h>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <map>
#include <random>

#include "orpe/semantic/segmenter.h"

namespace orpe {
namespace {

std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

/// Small deterministic generator (portable: no std distributions, whose output is library-defined).
class Rng {
 public:
  Rng(std::uint64_t a, std::uint64_t b, std::uint64_t c)
      : engine_(splitmix64(splitmix64(splitmix64(a) ^ b) ^ c)) {}
  double uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }  // [0, 1)
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  int uniform_int(int lo, int hi) {  // inclusive
    return lo + static_cast<int>(std::floor(uniform() * (hi - lo + 1)));
  }
  bool bernoulli(double p) { return uniform() < p; }
  double gaussian() {
    const double u1 = std::max(uniform(), 1e-300), u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
  }
  int poisson(double mean) {
    const double limit = std::exp(-mean);
    int k = 0;
    for (double p = uniform(); p > limit; p *= uniform()) ++k;
    return k;
  }

 private:
  std::mt19937_64 engine_;
};

constexpr std::uint64_t kSpuriousStream = 0x5b0c1e5ULL;
constexpr std::uint64_t kObjectStream = 0xfffffffff0b1ec75ULL;  // never a frame index

/// Writes the soft mask of `object` (a 0/1 full-size mask whose non-zero pixels lie in `box`) into
/// `probability`, with boundary shift `shift_px`.
void soft_mask(const cv::Mat1b& object, const BoxPx& box, int shift_px, const SegmentationParams& p,
               Rng& rng, ProbabilityImage& probability) {
  const int margin = std::abs(shift_px) +
                     static_cast<int>(std::ceil(p.gt_background_decay_px * 8 + p.gt_core_ramp_px)) +
                     2;
  const cv::Rect roi = cv::Rect(box.u_min - margin, box.v_min - margin, box.width_px() + 2 * margin,
                                box.height_px() + 2 * margin) &
                       cv::Rect(0, 0, object.cols, object.rows);
  const cv::Mat1b inside = object(roi) > 0;
  cv::Mat1b outside;
  cv::bitwise_not(inside, outside);
  cv::Mat1f d_in, d_out;
  cv::distanceTransform(inside, d_in, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  cv::distanceTransform(outside, d_out, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  const double e = shift_px;
  const double ramp = p.gt_core_ramp_px, core = p.gt_core_probability;
  const double band_min = p.gt_band_min_probability, band_max = 0.5 - 0.005;
  const double dilation = std::max(0.0, -e);
  for (int y = 0; y < roi.height; ++y) {
    for (int x = 0; x < roi.width; ++x) {
      double prob;
      if (inside(y, x)) {
        const double d = d_in(y, x);
        if (d > e) {
          prob = 0.5 + (core - 0.5) * std::min(1.0, (d - e) / ramp);
        } else {  // eroded boundary band: just below 0.5, lowest at the true edge
          const double t = e > 1 ? (d - 1.0) / (e - 1.0) : 1.0;
          prob = band_min + (band_max - band_min) * std::clamp(t, 0.0, 1.0);
        }
      } else {
        const double d = d_out(y, x);
        if (d <= dilation) {
          prob = 0.5 + (core - 0.5) * std::min(1.0, (dilation - d + 1.0) / ramp);
        } else {
          prob = p.gt_background_edge_probability *
                 std::exp(-(d - dilation - 1.0) / p.gt_background_decay_px);
        }
      }
      if (p.gt_probability_noise > 0) prob += p.gt_probability_noise * rng.gaussian();
      float& out = probability.at(roi.x + x, roi.y + y);
      out = std::max(out, static_cast<float>(std::clamp(prob, 0.0, 1.0)));
    }
  }
}

bool keep(const Detection& d, const SegmentationParams& p) {
  return d.score >= p.min_score && !d.box.empty() &&
         mask_area(d.probability, static_cast<float>(p.mask_threshold)) >= p.min_mask_area_px;
}

}  // namespace

GroundTruthSegmenter::GroundTruthSegmenter(const SegmentationParams& params,
                                           std::vector<int> class_ids)
    : params_(params), class_ids_(std::move(class_ids)) {
  if (class_ids_.empty())
    for (int c = 1; c <= 21; ++c) class_ids_.push_back(c);
}

namespace {

/// The degraded mask of ground-truth object k (label k of `labels`, within `box`): its boundary
/// shifted (a per-object bias plus a per-frame jitter), its class sometimes wrong, its score drawn;
/// false when this frame misses it. Deterministic in (seed, frame, instance).
bool degrade_object(const SegmentationParams& p, const std::vector<int>& class_ids,
                    const LabelImage& labels, int k, const BoxPx& box,
                    const ObjectGroundTruth& object, std::uint64_t seed, std::uint64_t frame_key,
                    Detection& det) {
  const int width = labels.width(), height = labels.height();
  const auto object_key = 0x1000000ULL + static_cast<std::uint64_t>(object.instance_id);
  Rng object_rng(seed, kObjectStream, object_key);  // same in every frame
  const int base_shift =
      object_rng.uniform_int(p.gt_boundary_shift_min_px, p.gt_boundary_shift_max_px);
  Rng rng(seed, frame_key, object_key);
  if (rng.bernoulli(p.gt_miss_rate)) return false;
  const int shift = base_shift + rng.uniform_int(-p.gt_boundary_jitter_px, p.gt_boundary_jitter_px);
  det.score = static_cast<float>(rng.uniform(0.8, 1.0));
  if (rng.bernoulli(p.gt_wrong_class_rate)) {
    std::vector<int> others;
    for (int c : class_ids)
      if (c != object.class_id) others.push_back(c);
    if (!others.empty()) {
      det.class_id = others[rng.uniform_int(0, static_cast<int>(others.size()) - 1)];
      det.score = static_cast<float>(rng.uniform(0.5, 0.9));
    }
  }
  cv::Mat1b mask(height, width, static_cast<uchar>(0));
  for (int v = box.v_min; v <= box.v_max; ++v)
    for (int u = box.u_min; u <= box.u_max; ++u)
      if (labels.at(u, v) == k) mask(v, u) = 1;
  soft_mask(mask, box, shift, p, rng, det.probability);
  return true;
}

/// p.gt_spurious_per_frame (Poisson mean) spurious elliptic detections of random classes.
void append_spurious(const SegmentationParams& p, const std::vector<int>& class_ids, int width,
                     int height, std::uint64_t seed, std::uint64_t frame_key,
                     std::vector<Detection>& out) {
  const float threshold = static_cast<float>(p.mask_threshold);
  Rng rng(seed, frame_key, kSpuriousStream);
  const int count = rng.poisson(p.gt_spurious_per_frame);
  for (int i = 0; i < count; ++i) {
    const int ru = rng.uniform_int(p.gt_spurious_min_radius_px, p.gt_spurious_max_radius_px);
    const int rv = rng.uniform_int(p.gt_spurious_min_radius_px, p.gt_spurious_max_radius_px);
    const int cu = rng.uniform_int(0, width - 1), cv_ = rng.uniform_int(0, height - 1);
    const double angle_deg = rng.uniform(0.0, 180.0);
    Detection det;
    det.class_id = class_ids[rng.uniform_int(0, static_cast<int>(class_ids.size()) - 1)];
    det.score = static_cast<float>(rng.uniform(0.5, 0.9));
    det.source_instance_id = -1;
    det.probability = ProbabilityImage(width, height, 0.0f);
    cv::Mat1b mask(height, width, static_cast<uchar>(0));
    cv::ellipse(mask, cv::Point(cu, cv_), cv::Size(ru, rv), angle_deg, 0, 360, cv::Scalar(1), -1);
    BoxPx box;
    for (int v = std::max(0, cv_ - std::max(ru, rv));
         v <= std::min(height - 1, cv_ + std::max(ru, rv)); ++v)
      for (int u = std::max(0, cu - std::max(ru, rv));
           u <= std::min(width - 1, cu + std::max(ru, rv)); ++u)
        if (mask(v, u)) box.include(u, v);
    if (box.empty()) continue;
    soft_mask(mask, box, 0, p, rng, det.probability);
    det.box = mask_box(det.probability, threshold);
    if (keep(det, p)) out.push_back(std::move(det));
  }
}

}  // namespace

std::vector<Detection> GroundTruthSegmenter::detect(const RgbdFrame& frame) const {
  std::vector<Detection> out;
  const LabelImage& labels = frame.labels_gt;
  if (labels.empty() || frame.objects_gt.empty()) {
    static std::atomic<bool> warned{false};
    if (!warned.exchange(true))
      spdlog::warn("segmentation gt: frame '{}' has no ground-truth labels; no detections",
                   frame.name);
    return out;
  }
  const int width = labels.width(), height = labels.height();
  const int num_objects = static_cast<int>(frame.objects_gt.size());
  std::vector<int> area(num_objects + 1, 0);
  std::vector<BoxPx> boxes(num_objects + 1);
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u) {
      const int k = labels.at(u, v);
      if (k <= 0 || k > num_objects) continue;
      ++area[k];
      boxes[k].include(u, v);
    }
  const float threshold = static_cast<float>(params_.mask_threshold);
  const auto seed = static_cast<std::uint64_t>(params_.seed);
  const auto frame_key = static_cast<std::uint64_t>(static_cast<std::int64_t>(frame.index));

  for (int k = 1; k <= num_objects; ++k) {
    if (area[k] == 0 || area[k] < params_.gt_min_visible_px) continue;
    const ObjectGroundTruth& object = frame.objects_gt[k - 1];
    Detection det;
    det.class_id = object.class_id;
    det.source_instance_id = object.instance_id;
    det.probability = ProbabilityImage(width, height, 0.0f);
    if (!params_.gt_degrade) {
      det.score = 1.0f;
      for (size_t i = 0; i < labels.size(); ++i)
        if (labels[i] == k) det.probability[i] = 1.0f;
    } else if (!degrade_object(params_, class_ids_, labels, k, boxes[k], object, seed, frame_key,
                               det)) {
      continue;
    }
    det.box = mask_box(det.probability, threshold);
    if (keep(det, params_)) out.push_back(std::move(det));
  }
  if (params_.gt_degrade && params_.gt_spurious_per_frame > 0)
    append_spurious(params_, class_ids_, width, height, seed, frame_key, out);
  return out;
}

}  // namespace orpe
