#include "orpe/nets/densefusion_estimator.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>
#include <stdexcept>

#include <Eigen/Geometry>

#include "orpe/core/error.h"

namespace orpe::nets {

namespace {

/// The reference's snapping: a size strictly between two borders becomes the upper one; then a
/// multiple of 8 (PSPNet's stride) no larger than the image.
int snap_size(int size, int image_size) {
  static const int borders[] = {-1,  40,  80,  120, 160, 200, 240, 280, 320,
                                360, 400, 440, 480, 520, 560, 600, 640, 680};
  for (size_t k = 0; k + 1 < std::size(borders); ++k)
    if (size > borders[k] && size < borders[k + 1]) {
      size = borders[k + 1];
      break;
    }
  size = (size + 7) / 8 * 8;
  return std::min(size, image_size / 8 * 8);
}

/// Centres a span of `size` on [lo, hi) and shifts it inside [0, limit), as the reference does.
void place(int lo, int hi, int size, int limit, int* out_lo, int* out_hi) {
  const int centre = (lo + hi) / 2;
  int a = centre - size / 2, b = centre + size / 2;
  if (a < 0) b -= a, a = 0;
  if (b > limit) a -= b - limit, b = limit;
  *out_lo = a;
  *out_hi = b;
}

constexpr float kMean[3] = {0.485f, 0.456f, 0.406f};
constexpr float kStd[3] = {0.229f, 0.224f, 0.225f};

}  // namespace

CropBox densefusion_box(const MaskImage& mask) {
  int rmin = mask.height(), rmax = -1, cmin = mask.width(), cmax = -1;
  for (int v = 0; v < mask.height(); ++v)
    for (int u = 0; u < mask.width(); ++u)
      if (mask.at(u, v)) {
        rmin = std::min(rmin, v), rmax = std::max(rmax, v);
        cmin = std::min(cmin, u), cmax = std::max(cmax, u);
      }
  CropBox box;
  if (rmax < 0) return box;
  ++rmax, ++cmax;  // exclusive, as datasets/ycb/dataset.py's get_bbox
  place(rmin, rmax, snap_size(rmax - rmin, mask.height()), mask.height(), &box.rmin, &box.rmax);
  place(cmin, cmax, snap_size(cmax - cmin, mask.width()), mask.width(), &box.cmin, &box.cmax);
  return box;
}

bool make_densefusion_input(const SingleViewInput& in, int num_points, int min_points,
                            unsigned seed, DenseFusionInput* out, std::string* why) {
  auto fail = [&](const std::string& reason) {
    if (why) *why = reason;
    return false;
  };
  if (!in.IsValid(why)) return false;
  if (!in.color) return fail("densefusion needs the colour image");
  const MaskImage& mask = *in.mask;
  if (mask.width() < 8 || mask.height() < 8)
    return fail("densefusion: image " + std::to_string(mask.width()) + "x" +
                std::to_string(mask.height()) + " is smaller than 8 x 8 px");
  DenseFusionInput& d = *out;
  d = DenseFusionInput{};
  d.box = densefusion_box(mask);
  const CropBox& b = d.box;
  if (b.height() <= 0 || b.width() <= 0) return fail("empty mask");
  const int w = b.width();
  std::vector<std::int64_t> valid;  // crop indices of mask pixels with depth, row-major
  for (int v = b.rmin; v < b.rmax; ++v)
    for (int u = b.cmin; u < b.cmax; ++u)
      if (mask.at(u, v) && in.depth->at(u, v) > 0)
        valid.push_back(std::int64_t(v - b.rmin) * w + (u - b.cmin));
  d.valid_pixels = static_cast<int>(valid.size());
  if (d.valid_pixels < min_points)
    return fail("densefusion: " + std::to_string(d.valid_pixels) +
                " mask pixels with depth in the box, fewer than densefusion_min_points");
  if (d.valid_pixels > num_points) {  // a random subset, kept in image order (the reference)
    std::vector<char> keep(valid.size(), 0);
    std::fill(keep.begin(), keep.begin() + num_points, 1);
    std::mt19937 rng(seed);
    std::shuffle(keep.begin(), keep.end(), rng);
    for (size_t k = 0; k < valid.size(); ++k)
      if (keep[k]) d.choose.push_back(valid[k]);
  } else {  // np.pad(..., 'wrap')
    for (int k = 0; k < num_points; ++k) d.choose.push_back(valid[k % valid.size()]);
  }
  const PinholeIntrinsics& K = in.intrinsics;
  d.cloud.reserve(3 * size_t(num_points));
  for (size_t k = 0; k < d.choose.size(); ++k) {
    const int u = b.cmin + int(d.choose[k] % w), v = b.rmin + int(d.choose[k] / w);
    const float z = in.depth->at(u, v);
    const Eigen::Vector3f p((float(u) - float(K.cx)) * z / float(K.fx),
                            (float(v) - float(K.cy)) * z / float(K.fy), z);
    d.cloud.insert(d.cloud.end(), {p.x(), p.y(), p.z()});
    if (k < std::min<size_t>(valid.size(), num_points)) d.points.push_back(p);
  }
  const size_t plane = size_t(b.height()) * w;
  d.crop_chw.resize(3 * plane);
  for (int v = b.rmin; v < b.rmax; ++v)
    for (int u = b.cmin; u < b.cmax; ++u) {
      const Rgb8 c = in.color->at(u, v);
      const float rgb[3] = {float(c.r), float(c.g), float(c.b)};
      const size_t at = size_t(v - b.rmin) * w + (u - b.cmin);
      for (int ch = 0; ch < 3; ++ch) d.crop_chw[ch * plane + at] = (rgb[ch] - kMean[ch]) / kStd[ch];
    }
  return true;
}

DenseFusionEstimator::DenseFusionEstimator(const PoseBackendParams& params,
                                           const std::map<int, std::string>& class_names)
    : params_(params) {
  std::string why;
  if (!params_.IsValid(&why)) throw ConfigError("pose: " + why);
  DenseFusionSpec spec;
  spec.num_objects = 0;  // from the file
  if (params_.densefusion_random_seed >= 0) {
    spec.num_objects = static_cast<int>(class_names.size());
    spec.random_seed = params_.densefusion_random_seed;
  }
  spec.num_points = params_.densefusion_num_points;
  spec.threads = params_.densefusion_threads;
  spec.posenet_path = params_.densefusion_model;
  if (params_.densefusion_iterations > 0) spec.refiner_path = params_.densefusion_refiner;
  network_ = std::make_unique<DenseFusionNetwork>(spec);
  const int n = network_->num_objects();
  if (n != static_cast<int>(class_names.size())) {
    std::string list;
    for (const auto& [id, name] : class_names) list += (list.empty() ? "" : ", ") + name;
    throw ConfigError(params_.densefusion_model + ": the network has " + std::to_string(n) +
                      " object classes, the dataset " + std::to_string(class_names.size()) + " (" +
                      list + "); train or convert a model for the dataset's classes");
  }
  int index = 0;
  for (const auto& [id, name] : class_names) index_of_class_[id] = index++;
}

int DenseFusionEstimator::object_index(int class_id) const {
  const auto it = index_of_class_.find(class_id);
  return it == index_of_class_.end() ? -1 : it->second;
}

SingleViewPose DenseFusionEstimator::estimate(const SingleViewInput& input) const {
  const auto t0 = std::chrono::steady_clock::now();
  SingleViewPose out;
  const int obj = object_index(input.class_id);
  DenseFusionInput d;
  if (obj < 0) {
    out.reason = "densefusion: class " + std::to_string(input.class_id) + " is not the dataset's";
  } else if (make_densefusion_input(
                 input, params_.densefusion_num_points, params_.densefusion_min_points,
                 static_cast<unsigned>(params_.densefusion_seed), &d, &out.reason)) {
    try {
      const DenseFusionPoints pts =
          network_->estimate(d.crop_chw, d.box.height(), d.box.width(), d.cloud, d.choose, obj);
      const DenseFusionPose p = network_->pose(pts, d.cloud, obj, params_.densefusion_iterations);
      const Eigen::Quaterniond q(p.quaternion[0], p.quaternion[1], p.quaternion[2],
                                 p.quaternion[3]);
      out.T_cam_obj = SE3(q, Vec3(p.translation[0], p.translation[1], p.translation[2]));
      out.score = *std::max_element(pts.confidence.begin(), pts.confidence.end());
      out.num_points = static_cast<int>(d.points.size());
      out.mu_m = mean_model_distance_m(d.points, *input.model, out.T_cam_obj);
      out.valid = std::isfinite(out.mu_m) && out.T_cam_obj.translation().allFinite();
      if (!out.valid) out.reason = "densefusion: the network gave a non-finite pose";
    } catch (const std::exception& e) {  // the interface never throws on content
      out.reason = std::string("densefusion: ") + e.what();
    }
  }
  out.time_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace orpe::nets
