// CPU forward kernels of the two torchvision operators a scripted torchvision Mask R-CNN calls,
// torchvision::nms and torchvision::roi_align, on plain float buffers (no LibTorch here). They
// follow torchvision 0.14's CPU kernels step by step (same float arithmetic, same tie order), so
// that a model run in LibTorch with these registered (src/orpe/nets/torch) gives torchvision's
// outputs; the tests compare them with torchvision's on random inputs (tests/nets, fixtures by
// scripts/nets/maskrcnn_export.py).
#pragma once

#include <cstdint>
#include <vector>

namespace orpe::nets {

/// Non-maximum suppression: indices of the kept boxes, by decreasing score (ties: lower index
/// first). boxes: n x 4 (x1, y1, x2, y2), row-major; a box is suppressed by a kept one when IoU >
/// threshold.
std::vector<std::int64_t> nms_cpu(const float* boxes, const float* scores, int n,
                                  float iou_threshold);

/// Shape of roi_align's feature input (N, C, H, W) and its parameters.
struct RoiAlignSpec {
  int batch = 0, channels = 0, height = 0, width = 0;
  float spatial_scale = 1;  ///< feature pixels per input pixel
  int pooled_height = 1, pooled_width = 1;
  int sampling_ratio = -1;  ///< samples per bin side; <= 0 = ceil(roi size / pooled size)
  bool aligned = false;     ///< true: pixel centres at +0.5 (no 1-pixel minimum RoI size)
};

/// RoI Align: rois is k x 5 (batch index, x1, y1, x2, y2 in input pixels); out is
/// k x C x pooled_height x pooled_width. Throws std::invalid_argument for a batch index outside
/// [0, N).
void roi_align_cpu(const float* input, const RoiAlignSpec& spec, const float* rois, int num_rois,
                   float* out);

}  // namespace orpe::nets
