#include "orpe/recognition/resting_search.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "orpe/core/convex_hull.h"

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

/// The two directions (radians, modulo 90 degrees, 5-degree bins) along which a hull's edges are
/// longest in total: a rectangle's sides, whether or not a border or an occluder cuts it.
std::vector<float> outline_directions(const std::vector<Eigen::Vector2f>& hull) {
  constexpr int kBins = 18;
  std::array<float, kBins> length{};
  for (size_t i = 0; i < hull.size(); ++i) {
    const Eigen::Vector2f e = hull[(i + 1) % hull.size()] - hull[i];
    float a = std::atan2(e.y(), e.x());
    a = std::fmod(a + static_cast<float>(2 * M_PI), static_cast<float>(M_PI / 2));
    length[static_cast<size_t>(std::min(kBins - 1, static_cast<int>(a / (M_PI / 2) * kBins)))] +=
        e.norm();
  }
  std::vector<float> out;
  for (int round = 0; round < 2; ++round) {
    const auto b = std::max_element(length.begin(), length.end()) - length.begin();
    if (!(length[static_cast<size_t>(b)] > 0)) break;
    // The length-weighted mean direction of the bin's edges would be finer; the refinement that
    // follows absorbs the 2.5-degree quantisation.
    out.push_back(static_cast<float>((static_cast<double>(b) + 0.5) * (M_PI / 2) / kBins));
    for (int d = -1; d <= 1; ++d) length[static_cast<size_t>((b + d + kBins) % kBins)] = 0;
  }
  return out;
}

