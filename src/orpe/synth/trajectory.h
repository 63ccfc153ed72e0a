// Hand-held-like camera paths around a scene: an arc at roughly constant distance with varying
// speed, height and distance, a wandering look-at point, and a small hand shake; every camera looks
// at the scene (z axis through the look-at point, x horizontal up to a small roll).
#pragma once

#include <random>
#include <vector>

#include "orpe/core/se3.h"

namespace orpe::synth {

struct TrajectoryParams {
  int frames = 300;
  double fps = 30.0;
  double span_deg = 140.0;  ///< azimuth swept by the arc around the target
  double baseline_m =
      0.0;  ///< > 0: distance between the first and last camera centre (sets the span)
  double distance_m = 1.5;      ///< mean distance camera - target
  double elevation_deg = 35.0;  ///< mean elevation above the horizontal seen from the target
  double azimuth_centre_rad = -M_PI / 2;  ///< azimuth of the arc's middle (world xy, from +x)
  double shake_m = 0.002;                 ///< hand-shake amplitude (translation, per axis)
  double shake_deg = 0.3;                 ///< hand-shake amplitude (rotation)
  double min_height_m = 0.25;             ///< cameras never go below this z
};

/// Builds the camera-to-world poses (T_world_cam, OpenCV camera axes) of `frames` frames.
/// Deterministic for a given generator state.
std::vector<SE3> make_handheld_trajectory(const TrajectoryParams& params, const Vec3& target_world,
                                          std::mt19937_64& rng);

/// Largest distance between two camera centres of a trajectory (m).
double trajectory_extent_m(const std::vector<SE3>& T_world_cam);

}  // namespace orpe::synth
