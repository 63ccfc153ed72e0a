// The `maskrcnn` segmentation back-end: a torchvision Mask R-CNN exported to TorchScript
// (scripts/nets/maskrcnn_export.py), run in LibTorch on the CPU, no Python at run time. LibTorch
// stays in src/orpe/nets/torch, a plugin opened on first use (orpe/nets/plugin.h): this header has
// none. docs/NETWORKS.md.
#pragma once

#include <array>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "orpe/core/image.h"
#include "orpe/semantic/segmenter.h"

namespace orpe::nets {

class MaskRcnnImpl;

/// True when orpe was built with LibTorch (ORPE_WITH_TORCH): the network back-ends exist.
bool torch_built();

/// A tensor copied out of LibTorch: shape and float values, row-major.
struct HostTensor {
  std::vector<std::int64_t> shape;
  std::vector<float> values;
  std::int64_t numel() const;
};

/// Reads every buffer of a scripted module saved by torch.jit.save (the fixture format of
/// scripts/nets/*.py), as float. Throws IoError naming the file.
std::map<std::string, HostTensor> read_tensor_file(const std::string& path);

/// Raw network output of one image, as torchvision's postprocess gives it (full-image boxes and
/// soft masks, network labels), sorted by decreasing score.
struct MaskRcnnOutput {
  std::vector<std::array<float, 4>> boxes;  ///< x1, y1, x2, y2 in image pixels (continuous)
  std::vector<float> scores;
  std::vector<int> labels;              ///< network labels, 1..num_classes-1
  std::vector<ProbabilityImage> masks;  ///< full-image mask probabilities
};

struct MaskRcnnOptions {
  int threads = 0;      ///< LibTorch intra-op threads (process-wide); 0 = LibTorch's default
  int min_size_px = 0;  ///< network input shorter side; 0 = as exported
  int max_size_px = 0;  ///< network input longer side at most; 0 = as exported
};

/// A loaded TorchScript Mask R-CNN. Registers the torchvision operators it needs (own CPU kernels,
/// orpe/nets/torchvision_kernels.h) on first use.
class MaskRcnnNetwork {
 public:
  /// Throws IoError (naming the file) for a missing, unreadable or non-Mask R-CNN file, ConfigError
  /// when orpe was built without LibTorch.
  MaskRcnnNetwork(const std::string& model_path, const MaskRcnnOptions& options);
  ~MaskRcnnNetwork();
  MaskRcnnNetwork(const MaskRcnnNetwork&) = delete;
  MaskRcnnNetwork& operator=(const MaskRcnnNetwork&) = delete;

  /// Classes including the background (metadata of the export script; 0 when the file has none).
  int num_classes() const;
  /// Runs the network on an RGB image (at least 32 x 32 px). Throws std::invalid_argument for a
  /// smaller one, IoError naming the model file when LibTorch fails.
  MaskRcnnOutput run(const ColorImage& image) const;

 private:
  std::unique_ptr<MaskRcnnImpl> impl_;  ///< in the LibTorch plugin (orpe/nets/plugin.h)
};

/// Network label -> dataset class id, from a class map file: one `label class` line per network
/// label 1..num_labels (class = dataset class id or name), '#' comments. Every label exactly once,
/// every class one of `class_names`. Throws IoError naming the file and line.
std::map<int, int> read_class_map(const std::string& path, int num_labels,
                                  const std::map<int, std::string>& class_names);

/// The segmenter: network + class map; detections filtered by SegmentationParams' min_score and
/// min_mask_area_px. Checks each frame's colour image against its depth image and the size given at
/// construction when set (SegmentationParams::maskrcnn_input_*), throwing std::invalid_argument.
class MaskRcnnSegmenter : public Segmenter {
 public:
  /// `class_names`: the dataset's classes. Throws IoError / ConfigError (see MaskRcnnNetwork and
  /// read_class_map); the class map must have one line per network class (num_classes - 1).
  MaskRcnnSegmenter(const SegmentationParams& params,
                    const std::map<int, std::string>& class_names);
  std::string name() const override { return "maskrcnn"; }
  std::vector<Detection> detect(const RgbdFrame& frame) const override;
  /// The detections of a raw output (class map, filters), for tests.
  std::vector<Detection> to_detections(const MaskRcnnOutput& output) const;

 private:
  SegmentationParams params_;
  std::unique_ptr<MaskRcnnNetwork> network_;
  std::map<int, int> class_of_label_;
};

}  // namespace orpe::nets