/// Centres of a side of length `side` over an observed extent [lo, hi]: the middle when the
/// extent spans the side (within `slack`), else flush with either end -- but not with an end cut by
/// the image border (`lo_cut`, `hi_cut`) while the other end is in view: the object goes on out of
/// sight there, and flush with it the rest of it would lie in view, where nothing is seen.
std::vector<float> placements(float lo, float hi, float side, float slack, bool lo_cut = false,
                              bool hi_cut = false) {
  if (side - (hi - lo) < slack) return {0.5f * (lo + hi)};
  std::vector<float> out;
  if (!lo_cut || hi_cut) out.push_back(lo + 0.5f * side);
  if (!hi_cut || lo_cut) out.push_back(hi - 0.5f * side);
  return out;
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

/// Whether grid cell c lies on the image border (two cells wide).
static bool on_image_border(const SceneGrid& g, int c) {
  const int gu = c % g.width, gv = c / g.width;
  return gu <= 1 || gv <= 1 || gu >= g.width - 2 || gv >= g.height - 2;
}

/// Whether a face's lowest cells (within 2 cm of its bottom) lie on the image border: the face
/// leaves the view there, so its foot may stand on the support out of sight.
static bool foot_out_of_view(const SceneGrid& g, const std::vector<int>& cells,
                             const std::vector<float>& height, float bottom) {
  int on_border = 0;
  for (size_t i = 0; i < cells.size(); ++i)
    on_border += height[i] <= bottom + 0.02f && on_image_border(g, cells[i]);
  return on_border >= 3;
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
    std::vector<int> face_cells;
    for (size_t i = 0; i < group.size(); ++i) {
      if (std::abs(offsets[i] - mode) > 0.015f) continue;
      const Vec3f& q = g.points[static_cast<size_t>(group[i])];
      on.push_back(offsets[i]);
      s.push_back(f.along.dot(q - origin));
      height.push_back(support.signed_distance(q));
      face_cells.push_back(group[i]);
    }
    f.cells = static_cast<int>(on.size());
    if (f.cells < p.min_cells) continue;
    f.offset = percentile(on, 0.5);
    f.s_min = percentile(s, 0.02), f.s_max = percentile(s, 0.98);
    f.bottom = percentile(height, 0.02), f.top = percentile(height, 0.98);
    for (size_t i = 0; i < face_cells.size(); ++i)
      if (on_image_border(g, face_cells[i])) {
        f.s_min_cut |= s[i] < f.s_min + 0.01f;
        f.s_max_cut |= s[i] > f.s_max - 0.01f;
      }
    if (f.bottom > p.max_bottom_m && !foot_out_of_view(g, face_cells, height, f.bottom)) continue;
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
      const std::vector<float> along =
          placements(face.s_min, face.s_max, side, slack, face.s_min_cut, face.s_max_cut);
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

std::vector<TopFace> top_faces(const SceneGrid& g, GridNormals& normals,
                               const std::vector<int>& cells, const Plane& support,
                               const RestingFaceParams& p) {
  const Vec3f up = support.normal;
  const Vec3f origin = -support.d * up;
  const float cos_tilt = std::cos(static_cast<float>(p.max_tilt_deg * M_PI / 180.0));
  constexpr float kMinHeight = 0.02f, kBin = 0.01f, kHalfWidth = 0.015f;
  std::vector<int> flat;
  std::vector<float> heights;
  for (int c : cells) {
    const Vec3f& n = normals.at(c);
    if (n.isZero() || std::abs(n.dot(up)) < cos_tilt) continue;
    const float h = support.signed_distance(g.points[static_cast<size_t>(c)]);
    if (h < kMinHeight) continue;
    flat.push_back(c);
    heights.push_back(h);
  }
  std::vector<TopFace> faces;
  std::vector<char> taken(flat.size(), 0);
  for (int round = 0; round < p.max_faces; ++round) {
    std::vector<int> hist;
    for (size_t i = 0; i < flat.size(); ++i) {
      if (taken[i]) continue;
      const size_t k = static_cast<size_t>(heights[i] / kBin);
      if (k >= hist.size()) hist.resize(k + 1, 0);
      ++hist[k];
    }
    if (hist.empty()) break;
    const auto peak = std::max_element(hist.begin(), hist.end()) - hist.begin();
    if (hist[static_cast<size_t>(peak)] < p.min_cells / 3) break;
    const float mode = kBin * (static_cast<float>(peak) + 0.5f);
    TopFace f;
    f.e1 = up.unitOrthogonal(), f.e2 = up.cross(f.e1);
    std::vector<float> on;
    std::vector<Eigen::Vector2f> pts;
    for (size_t i = 0; i < flat.size(); ++i) {
      if (taken[i] || std::abs(heights[i] - mode) > kHalfWidth) continue;
      taken[i] = 1;
      const Vec3f d = g.points[static_cast<size_t>(flat[i])] - origin;
      on.push_back(heights[i]);
      pts.emplace_back(d.dot(f.e1), d.dot(f.e2));
      if (on_image_border(g, flat[i])) f.border.push_back(pts.back());
    }
    f.cells = static_cast<int>(on.size());
    if (f.cells < p.min_cells) continue;
    f.height = percentile(on, 0.5);
    f.at_border = f.border.size() >= 3;
    f.hull = convex_hull(std::move(pts));
    faces.push_back(std::move(f));
  }
  return faces;
}

std::vector<SE3> resting_poses_on_top(const ModelFaceAxes& axes, const TopFace& face,
                                      const Plane& support, const RestingFaceParams& p) {
  std::vector<SE3> out;
  if (face.hull.size() < 3) return out;
  const Vec3f up = support.normal;
  const Vec3f origin = -support.d * up;
  const float slack = static_cast<float>(p.width_slack_m);
  for (float angle : outline_directions(face.hull)) {
    const Eigen::Vector2f d1(std::cos(angle), std::sin(angle)), d2(-d1.y(), d1.x());
    float a0 = std::numeric_limits<float>::infinity(), a1 = -a0, b0 = a0, b1 = -a0;
    for (const Eigen::Vector2f& q : face.hull) {
      a0 = std::min(a0, q.dot(d1)), a1 = std::max(a1, q.dot(d1));
      b0 = std::min(b0, q.dot(d2)), b1 = std::max(b1, q.dot(d2));
    }
    // Which ends of the face the image border cuts (a border cell within 1 cm of the end).
    bool a0_cut = false, a1_cut = false, b0_cut = false, b1_cut = false;
    constexpr float kEnd = 0.01f;
    for (const Eigen::Vector2f& q : face.border) {
      const float a = q.dot(d1), b = q.dot(d2);
      a0_cut |= (a < a0 + kEnd), a1_cut |= (a > a1 - kEnd);
      b0_cut |= (b < b0 + kEnd), b1_cut |= (b > b1 - kEnd);
    }
    const Vec3f D1 = d1.x() * face.e1 + d1.y() * face.e2;
    Eigen::Matrix3f cam;
    cam.col(0) = D1, cam.col(1) = up.cross(D1), cam.col(2) = up;
    for (int k = 0; k < 3; ++k) {  // the axis along the support normal
      const float height = axes.extents[k];
      if (std::abs(height - face.height) > p.height_tolerance_m) continue;
      for (int i = 0; i < 3; ++i) {  // the axis along d1
        if (i == k) continue;
        const int j = 3 - i - k;  // along d2
        const float side1 = axes.extents[i], side2 = axes.extents[j];
        if (a1 - a0 > side1 + slack || b1 - b0 > side2 + slack) continue;
        Eigen::Matrix3f obj;
        obj.col(0) = axes.axes.col(i), obj.col(1) = axes.axes.col(j);
        obj.col(2) = obj.col(0).cross(obj.col(1));
        const Eigen::Matrix3f R = cam * obj.transpose();
        for (float c1 : placements(a0, a1, side1, slack, a0_cut, a1_cut))
          for (float c2 : placements(b0, b1, side2, slack, b0_cut, b1_cut)) {
            const Vec3f centre = origin + c1 * D1 + c2 * cam.col(1) + 0.5f * height * up;
            out.emplace_back(R.cast<double>(), (centre - R * axes.centre).cast<double>());
          }
      }
    }
  }
  return out;
}

}  // namespace orpe
