#include "orpe/synth/appearance_symmetry.h"

#include <cmath>
#include <limits>
#include <vector>

#include "orpe/core/weighted_correlation.h"

namespace orpe::synth {
namespace {

struct ColouredSamples {
  std::vector<Eigen::Vector3f> points;
  std::vector<Eigen::Vector3d> rgb;  ///< [0, 1] per channel
};

ColouredSamples coloured_samples(const TriangleMesh& mesh, int count, std::uint64_t seed) {
  std::vector<Rgb8> colours;
  const auto pts = sample_surface_points(mesh, static_cast<size_t>(count), seed, &colours);
  ColouredSamples s;
  for (size_t i = 0; i < pts.size(); ++i) {
    s.points.push_back(pts[i].cast<float>());
    s.rgb.push_back(Eigen::Vector3d(colours[i].r, colours[i].g, colours[i].b) / 255.0);
  }
  return s;
}

/// Correlation of a's colours with those of b's samples nearest to S * a.points: the covariance
/// summed over the three channels over the root of the product of the summed variances (a print
/// whose halves differ only in hue, at one grey level, is not symmetric either).
double transformed_correlation(const ColouredSamples& a, const ColouredSamples& b, const SE3& S) {
  const Eigen::Matrix3f R = S.rotation().cast<float>();
  const Eigen::Vector3f t = S.translation().cast<float>();
  const size_t n = a.points.size();
  std::vector<Eigen::Vector3d> y(n);
#pragma omp parallel for schedule(static)
  for (long i = 0; i < static_cast<long>(n); ++i) {
    const Eigen::Vector3f q = R * a.points[i] + t;
    float best = std::numeric_limits<float>::max();
    size_t arg = 0;
    for (size_t j = 0; j < b.points.size(); ++j) {
      const float d = (b.points[j] - q).squaredNorm();
      if (d < best) best = d, arg = j;
    }
    y[i] = b.rgb[arg];
  }
  WeightedCorrelation<Eigen::Vector3d> corr;
  for (size_t i = 0; i < n; ++i) corr.add(a.rgb[i], y[i]);
  double r = 1.0;  // flat colour: nothing tells S from the identity
  corr.correlation(&r, 1e-8, 1e-8);
  return r;
}

SE3 turn_about(const Vec3& axis, const Vec3& offset, double angle) {
  const Mat3 R = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
  return SE3(R, offset - R * offset);
}

}  // namespace

ObjectSymmetries appearance_symmetries(const ObjectModel& model,
                                       const AppearanceSymmetryParams& params) {
  const TriangleMesh& mesh = *model.mesh;
  if (!model.symmetries.any() || (!mesh.has_texture() && !mesh.has_colors()))
    return model.symmetries;
  const ColouredSamples a = coloured_samples(mesh, params.samples, 101);
  const ColouredSamples b = coloured_samples(mesh, params.samples, 202);
  const double baseline = transformed_correlation(a, b, SE3());
  if (baseline >= 1.0) return model.symmetries;  // one flat colour
  auto keeps = [&](const SE3& S) {
    return transformed_correlation(a, b, S) >= params.min_correlation * baseline;
  };
  ObjectSymmetries out;
  for (const SE3& S : model.symmetries.discrete)
    if (keeps(S)) out.discrete.push_back(S);
  for (const auto& c : model.symmetries.continuous) {
    bool all = true;
    for (int k = 1; k < params.continuous_steps && all; ++k)
      all = keeps(turn_about(c.axis, c.offset_m, 2 * M_PI * k / params.continuous_steps));
    if (all) out.continuous.push_back(c);
  }
  return out;
}

}  // namespace orpe::synth
