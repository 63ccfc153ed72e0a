// The `densefusion` pose back-end (pose.backend=densefusion): DenseFusion's PoseNet and
// PoseRefineNet (orpe/nets/densefusion.h, LibTorch in the plugin) behind the single-view pose
// interface, with the reference evaluation's input contract (tools/eval_ycb.py, datasets/ycb/
// dataset.py of j96w/DenseFusion; ../shared/spec/REFERENCE.md):
//   - box of the mask, height and width snapped up to the next of 40, 80, ..., 680 px, kept
//     centred, shifted inside the image (and, for images smaller than the box, shrunk to the
//     image, a multiple of 8);
//   - the mask's pixels with valid depth inside the box; num_points of them chosen (a seeded random
//     subset in image order, or wrap-padded when fewer), back-projected to metres;
//   - the crop's RGB values (0..255, as the reference feeds them) normalised with ImageNet's mean
//     and std;
//   - the object's head = the class's index among the dataset's sorted class ids (YCB-Video: id-1);
//   - most confident point's pose, then `iterations` refiner passes.
// mu (the EKF's noise) = mean distance of the used points to the model under the pose. The
// pipeline feeds the map-rendered mask / depth / colour when the variant asks for PM / PD / PC.
// No LibTorch here. docs/NETWORKS.md.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "orpe/nets/densefusion.h"
#include "orpe/pose/pose_backend.h"
#include "orpe/pose/single_view.h"

namespace orpe::nets {

/// The crop box (rows [rmin, rmax), columns [cmin, cmax)) of a mask as the reference computes it;
/// {0, 0, 0, 0} for an empty mask.
struct CropBox {
  int rmin = 0, rmax = 0, cmin = 0, cmax = 0;
  int height() const { return rmax - rmin; }
  int width() const { return cmax - cmin; }
};
CropBox densefusion_box(const MaskImage& mask);

/// One object's network input.
struct DenseFusionInput {
  CropBox box;
  std::vector<float> crop_chw;          ///< 3 x h x w, ImageNet-normalised 0..255 RGB
  std::vector<float> cloud;             ///< num_points x 3, camera frame, metres
  std::vector<std::int64_t> choose;     ///< num_points indices into the crop (row-major)
  std::vector<Eigen::Vector3f> points;  ///< the distinct chosen points (for mu)
  int valid_pixels = 0;                 ///< mask pixels with depth in the box
};

/// Builds the input from a single-view input (mask, depth, colour, intrinsics). False with the
/// reason when it cannot (no colour, too few points, image smaller than 8 x 8).
bool make_densefusion_input(const SingleViewInput& in, int num_points, int min_points,
                            unsigned seed, DenseFusionInput* out, std::string* why);

class DenseFusionEstimator : public SingleViewPoseEstimator {
 public:
  /// Loads the networks (pose.densefusion_model / _refiner). `class_names`: the dataset's classes;
  /// the network must have one head per class. Throws IoError naming a missing or incompatible
  /// file, ConfigError for a class-count mismatch or without LibTorch.
  DenseFusionEstimator(const PoseBackendParams& params,
                       const std::map<int, std::string>& class_names);
  std::string name() const override { return "densefusion"; }
  SingleViewPose estimate(const SingleViewInput& input) const override;

  /// The network head of a class (-1 when the class is not the dataset's).
  int object_index(int class_id) const;
  const DenseFusionNetwork& network() const { return *network_; }
  const PoseBackendParams& params() const { return params_; }

 private:
  PoseBackendParams params_;
  std::unique_ptr<DenseFusionNetwork> network_;
  std::map<int, int> index_of_class_;
};

}  // namespace orpe::nets
