#include "orpe/recognition/resting_search.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace orpe {

namespace {

using Vec3f = Eigen::Vector3f;

const float kCos10 = std::cos(10.0f * static_cast<float>(M_PI) / 180.0f);
const float kSin10 = std::sin(10.0f * static_cast<float>(M_PI) / 180.0f);

/// The mean of the normals within 10 degrees of +-a, turned to a's side; a when there is none.
Vec3f cluster_mean(const std::vector<Vec3f>& normals, const Vec3f& a) {
  Vec3f sum = Vec3f::Zero();
  for (const Vec3f& n : normals) {
    const float d = n.dot(a);
    if (std::abs(d) > kCos10) sum += d > 0 ? n : Vec3f(-n);
  }
  return sum.norm() > 0 ? Vec3f(sum.normalized()) : a;
}

/// Of the candidate directions (projected off `off` when given), the one most normals run along.
Vec3f dominant_axis(const std::vector<Vec3f>& normals, const Vec3f* off) {
  const size_t step = std::max<size_t>(1, normals.size() / 300);
  Vec3f best = Vec3f::Zero();
  int best_count = -1;
  for (size_t i = 0; i < normals.size(); i += step) {
    Vec3f c = normals[i];
    if (off) {
      if (std::abs(c.dot(*off)) > kSin10) continue;
      c = (c - c.dot(*off) * *off).normalized();
    }
    int count = 0;
    for (const Vec3f& n : normals) count += std::abs(n.dot(c)) > kCos10;
    if (count > best_count) best_count = count, best = c;
  }
  return best;
}

float percentile(std::vector<float> v, double q) {
  if (v.empty()) return 0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * static_cast<double>(v.size())));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

}  // namespace

ModelFaceAxes model_face_axes(const ObjectModel& model) {
  ModelFaceAxes out;
  if (!model.has_normals() || model.points.empty()) return out;
  const std::vector<Vec3f>& normals = model.normals;
  Vec3f a1 = cluster_mean(normals, dominant_axis(normals, nullptr));
  Vec3f a2 = dominant_axis(normals, &a1);
  if (a2.isZero()) a2 = a1.unitOrthogonal();
  a2 = cluster_mean(normals, a2);
  a2 = (a2 - a2.dot(a1) * a1).normalized();
  const Vec3f a3 = a1.cross(a2);
  out.axes.col(0) = a1, out.axes.col(1) = a2, out.axes.col(2) = a3;
  int on_faces = 0;
  for (const Vec3f& n : normals)
    on_faces += (out.axes.transpose() * n).cwiseAbs().maxCoeff() > kCos10;
  out.face_fraction = static_cast<double>(on_faces) / static_cast<double>(normals.size());
  Vec3f lo = Vec3f::Constant(std::numeric_limits<float>::infinity()), hi = -lo;
  for (const Vec3f& p : model.points) {
    const Vec3f q = out.axes.transpose() * p;
    lo = lo.cwiseMin(q), hi = hi.cwiseMax(q);
  }
  out.extents = hi - lo;
  out.centre = out.axes * (0.5f * (lo + hi));
  return out;
}

