#include "orpe/nets/torchvision_kernels.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>

namespace orpe::nets {

std::vector<std::int64_t> nms_cpu(const float* boxes, const float* scores, int n,
                                  float iou_threshold) {
  std::vector<int> order(static_cast<size_t>(n));
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return scores[a] > scores[b]; });
  std::vector<float> areas(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    const float* b = boxes + 4 * i;
    areas[i] = (b[2] - b[0]) * (b[3] - b[1]);
  }
  std::vector<char> suppressed(static_cast<size_t>(n), 0);
  std::vector<std::int64_t> keep;
  for (int oi = 0; oi < n; ++oi) {
    const int i = order[oi];
    if (suppressed[i]) continue;
    keep.push_back(i);
    const float* bi = boxes + 4 * i;
    for (int oj = oi + 1; oj < n; ++oj) {
      const int j = order[oj];
      if (suppressed[j]) continue;
      const float* bj = boxes + 4 * j;
      const float w = std::max(0.0f, std::min(bi[2], bj[2]) - std::max(bi[0], bj[0]));
      const float h = std::max(0.0f, std::min(bi[3], bj[3]) - std::max(bi[1], bj[1]));
      const float inter = w * h;
      const float iou = inter / (areas[i] + areas[j] - inter);
      if (iou > iou_threshold) suppressed[j] = 1;
    }
  }
  return keep;
}

namespace {

/// One bilinear sample: four feature offsets and their weights (zero weights outside the map).
struct Sample {
  int pos[4] = {0, 0, 0, 0};
  float w[4] = {0, 0, 0, 0};
};

Sample bilinear_sample(float y, float x, int height, int width) {
  Sample s;
  if (y < -1.0f || y > height || x < -1.0f || x > width) return s;
  if (y <= 0) y = 0;
  if (x <= 0) x = 0;
  int y_low = static_cast<int>(y), x_low = static_cast<int>(x), y_high, x_high;
  if (y_low >= height - 1) {
    y_high = y_low = height - 1;
    y = static_cast<float>(y_low);
  } else {
    y_high = y_low + 1;
  }
  if (x_low >= width - 1) {
    x_high = x_low = width - 1;
    x = static_cast<float>(x_low);
  } else {
    x_high = x_low + 1;
  }
  const float ly = y - y_low, lx = x - x_low, hy = 1.0f - ly, hx = 1.0f - lx;
  s.pos[0] = y_low * width + x_low;
  s.pos[1] = y_low * width + x_high;
  s.pos[2] = y_high * width + x_low;
  s.pos[3] = y_high * width + x_high;
  s.w[0] = hy * hx;
  s.w[1] = hy * lx;
  s.w[2] = ly * hx;
  s.w[3] = ly * lx;
  return s;
}

}  // namespace

void roi_align_cpu(const float* input, const RoiAlignSpec& spec, const float* rois, int num_rois,
                   float* out) {
  const int ph_n = spec.pooled_height, pw_n = spec.pooled_width;
  const size_t plane = static_cast<size_t>(spec.height) * spec.width;
  const float offset = spec.aligned ? 0.5f : 0.0f;
  std::vector<Sample> samples;
  for (int r = 0; r < num_rois; ++r) {
    const float* roi = rois + 5 * r;
    const int b = static_cast<int>(roi[0]);
    if (b < 0 || b >= spec.batch)
      throw std::invalid_argument("roi_align: RoI " + std::to_string(r) + " has batch index " +
                                  std::to_string(b) + ", the input has " +
                                  std::to_string(spec.batch));
    const float x0 = roi[1] * spec.spatial_scale - offset,
                y0 = roi[2] * spec.spatial_scale - offset;
    float roi_w = roi[3] * spec.spatial_scale - offset - x0;
    float roi_h = roi[4] * spec.spatial_scale - offset - y0;
    if (!spec.aligned) {
      roi_w = std::max(roi_w, 1.0f);
      roi_h = std::max(roi_h, 1.0f);
    }
    const float bin_h = roi_h / static_cast<float>(ph_n), bin_w = roi_w / static_cast<float>(pw_n);
    const int grid_h =
        spec.sampling_ratio > 0 ? spec.sampling_ratio : static_cast<int>(std::ceil(roi_h / ph_n));
    const int grid_w =
        spec.sampling_ratio > 0 ? spec.sampling_ratio : static_cast<int>(std::ceil(roi_w / pw_n));
    const float count = static_cast<float>(std::max(grid_h * grid_w, 1));
    samples.clear();
    for (int ph = 0; ph < ph_n; ++ph)
      for (int pw = 0; pw < pw_n; ++pw)
        for (int iy = 0; iy < grid_h; ++iy) {
          const float y = y0 + ph * bin_h + static_cast<float>(iy + .5f) * bin_h / grid_h;
          for (int ix = 0; ix < grid_w; ++ix) {
            const float x = x0 + pw * bin_w + static_cast<float>(ix + .5f) * bin_w / grid_w;
            samples.push_back(bilinear_sample(y, x, spec.height, spec.width));
          }
        }
    for (int c = 0; c < spec.channels; ++c) {
      const float* data = input + (static_cast<size_t>(b) * spec.channels + c) * plane;
      float* o = out + (static_cast<size_t>(r) * spec.channels + c) * ph_n * pw_n;
      size_t k = 0;
      for (int bin = 0; bin < ph_n * pw_n; ++bin) {
        float v = 0;
        for (int g = 0; g < grid_h * grid_w; ++g, ++k) {
          const Sample& s = samples[k];
          v += s.w[0] * data[s.pos[0]] + s.w[1] * data[s.pos[1]] + s.w[2] * data[s.pos[2]] +
               s.w[3] * data[s.pos[3]];
        }
        o[bin] = v / count;
      }
    }
  }
}

}  // namespace orpe::nets
