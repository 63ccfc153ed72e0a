#include "orpe/synth/trajectory.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace orpe::synth {
namespace {

/// A smooth random signal in [-1, 1]: a sum of sinusoids with random phases (frequencies in Hz).
/// `harmonics` > 0 instead draws integer frequencies 1..harmonics: periodic with period 1.
struct SmoothNoise {
  std::vector<double> freq, phase, amp;
  SmoothNoise(std::mt19937_64& rng, double f_lo, double f_hi, int terms, int harmonics = 0) {
    std::uniform_real_distribution<double> U(0, 1);
    double total = 0;
    for (int i = 0; i < terms; ++i) {
      freq.push_back(harmonics > 0
                         ? 1 + std::min(harmonics - 1, static_cast<int>(U(rng) * harmonics))
                         : f_lo + (f_hi - f_lo) * U(rng));
      phase.push_back(2 * M_PI * U(rng));
      amp.push_back(0.5 + U(rng));
      total += amp.back();
    }
    for (auto& a : amp) a /= total;
  }
  double operator()(double t) const {
    double s = 0;
    for (size_t i = 0; i < freq.size(); ++i)
      s += amp[i] * std::sin(2 * M_PI * freq[i] * t + phase[i]);
    return s;
  }
};

/// A smooth random function of an angle, periodic in 2 pi, in [-1, 1]: harmonics 1..max_harmonic.
struct PeriodicNoise {
  SmoothNoise noise;
  PeriodicNoise(std::mt19937_64& rng, int max_harmonic, int terms)
      : noise(rng, 0, 0, terms, max_harmonic) {}
  double operator()(double theta) const { return noise(theta / (2 * M_PI)); }
};

/// The hand's roll and shake added to a camera pose at time t (camera-frame rotation, world
/// translation).
SE3 with_hand_shake(SE3 T, const SmoothNoise (&shake)[6], const SmoothNoise& roll, double t,
                    double shake_m, double shake_deg) {
  const double deg = M_PI / 180.0;
  const Vec3 dphi(shake_deg * deg * shake[3](t), shake_deg * deg * shake[4](t),
                  shake_deg * deg * shake[5](t) + 2.0 * deg * roll(t));
  T.rotation() = T.rotation() * so3_exp(dphi);
  T.translation() += shake_m * Vec3(shake[0](t), shake[1](t), shake[2](t));
  return T;
}

}  // namespace

std::vector<SE3> make_loop_trajectory(const LoopParams& p, const Vec3& centre,
                                      std::mt19937_64& rng) {
  if (p.frames < 2 || !(p.fps > 0) || !(p.radius_m > 0) || !(p.overlap_deg >= 0))
    throw std::invalid_argument("make_loop_trajectory: bad parameters");
  SmoothNoise speed(rng, 0.05, 0.25, 3), roll(rng, 0.1, 0.4, 2);
  PeriodicNoise radius(rng, 3, 3), height(rng, 3, 3), pitch(rng, 4, 3), yaw(rng, 4, 3);
  SmoothNoise shake[6] = {{rng, 1.5, 6, 3}, {rng, 1.5, 6, 3}, {rng, 1.5, 6, 3},
                          {rng, 1.5, 6, 3}, {rng, 1.5, 6, 3}, {rng, 1.5, 6, 3}};
  std::uniform_real_distribution<double> U(0, 1);
  const double az0 = 2 * M_PI * U(rng);
  const double total_az = 2 * M_PI + p.overlap_deg * M_PI / 180.0;
  std::vector<double> progress(p.frames, 0.0);
  for (int i = 1; i < p.frames; ++i)
    progress[i] = progress[i - 1] + std::max(0.2, 1.0 + 0.25 * speed(i / p.fps));
  const double deg = M_PI / 180.0;
  std::vector<SE3> out;
  out.reserve(p.frames);
  for (int i = 0; i < p.frames; ++i) {
    const double t = i / p.fps;
    const double th = az0 + total_az * progress[i] / progress.back();  // az0 + [0, total]
    const double r = p.radius_m * (1.0 + 0.1 * radius(th));
    const Vec3 radial(std::cos(th), std::sin(th), 0.0);
    Vec3 eye, look;
    if (p.outward) {
      eye = centre + r * radial;
      eye.z() = p.height_m + 0.1 * height(th);
      const double a = th + p.yaw_wander_deg * deg * yaw(th);
      const double el = (p.pitch_deg + 5.0 * pitch(th)) * deg;
      look = eye + Vec3(std::cos(el) * std::cos(a), std::cos(el) * std::sin(a), std::sin(el));
    } else {
      const double el = std::clamp(p.elevation_deg * deg + 0.12 * height(th), 0.02, 1.45);
      eye = centre + r * Vec3(std::cos(el) * radial.x(), std::cos(el) * radial.y(), std::sin(el));
      look = centre;
    }
    eye.z() = std::max(eye.z(), p.min_height_m);
    out.push_back(with_hand_shake(look_at(eye, look), shake, roll, t, p.shake_m, p.shake_deg));
  }
  return out;
}

