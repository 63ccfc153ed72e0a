// Frame preprocessing for dense SLAM: depth cut-off and bilateral filter, 3-level pyramids of depth and
// intensity (2x2 block averages, matching PinholeIntrinsics::scaled), vertex and normal maps in the
// camera frame, and intensity gradients.
#pragma once

#include <string>
#include <vector>

#include "orpe/core/camera.h"
#include "orpe/core/frame.h"
#include "orpe/core/image.h"
#include "orpe/slam/map_renderer.h"

namespace orpe::slam {

/// Intensity 0..255 as float (0.299 R + 0.587 G + 0.114 B), the units of ElasticFusion's photometric
/// thresholds.
using IntensityImage = Image<float>;

struct PreprocessParams {
  int pyramid_levels = 3;             ///< levels, finest = full resolution
  double min_depth_m = 0.2;           ///< nearer depth is invalid
  double max_depth_m = 6.0;           ///< farther depth is invalid (tracking range; fusion cuts at 3 m)
  int bilateral_radius_px = 2;        ///< window (2r+1)^2; ElasticFusion uses r = 6 on the GPU
  double bilateral_sigma_space_px = 4.5;
  double bilateral_sigma_depth_m = 0.03;
  double pyramid_max_depth_jump_m = 0.09;  ///< 2x2 depth averaging skips pixels this far from the block's first
  double normal_max_depth_jump_m = 0.05;   ///< no normal across a depth jump larger than this (scaled by z)

  template <class V>
  void visit(V&& v) {
    v("pyramid_levels", pyramid_levels, "Pyramid levels for tracking (1-5); ElasticFusion: 3");
    v("min_depth_m", min_depth_m, "Depth below this is invalid (m)");
    v("max_depth_m", max_depth_m, "Depth beyond this is invalid for tracking (m); ElasticFusion: 6");
    v("bilateral_radius_px", bilateral_radius_px,
      "Bilateral depth filter half-window (px); 0 = no filter. ElasticFusion: 6 (GPU); 2 here for speed");
    v("bilateral_sigma_space_px", bilateral_sigma_space_px, "Bilateral spatial sigma (px); ElasticFusion: 4.5");
    v("bilateral_sigma_depth_m", bilateral_sigma_depth_m, "Bilateral range sigma (m); ElasticFusion: 0.03");
    v("pyramid_max_depth_jump_m", pyramid_max_depth_jump_m,
      "Depth pyramid: a 2x2 block averages only depths within this of its first valid depth (m)");
    v("normal_max_depth_jump_m", normal_max_depth_jump_m,
      "No normal where a neighbour's depth differs by more than this times z (m per m of depth)");
  }
  bool IsValid(std::string* why) const;
};

/// One pyramid level. All images have the level's resolution (intrinsics `K`).
struct FrameLevel {
  PinholeIntrinsics K;
  DepthImage depth;           ///< filtered depth (m), 0 = invalid
  VertexImage vertex;         ///< camera frame (m), z = 0 invalid
  NormalImage normal;         ///< camera frame, unit, facing the camera; zero = invalid
  IntensityImage intensity;   ///< 0..255
  Image<float> grad_u;        ///< d intensity / du (per pixel), 3x3 Sobel / 8
  Image<float> grad_v;        ///< d intensity / dv
};

/// A preprocessed frame. Buffers are reused across frames of the same size.
struct FramePyramid {
  std::vector<FrameLevel> levels;  ///< [0] = full resolution
  DepthImage raw_depth;            ///< input depth after the min/max cut, unfiltered (fusion)
  ColorImage color;                ///< input colour (fusion)
};

class FramePreprocessor {
 public:
  /// `level0_normal_step` n > 1: level-0 normals only at every n-th row and column (the rest
  /// zero), for a tracker that reads level 0 at that pixel step when nothing else reads its normals.
  explicit FramePreprocessor(const PreprocessParams& params = {}, int level0_normal_step = 1);
  const PreprocessParams& params() const { return params_; }

  /// Fills `out` from an RGB-D frame. Colour and depth must have the intrinsics' size (else
  /// ConfigError naming the frame).
  void process(const RgbdFrame& frame, FramePyramid* out) const;

 private:
  /// Bilateral filter of the cut depth (invalid pixels stay invalid and do not contribute).
  void bilateral(const DepthImage& src, DepthImage* out) const;

  PreprocessParams params_;
  int level0_normal_step_ = 1;
  std::vector<float> range_lut_;  // range weight per millimetre of depth difference
  std::vector<float> space_lut_;  // spatial weight per window offset
};

/// Vertex and normal maps from a depth image (used for the frame and for rendered model levels).
void compute_vertex_map(const DepthImage& depth, const PinholeIntrinsics& K, VertexImage* vertex);
/// `step` n > 1: normals only at every n-th row and column (from 0); the other pixels get zero.
void compute_normal_map(const VertexImage& vertex, double max_depth_jump_per_m, NormalImage* normal,
                        int step = 1);
/// 2x2 block average of depth, skipping invalid pixels and pixels far from the block's first depth.
void downsample_depth(const DepthImage& in, float max_jump_m, DepthImage* out);
/// 2x2 block average of an intensity image (all pixels valid).
void downsample_intensity(const IntensityImage& in, IntensityImage* out);
/// 3x3 Sobel / 8: derivatives in intensity units per pixel; border pixels get 0.
void compute_gradients(const IntensityImage& in, Image<float>* gu, Image<float>* gv);
void color_to_intensity(const ColorImage& color, IntensityImage* out);

}  // namespace orpe::slam
