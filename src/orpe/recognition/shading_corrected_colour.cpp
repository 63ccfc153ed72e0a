#include "orpe/recognition/shading_corrected_colour.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <vector>

namespace orpe {

namespace {

using Vec4d = Eigen::Matrix<double, 4, 1>;
using Mat4d = Eigen::Matrix<double, 4, 4>;

Vec4d basis(const Eigen::Vector3f& n) {
  return Vec4d(1.0, n.x(), n.y(), n.z());
}

}  // namespace

ColourAgreement shading_corrected_agreement(const ModelColour& colour, const SE3& T_cam_obj,
                                            const ColorImage& image, const DepthImage& depth,
                                            const PinholeIntrinsics& K,
                                            const ColourScoreParams& params,
                                            double* model_contrast) {
  ColourAgreement out;
  if (model_contrast) *model_contrast = 0;
  const std::vector<VisibleColourSample> samples = visible_colour_samples(
      colour, T_cam_obj, image, depth, MaskImage(), K, params.depth_tolerance_m);
  out.pixels = static_cast<int>(samples.size());
  if (out.pixels < params.min_pixels) return out;
  // Weighted normal equations of both fits at once (one design matrix).
  Mat4d M = Mat4d::Zero();
  Vec4d bx = Vec4d::Zero(), by = Vec4d::Zero();
  double sw = 0;
  for (const VisibleColourSample& s : samples) {
    const double w = colour.weight[s.index];
    const Vec4d b = basis(s.normal);
    M += w * b * b.transpose();
    bx += w * colour.grey[s.index] * b;
    by += w * s.image_grey * b;
    sw += w;
  }
  if (!(sw > 0)) return out;
  // A box shows at most three normals, a view straight at a face one: the system is singular
  // there, and a small ridge keeps the fit defined (it still removes each face's mean).
  M.diagonal().array() += 1e-9 * std::max(1.0, M.trace());
  const Eigen::LDLT<Mat4d> ldlt(M);
  const Vec4d cx = ldlt.solve(bx), cy = ldlt.solve(by);
  double sxx = 0, syy = 0, sxy = 0;
  for (const VisibleColourSample& s : samples) {
    const double w = colour.weight[s.index];
    const Vec4d b = basis(s.normal);
    const double rx = colour.grey[s.index] - cx.dot(b), ry = s.image_grey - cy.dot(b);
    sxx += w * rx * rx, syy += w * ry * ry, sxy += w * rx * ry;
  }
  if (model_contrast) *model_contrast = std::sqrt(sxx / sw);
  if (sxx / sw < 1e-6 || syy / sw < 1e-6) return out;
  out.ncc = std::clamp(sxy / std::sqrt(sxx * syy), -1.0, 1.0);
  out.valid = true;
  return out;
}

}  // namespace orpe