std::vector<SE3> make_handheld_trajectory(const TrajectoryParams& p, const Vec3& target,
                                          std::mt19937_64& rng) {
  if (p.frames < 1 || !(p.fps > 0) || !(p.distance_m > 0))
    throw std::invalid_argument("make_handheld_trajectory: bad parameters");
  double span = p.span_deg * M_PI / 180.0;
  const double elev0 = p.elevation_deg * M_PI / 180.0;
  if (p.baseline_m > 0) {
    // Chord between the arc's ends at the mean horizontal radius.
    const double rh = p.distance_m * std::cos(elev0);
    span = 2.0 * std::asin(std::min(1.0, p.baseline_m / (2.0 * rh)));
  }
  const double duration = (p.frames - 1) / p.fps;
  // Slow variations (fractions of a Hz over the whole take) and hand shake (1.5-6 Hz).
  SmoothNoise speed(rng, 0.05, 0.25, 3), height(rng, 0.05, 0.3, 3), radius(rng, 0.05, 0.3, 3),
      roll(rng, 0.1, 0.4, 2);
  SmoothNoise wander_x(rng, 0.05, 0.3, 2), wander_y(rng, 0.05, 0.3, 2), wander_z(rng, 0.05, 0.3, 2);
  SmoothNoise shake[6] = {{rng, 1.5, 6, 3}, {rng, 1.5, 6, 3}, {rng, 1.5, 6, 3},
                          {rng, 1.5, 6, 3}, {rng, 1.5, 6, 3}, {rng, 1.5, 6, 3}};
  std::uniform_real_distribution<double> U(0, 1);
  const bool reverse = U(rng) < 0.5;
  // Progress along the arc: monotone, with speed varying +-35 % (integrated numerically).
  std::vector<double> progress(p.frames, 0.0);
  for (int i = 1; i < p.frames; ++i) {
    const double t = i / p.fps;
    progress[i] = progress[i - 1] + std::max(0.2, 1.0 + 0.35 * speed(t));
  }
  const double total = std::max(progress.back(), 1e-9);
  std::vector<SE3> out;
  out.reserve(p.frames);
  const double look_wander = 0.03 * p.distance_m;
  for (int i = 0; i < p.frames; ++i) {
    const double t = duration > 0 ? i / p.fps : 0.0;
    double s = p.frames > 1 ? progress[i] / total : 0.5;
    if (reverse) s = 1.0 - s;
    const double az = p.azimuth_centre_rad + (s - 0.5) * span;
    const double el = std::clamp(elev0 + 0.12 * height(t), 0.02, 1.45);
    const double r = p.distance_m * (1.0 + 0.1 * radius(t));
    Vec3 eye =
        target + r * Vec3(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
    eye.z() = std::max(eye.z(), p.min_height_m);
    const Vec3 look = target + look_wander * Vec3(wander_x(t), wander_y(t), 0.5 * wander_z(t));
    out.push_back(with_hand_shake(look_at(eye, look), shake, roll, t, p.shake_m, p.shake_deg));
  }
  return out;
}

double trajectory_extent_m(const std::vector<SE3>& T) {
  double best = 0;
  for (size_t i = 0; i < T.size(); ++i)
    for (size_t j = i + 1; j < T.size(); ++j)
      best = std::max(best, (T[i].translation() - T[j].translation()).norm());
  return best;
}

}  // namespace orpe::synth
