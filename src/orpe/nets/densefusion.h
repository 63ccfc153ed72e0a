// DenseFusion (Wang et al., CVPR 2019) in LibTorch, CPU: PoseNet (PSPNet ResNet-18 colour
// embedding, PointNet geometry, dense fusion, per-point rotation / translation / confidence heads)
// and PoseRefineNet, with the reference implementation's parameter names and shapes
// (cnn.model.module.feats.conv1.weight, ...; 77 + 24 tensors). LibTorch stays in the plugin
// (orpe/nets/plugin.h). docs/NETWORKS.md. The pose back-end over it: densefusion_estimator.h.
#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

namespace orpe::nets {

class DenseFusionImpl;

struct DenseFusionSpec {
  /// Classes of the checkpoint (YCB-Video: 21); 0 = from the PoseNet file (conv4_r.weight's rows /
  /// 4).
  int num_objects = 21;
  int num_points = 1000;
  int threads = 0;  ///< LibTorch intra-op threads (process-wide); 0 = LibTorch's default
  /// Weights: files of parameter name -> tensor (scripts/nets/densefusion_fixtures.py convert), or,
  /// when random_seed >= 0, seeded normal weights drawn in the reference's parameter order
  /// (torch.manual_seed(seed), then per tensor normal_(0, 1/sqrt(fan_in)) or normal_(0, 0.1) for
  /// 1-D tensors): the same weights as the fixture script's, for the equivalence tests.
  std::string posenet_path, refiner_path;
  int random_seed = -1;
};

/// Per-point outputs of PoseNet for one object (rows: points).
struct DenseFusionPoints {
  std::vector<float> rotation;     ///< num_points x 4, quaternion (w, x, y, z), not normalised
  std::vector<float> translation;  ///< num_points x 3, offset from the point (m)
  std::vector<float> confidence;   ///< num_points
  std::vector<float> embedding;    ///< 32 x num_points (the refiner's colour input)
};

/// A pose as DenseFusion's evaluation gives it: unit quaternion (w, x, y, z) and translation (m).
struct DenseFusionPose {
  std::array<double, 4> quaternion{1, 0, 0, 0};
  std::array<double, 3> translation{0, 0, 0};
};

class DenseFusionNetwork {
 public:
  /// Throws IoError naming a file with a missing / misshapen tensor, ConfigError without LibTorch.
  explicit DenseFusionNetwork(const DenseFusionSpec& spec);
  ~DenseFusionNetwork();
  DenseFusionNetwork(const DenseFusionNetwork&) = delete;
  DenseFusionNetwork& operator=(const DenseFusionNetwork&) = delete;

  /// PoseNet on an ImageNet-normalised crop (3 x h x w, h and w multiples of 8), the cloud
  /// (num_points x 3, m, camera frame) and `choose` (num_points pixel indices into the crop,
  /// row-major), for object index `obj` (class - 1). Throws std::invalid_argument for wrong sizes.
  DenseFusionPoints estimate(const std::vector<float>& crop_chw, int h, int w,
                             const std::vector<float>& cloud,
                             const std::vector<std::int64_t>& choose, int obj) const;
  /// The reference evaluation: best-confidence point, then `iterations` refiner passes.
  DenseFusionPose pose(const DenseFusionPoints& points, const std::vector<float>& cloud, int obj,
                       int iterations, DenseFusionPose* before_refinement = nullptr) const;
  int num_objects() const;  ///< classes of the loaded network
  int num_points() const;
  bool has_refiner() const;
  /// Parameter names and shapes (PoseNet then PoseRefineNet, reference order), for tests.
  std::vector<std::pair<std::string, std::vector<std::int64_t>>> parameters() const;

 private:
  std::unique_ptr<DenseFusionImpl> impl_;
};

}  // namespace orpe::nets