std::vector<VerticalFace> vertical_faces(const SceneGrid& g, GridNormals& normals,
                                         const std::vector<int>& cells, const Plane& support,
                                         const RestingFaceParams& p) {
  const Vec3f up = support.normal;
  const Vec3f origin = -support.d * up;
  const Vec3f e1 = up.unitOrthogonal(), e2 = up.cross(e1);
  const float sin_tilt = std::sin(static_cast<float>(p.max_tilt_deg * M_PI / 180.0));
  constexpr int kBins = 36;
  std::vector<std::vector<int>> bins(kBins);
  std::vector<Vec3f> horizontal(g.points.size(), Vec3f::Zero());
  for (int c : cells) {
    Vec3f n = normals.at(c);
    if (n.isZero()) continue;
    if (n.dot(g.points[c]) > 0) n = -n;  // towards the camera
    if (std::abs(n.dot(up)) > sin_tilt) continue;
    const Vec3f h = (n - n.dot(up) * up).normalized();
    horizontal[c] = h;
    const double ang = std::atan2(h.dot(e2), h.dot(e1));
    bins[static_cast<size_t>(static_cast<int>((ang + M_PI) / (2 * M_PI) * kBins) % kBins)]
        .push_back(c);
  }
  std::vector<VerticalFace> faces;
  std::vector<char> used(kBins, 0);
  for (int round = 0; round < kBins; ++round) {
    int b = -1;
    for (int k = 0; k < kBins; ++k)
      if (!used[k] && (b < 0 || bins[k].size() > bins[b].size())) b = k;
    if (b < 0 || static_cast<int>(bins[b].size()) < p.min_cells / 3) break;
    std::vector<int> group;
    for (int k : {b - 1, b, b + 1}) {
      const int kk = (k + kBins) % kBins;
      if (used[kk]) continue;
      used[kk] = 1;
      group.insert(group.end(), bins[kk].begin(), bins[kk].end());
    }
    Vec3f mean = Vec3f::Zero();
    for (int c : group) mean += horizontal[c];
    VerticalFace f;
    f.normal = (mean - mean.dot(up) * up).normalized();
    f.along = up.cross(f.normal);
    // The face: the offset (1 cm bins) most of the group's points lie at, +-1.5 cm.
    std::vector<float> offsets;
    for (int c : group) offsets.push_back(f.normal.dot(g.points[c] - origin));
    std::vector<int> hist;
    const float o_min = *std::min_element(offsets.begin(), offsets.end());
    for (float o : offsets) {
      const size_t k = static_cast<size_t>((o - o_min) / 0.01f);
      if (k >= hist.size()) hist.resize(k + 1, 0);
      ++hist[k];
    }
    const float mode =
        o_min +
        0.01f *
            (static_cast<float>(std::max_element(hist.begin(), hist.end()) - hist.begin()) + 0.5f);
    std::vector<float> on, s, height;
    for (size_t i = 0; i < group.size(); ++i) {
      if (std::abs(offsets[i] - mode) > 0.015f) continue;
      const Vec3f& q = g.points[static_cast<size_t>(group[i])];
      on.push_back(offsets[i]);
      s.push_back(f.along.dot(q - origin));
      height.push_back(support.signed_distance(q));
    }
    f.cells = static_cast<int>(on.size());
    if (f.cells < p.min_cells) continue;
    f.offset = percentile(on, 0.5);
    f.s_min = percentile(s, 0.02), f.s_max = percentile(s, 0.98);
    f.bottom = percentile(height, 0.02), f.top = percentile(height, 0.98);
    if (f.bottom > p.max_bottom_m) continue;
    faces.push_back(f);
    if (static_cast<int>(faces.size()) >= p.max_faces) break;
  }
  return faces;
}

std::vector<SE3> resting_poses(const ModelFaceAxes& axes, const VerticalFace& face,
                               const Plane& support, const RestingFaceParams& p) {
  std::vector<SE3> out;
  const Vec3f up = support.normal;
  const Vec3f origin = -support.d * up;
  const float width = face.s_max - face.s_min;
  const float slack = static_cast<float>(p.width_slack_m);
  Eigen::Matrix3f cam;
  cam.col(0) = face.normal, cam.col(1) = up, cam.col(2) = face.normal.cross(up);
  for (int k = 0; k < 3; ++k) {  // the axis along the support normal
    const float height = axes.extents[k];
    if (std::abs(height - face.top) > p.height_tolerance_m) continue;
    for (int j = 0; j < 3; ++j) {  // the axis along the face normal
      if (j == k) continue;
      const float side = axes.extents[3 - j - k];
      if (width > side + slack) continue;
      std::vector<float> along;
      if (side - width < slack)
        along = {0.5f * (face.s_min + face.s_max)};
      else
        along = {face.s_min + 0.5f * side, face.s_max - 0.5f * side};
      // One sign of each axis: the other three are the same box turned by 180 degrees, which the
      // refinement and the verification do not tell apart (measured: identical fits).
      Eigen::Matrix3f obj;
      obj.col(0) = axes.axes.col(j), obj.col(1) = axes.axes.col(k);
      obj.col(2) = obj.col(0).cross(obj.col(1));
      const Eigen::Matrix3f R = cam * obj.transpose();
      for (float a : along) {
        const Vec3f centre = origin + a * face.along +
                             (face.offset - 0.5f * axes.extents[j]) * face.normal +
                             0.5f * height * up;
        out.emplace_back(R.cast<double>(), (centre - R * axes.centre).cast<double>());
      }
    }
  }
  return out;
}

}  // namespace orpe
