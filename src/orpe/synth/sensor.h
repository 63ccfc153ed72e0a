// Structured-light RGB-D sensor model (Kinect v1 / Xtion class), applied to a clean rendered frame.
//
// Depth, in this order:
//  1. projector shadows: the projector sits `baseline_m` to the camera's right (+x); surface points
//  it
//     cannot see (occluded along its rows) get no depth, as on the left of foreground objects;
//  2. grazing angles: no depth where the angle between the surface normal and the viewing ray
//  exceeds
//     `grazing_max_deg`, with a probability ramping up from `grazing_start_deg`;
//  3. depth edges: pixels next to a jump of more than `edge_jump_m` (+ 2 % of z) lose their depth
//  with
//     probability `edge_dropout`; lateral noise jitters the edges by `lateral_sigma_px`;
//  4. axial noise (Nguyen, Izadi, Lovell 2012):
//       sigma_z(z, theta) = 0.0012 + 0.0019 (z - 0.4)^2 + 0.0001 / sqrt(z) * theta^2 / (pi/2 -
//       theta)^2,
//     z in metres, theta the incidence angle (rad; the angle term is capped at theta = 80 deg);
//  5. disparity quantisation: d = f b / z rounded to 1 / `disparity_subpixel` pixel;
//  6. range: depth outside [min_depth_m, max_depth_m] becomes 0; random dropouts (`dropout`).
// Colour: a global gain (illumination variation, from the caller), Gaussian noise per channel.
#pragma once

#include <random>
#include <string>

#include "orpe/core/camera.h"
#include "orpe/core/image.h"

namespace orpe::synth {

struct DepthSensorParams {
  bool enabled = true;
  double min_depth_m = 0.4;
  double max_depth_m = 4.5;
  double baseline_m = 0.075;      ///< projector - camera
  double disparity_subpixel = 8;  ///< disparity steps per pixel
  double noise_scale = 1.0;       ///< multiplies sigma_z
  double lateral_sigma_px = 0.8;  ///< edge jitter (pixels)
  double grazing_start_deg = 70;
  double grazing_max_deg = 82;
  double edge_jump_m = 0.03;
  double edge_dropout = 0.5;
  double dropout = 0.002;  ///< random missing pixels
  bool projector_shadow = true;

  bool IsValid(std::string* why) const;
};

/// Axial noise sigma (m) at depth z (m) and incidence angle theta (rad), before noise_scale.
double axial_noise_sigma_m(double z_m, double theta_rad);

/// Disparity quantisation step of depth at z (m): z^2 / (f b subpixel).
double quantisation_step_m(double z_m, double focal_px, const DepthSensorParams& p);

/// A bound the sensor's depth error stays within for interior pixels (not jittered edges):
/// 5 sigma_z(z, theta) * noise_scale + one quantisation step.
double depth_error_bound_m(double z_m, double theta_rad, double focal_px,
                           const DepthSensorParams& p);

struct DepthSensorStats {
  size_t shadowed = 0, grazing = 0, edges = 0, out_of_range = 0, dropped = 0;
};

/// Applies the model to a clean depth image (m, 0 = none) with camera-frame normals (facing the
/// camera). Deterministic for a given generator state.
DepthImage simulate_depth_sensor(const DepthImage& clean, const Image<Eigen::Vector3f>& normals,
                                 const PinholeIntrinsics& K, const DepthSensorParams& p,
                                 std::mt19937_64& rng, DepthSensorStats* stats = nullptr);

/// Colour: multiplies by `gain`, adds Gaussian noise of `sigma` levels per channel (then clamps).
void apply_color_noise(ColorImage& image, double gain, double sigma, std::mt19937_64& rng);

}  // namespace orpe::synth
