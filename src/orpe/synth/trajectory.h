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

/// A closed loop: the camera circles `centre` once (counter-clockwise seen from above) and goes on
/// for overlap_deg over the start of its path again, so the last frames revisit the first ones.
/// Radius, height and viewing direction vary smoothly with the azimuth (periodic in it: the path
/// itself closes); the speed varies +-25 % with time, and the hand shake of
/// make_handheld_trajectory is added.
struct LoopParams {
  int frames = 1200;
  double fps = 30.0;
  double overlap_deg = 30.0;  ///< azimuth travelled beyond 360 degrees
  double radius_m = 0.9;      ///< mean radius of the circle (m), varies +-10 %
  /// true: look away from the centre (inside a room, at its walls); false: look at the centre
  /// from elevation_deg above it (around a scene).
  bool outward = true;
  double height_m = 1.0;         ///< outward: mean camera height (m), varies +-0.1 m
  double pitch_deg = -8.0;       ///< outward: mean pitch (deg, negative = down), varies +-5 deg
  double yaw_wander_deg = 12.0;  ///< outward: the view turns away from the radial by up to this
  double elevation_deg = 35.0;   ///< inward: mean elevation seen from the centre
  double shake_m = 0.002;
  double shake_deg = 0.3;
  double min_height_m = 0.25;
};
std::vector<SE3> make_loop_trajectory(const LoopParams& params, const Vec3& centre_world,
                                      std::mt19937_64& rng);

/// Largest distance between two camera centres of a trajectory (m).
double trajectory_extent_m(const std::vector<SE3>& T_world_cam);

}  // namespace orpe::synth
