#include "orpe/synth/objects.h"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numeric>
#include <stdexcept>

#include "orpe/core/convex_hull.h"
#include "orpe/core/error.h"
#include "orpe/render/mesh_io.h"
#include "orpe/render/primitives.h"
#include "orpe/synth/textures.h"

namespace orpe::synth {
namespace {

Mat3 rot(const Vec3& axis, double angle) {
  return Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
}

ObjectSymmetries box_symmetries(const Eigen::Vector3f& size) {
  ObjectSymmetries s;
  for (int k = 0; k < 3; ++k) s.discrete.emplace_back(rot(Vec3::Unit(k), M_PI), Vec3::Zero());
  // Square cross-sections add quarter turns.
  const double tol = 1e-4;
  for (int k = 0; k < 3; ++k) {
    const int i = (k + 1) % 3, j = (k + 2) % 3;
    if (std::abs(size[i] - size[j]) < tol) {
      const Vec3 axis = Vec3::Unit(k);
      s.discrete.emplace_back(rot(axis, M_PI / 2), Vec3::Zero());
      s.discrete.emplace_back(rot(axis, -M_PI / 2), Vec3::Zero());
    }
  }
  return s;
}

/// Pastes face images into one atlas (two rows of three cells with replicated 2-px borders) and
/// returns the uv rectangle of each face.
struct Atlas {
  std::shared_ptr<ColorImage> image;
  std::vector<UvRect> rects;
};

Atlas pack_atlas(const std::vector<ColorImage>& faces, int per_row) {
  const int pad = 2;
  std::vector<int> row_w, row_h;
  for (size_t i = 0; i < faces.size(); ++i) {
    const size_t r = i / per_row;
    if (row_w.size() <= r) row_w.push_back(0), row_h.push_back(0);
    row_w[r] += faces[i].width() + 2 * pad;
    row_h[r] = std::max(row_h[r], faces[i].height() + 2 * pad);
  }
  const int W = *std::max_element(row_w.begin(), row_w.end());
  int H = 0;
  for (int h : row_h) H += h;
  Atlas a;
  a.image = std::make_shared<ColorImage>(W, H, Rgb8{128, 128, 128});
  int y0 = 0;
  for (size_t r = 0, i = 0; r < row_w.size(); ++r) {
    int x0 = 0;
    for (int c = 0; c < per_row && i < faces.size(); ++c, ++i) {
      const ColorImage& f = faces[i];
      for (int y = -pad; y < f.height() + pad; ++y)
        for (int x = -pad; x < f.width() + pad; ++x)
          a.image->at(x0 + pad + x, y0 + pad + y) =
              f.at(std::clamp(x, 0, f.width() - 1), std::clamp(y, 0, f.height() - 1));
      const float u0 = static_cast<float>(x0 + pad) / W,
                  u1 = static_cast<float>(x0 + pad + f.width()) / W;
      const float v1 = 1.0f - static_cast<float>(y0 + pad) / H,
                  v0 = 1.0f - static_cast<float>(y0 + pad + f.height()) / H;
      a.rects.push_back({u0, v0, u1, v1});
      x0 += f.width() + 2 * pad;
    }
    y0 += row_h[r];
  }
  return a;
}

double px_per_m_for(double max_dim) {
  return std::clamp(300.0 / max_dim, 600.0, 2000.0);
}

/// A printed box: faces +x, -x (sides), +y (front), -y (back), +z, -z (flaps).
std::shared_ptr<TriangleMesh> make_printed_box(const Eigen::Vector3f& size, const PrintStyle& style,
                                               float cell_m) {
  const double ppm = px_per_m_for(size.maxCoeff());
  auto px = [&](float m) { return std::max(8, static_cast<int>(std::lround(m * ppm))); };
  // Face sizes (right x up) as in make_box: +-x: y x z, +-y: x x z, +-z: x x y.
  std::vector<ColorImage> faces;
  faces.push_back(draw_package_face(px(size.y()), px(size.z()), style, 2, 0));  // +x
  faces.push_back(draw_package_face(px(size.y()), px(size.z()), style, 2, 1));  // -x
  faces.push_back(draw_package_face(px(size.x()), px(size.z()), style, 0, 0));  // +y front
  faces.push_back(draw_package_face(px(size.x()), px(size.z()), style, 1, 0));  // -y back
  faces.push_back(draw_package_face(px(size.x()), px(size.y()), style, 3, 0));  // +z
  faces.push_back(draw_package_face(px(size.x()), px(size.y()), style, 3, 1));  // -z
  const Atlas atlas = pack_atlas(faces, 3);
  std::array<UvRect, 6> uv;
  std::copy(atlas.rects.begin(), atlas.rects.end(), uv.begin());
  auto mesh = std::make_shared<TriangleMesh>(make_box(size, cell_m, &uv));
  mesh->texture = atlas.image;
  return mesh;
}

std::shared_ptr<TriangleMesh> make_printed_can(float radius, float height,
                                               const PrintStyle& style) {
  const double ppm = px_per_m_for(std::max(2 * radius, height)) * 1.5;
  const int lw = std::max(32, static_cast<int>(2 * M_PI * radius * ppm)),
            lh = std::max(16, static_cast<int>(height * ppm));
  const int lid = std::max(16, static_cast<int>(2 * radius * ppm));
  std::vector<ColorImage> parts{draw_can_label(lw, lh, style), draw_can_lid(lid, style.seed + 1),
                                draw_can_lid(lid, style.seed + 2)};
  const Atlas atlas = pack_atlas(parts, 1);
  auto mesh = std::make_shared<TriangleMesh>(
      make_cylinder(radius, height, 48, 0.01f, atlas.rects[0], atlas.rects[1], atlas.rects[2]));
  mesh->texture = atlas.image;
  return mesh;
}

/// EUR-style block pallet (length along x, width along y), boards, blocks and stringers as boxes
/// mapped onto one wood texture.
std::shared_ptr<TriangleMesh> make_pallet_mesh(float length, float width, std::uint64_t seed) {
  const float height = 0.144f, board = 0.022f, block_h = 0.078f;
  const double ppm = 500.0;
  auto wood = std::make_shared<ColorImage>(draw_wood(1024, 512, seed));
  std::mt19937_64 rng(seed + 99);
  std::uniform_real_distribution<float> U(0.0f, 1.0f);
  auto mesh = std::make_shared<TriangleMesh>();
  // A box whose long axis is x; uv rects are random windows of the wood image with physical
  // proportions.
  auto add_part = [&](const Eigen::Vector3f& size, const Vec3& centre, bool along_y) {
    const Eigen::Vector3f s = size;  // long axis x; parts along y are turned afterwards
    std::array<UvRect, 6> uv;
    const float face_dims[6][2] = {{s.y(), s.z()}, {s.y(), s.z()}, {s.x(), s.z()},
                                   {s.x(), s.z()}, {s.x(), s.y()}, {s.x(), s.y()}};
    for (int f = 0; f < 6; ++f) {
      const float du = static_cast<float>(face_dims[f][0] * ppm / wood->width());
      const float dv = static_cast<float>(face_dims[f][1] * ppm / wood->height());
      const float u0 = U(rng) * std::max(0.0f, 1.0f - du), v0 = U(rng) * std::max(0.0f, 1.0f - dv);
      uv[f] = {u0, v0, u0 + std::min(du, 1.0f), v0 + std::min(dv, 1.0f)};
    }
    TriangleMesh part = make_box(s, 0.05f, &uv);
    part.texture = wood;
    SE3 T(along_y ? rot(Vec3::UnitZ(), M_PI / 2) : Mat3::Identity(), centre);
    part.transform(T);
    mesh->append(part);
  };
  const float z0 = -height / 2;
  // Bottom boards along x.
  const float ys3[3] = {-width / 2 + 0.0725f, 0.0f, width / 2 - 0.0725f};
  const float wb3[3] = {0.145f, 0.10f, 0.145f};
  for (int i = 0; i < 3; ++i)
    add_part({length, wb3[i], board}, Vec3(0, ys3[i], z0 + board / 2), false);
  // Blocks.
  const float xs3[3] = {-length / 2 + 0.0725f, 0.0f, length / 2 - 0.0725f};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      add_part({0.145f, j == 1 ? 0.10f : 0.145f, block_h},
               Vec3(xs3[i], ys3[j], z0 + board + block_h / 2), false);
  // Stringer boards along y (built along x, rotated).
  for (int i = 0; i < 3; ++i)
    add_part({width, 0.145f, board}, Vec3(xs3[i], 0, z0 + board + block_h + board / 2), true);
  // Top deck boards along x.
  std::vector<float> tw = width >= 0.75f ? std::vector<float>{0.145f, 0.10f, 0.145f, 0.10f, 0.145f}
                                         : std::vector<float>{0.145f, 0.10f, 0.10f, 0.145f};
  float sum = 0;
  for (float w : tw) sum += w;
  const float gap = (width - sum) / static_cast<float>(tw.size() - 1);
  float y = -width / 2;
  for (float w : tw) {
    add_part({length, w, board}, Vec3(0, y + w / 2, height / 2 - board / 2), false);
    y += w + gap;
  }
  mesh->name = "pallet";
  return mesh;
}

struct BuiltinSpec {
  const char* name;
  int kind;       // 0 retail box, 1 shipping carton, 2 can, 3 carton (tomato puree), 4 pallet
  float dims[3];  // box x y z; can: radius, height; pallet: length, width
};

const BuiltinSpec kBuiltins[] = {
    {"001_frasvaf_box", 0, {0.19f, 0.07f, 0.26f}},
    {"002_small_jacky_box", 1, {0.30f, 0.20f, 0.16f}},
    {"003_jacky_box", 1, {0.40f, 0.30f, 0.24f}},
    {"004_skansk_can", 2, {0.037f, 0.110f, 0}},
    {"005_sotstark_can", 2, {0.042f, 0.122f, 0}},
    {"006_onos_can", 2, {0.033f, 0.075f, 0}},
    {"007_risi_frutti_box", 0, {0.24f, 0.16f, 0.09f}},
    {"008_pauluns_box", 0, {0.16f, 0.06f, 0.23f}},
    {"009_tomatpure", 3, {0.065f, 0.042f, 0.115f}},
    {"010_pallet", 4, {1.2f, 0.8f, 0}},
    {"011_half_pallet", 4, {0.8f, 0.6f, 0}},
};

}  // namespace

const std::vector<std::string>& builtin_class_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const auto& b : kBuiltins) n.emplace_back(b.name);
    return n;
  }();
  return names;
}

ObjectModel make_builtin_object(const std::string& name, int variant) {
  const BuiltinSpec* spec = nullptr;
  for (const auto& b : kBuiltins)
    if (name == b.name) spec = &b;
  if (!spec) throw std::invalid_argument("unknown built-in object '" + name + "'");
  // Seed from the class index and variant: the same class looks the same in every scene.
  const std::uint64_t class_seed =
      1000003ull * static_cast<std::uint64_t>(spec - kBuiltins + 1) + 7919ull * variant;
  std::mt19937_64 rng(class_seed);
  std::uniform_real_distribution<float> U(0.9f, 1.1f);
  Eigen::Vector3f d(spec->dims[0], spec->dims[1], spec->dims[2]);
  if (variant > 0 && spec->kind != 4) d = d.cwiseProduct(Eigen::Vector3f(U(rng), U(rng), U(rng)));

  ObjectModel m;
  m.name = variant == 0 ? name : name + "_v" + std::to_string(variant + 1);
  m.source = "builtin";
  std::shared_ptr<TriangleMesh> mesh;
  std::array<double, 6> up_w{1, 1, 1, 1, 1, 1};
  bool flat_top = true;
  switch (spec->kind) {
    case 0: {
      PrintStyle s = random_print_style(rng, false);
      mesh = make_printed_box(d, s, 0.01f);
      m.symmetries = box_symmetries(d);
      up_w = {0.5, 0.5, 1.5, 1.5, 4, 0.5};  // mostly upright, often lying on the big faces
      break;
    }
    case 1: {
      PrintStyle s = random_print_style(rng, true);
      mesh = make_printed_box(d, s, 0.02f);
      m.symmetries = box_symmetries(d);
      up_w = {0.5, 0.5, 0.5, 0.5, 6, 1};
      break;
    }
    case 2: {
      PrintStyle s = random_print_style(rng, false);
      mesh = make_printed_can(d.x(), d.y(), s);
      m.symmetries.continuous.push_back({Vec3::UnitZ(), Vec3::Zero()});
      m.symmetries.discrete.emplace_back(rot(Vec3::UnitX(), M_PI), Vec3::Zero());
      up_w = {0, 0, 0, 0, 4, 1};
      break;
    }
    case 3: {
      PrintStyle s = random_print_style(rng, false);
      s.primary = {200, 30, 25};    // tomato red
      s.secondary = {60, 150, 50};  // leaf green
      s.background = {245, 240, 230};
      s.logo_shape = 0;
      mesh = make_printed_box(d, s, 0.01f);
      m.symmetries = box_symmetries(d);
      up_w = {0.3, 0.3, 1, 1, 5, 0.2};
      break;
    }
    default: {
      mesh = make_pallet_mesh(d.x(), d.y(), class_seed);
      m.symmetries.discrete.emplace_back(rot(Vec3::UnitZ(), M_PI), Vec3::Zero());
      up_w = {0, 0, 0, 0, 1, 0};
      m.is_pallet = true;
      break;
    }
  }
  mesh->name = m.name;
  std::string why;
  if (!mesh->IsValid(&why)) throw std::logic_error("built-in mesh " + m.name + " invalid: " + why);
  m.resting_poses = compute_resting_poses(*mesh, Mat3::Identity(), up_w);
  for (auto& r : m.resting_poses) r.flat_top = flat_top;
  if (spec->kind == 2)  // a can's lid is a flat top only when upright or upside down
    for (auto& r : m.resting_poses)
      r.flat_top = std::abs((r.R_support_obj * Vec3::UnitZ()).z()) > 0.99;
  m.mesh = mesh;
  return m;
}

namespace {

/// Sorted bounding-box sizes of a mesh (m).
Eigen::Vector3d sorted_sizes(const TriangleMesh& mesh) {
  const auto b = mesh.bounds();
  Eigen::Vector3d d = (b.max() - b.min()).cast<double>();
  std::sort(d.data(), d.data() + 3);
  return d;
}

Rgb8 hsv_to_rgb(double h_deg, double s, double v) {
  const double c = v * s, h = std::fmod(h_deg, 360.0) / 60.0;
  const double x = c * (1 - std::abs(std::fmod(h, 2.0) - 1)), m = v - c;
  const double rgb[6][3] = {{c, x, 0}, {x, c, 0}, {0, c, x}, {0, x, c}, {x, 0, c}, {c, 0, x}};
  const auto& t = rgb[std::min(5, static_cast<int>(h))];
  auto q = [&](double u) { return static_cast<std::uint8_t>(std::lround(255 * (u + m))); };
  return {q(t[0]), q(t[1]), q(t[2])};
}

}  // namespace

bool similar_size(const TriangleMesh& a, const TriangleMesh& b, double ratio) {
  const Eigen::Vector3d da = sorted_sizes(a), db = sorted_sizes(b);
  for (int k = 0; k < 3; ++k)
    if (std::max(da[k], db[k]) > ratio * std::min(da[k], db[k])) return false;
  return true;
}

ObjectModel make_distractor_object(const std::vector<ObjectModel>& targets, int index,
                                   std::mt19937_64& rng) {
  std::uniform_real_distribution<double> U(0, 1);
  const bool is_box = U(rng) < 0.5;
  std::shared_ptr<TriangleMesh> mesh;
  Eigen::Vector3f size;
  for (int attempt = 0; attempt < 100; ++attempt) {
    if (is_box) {
      size = Eigen::Vector3f(0.05 + 0.27 * U(rng), 0.05 + 0.27 * U(rng), 0.05 + 0.27 * U(rng));
      mesh = std::make_shared<TriangleMesh>(make_box(size, 0.02f));
    } else {
      const float r = static_cast<float>(0.025 + 0.065 * U(rng));
      size = Eigen::Vector3f(r, r, static_cast<float>(0.05 + 0.25 * U(rng)));
      mesh = std::make_shared<TriangleMesh>(make_cylinder(r, size.z(), 40, 0.02f));
    }
    const bool like_a_target = std::any_of(targets.begin(), targets.end(), [&](const auto& t) {
      return similar_size(*mesh, *t.mesh, kDistractorSizeRatio);
    });
    if (!like_a_target) break;
  }
  // Flat paint, saturated: unlike the targets' printed textures.
  mesh->uvs.clear();
  mesh->texture.reset();
  mesh->base_color = hsv_to_rgb(360 * U(rng), 0.55 + 0.4 * U(rng), 0.45 + 0.45 * U(rng));
  ObjectModel m;
  m.name = fmt::format("distractor_{}_{:02d}", is_box ? "box" : "cylinder", index + 1);
  m.source = "distractor";
  mesh->name = m.name;
  if (is_box) {
    m.symmetries = box_symmetries(size);
  } else {
    m.symmetries.continuous.push_back({Vec3::UnitZ(), Vec3::Zero()});
    m.symmetries.discrete.emplace_back(rot(Vec3::UnitX(), M_PI), Vec3::Zero());
  }
  const std::array<double, 6> up_w =
      is_box ? std::array<double, 6>{1, 1, 1, 1, 3, 1} : std::array<double, 6>{0, 0, 0, 0, 1, 1};
  m.resting_poses = compute_resting_poses(*mesh, Mat3::Identity(), up_w);
  for (auto& r : m.resting_poses) r.flat_top = true;
  m.mesh = mesh;
  return m;
}

ObjectModel load_object_model(const std::string& path, double metres_per_unit) {
  MeshLoadOptions opt;
  opt.metres_per_unit = 1.0;
  TriangleMesh mesh = load_mesh(path, opt);
  double scale = metres_per_unit;
  if (scale <= 0) {
    const auto b = mesh.bounds();
    scale = (b.max() - b.min()).maxCoeff() > 5.0 ? 0.001 : 1.0;
  }
  if (scale != 1.0) {
    for (auto& v : mesh.vertices) v *= static_cast<float>(scale);
  }
  const auto b = mesh.bounds();
  const double extent = (b.max() - b.min()).maxCoeff();
  if (!(extent > 0.005) || extent > 5.0)
    throw IoError(path,
                  "model size " + std::to_string(extent) +
                      " m is implausible for an object (check the unit scale, --model-unit-m)");
  ObjectModel m;
  m.name = std::filesystem::path(path).stem().string();
  if (m.name == "textured_simple" || m.name == "textured" ||
      m.name == "model")  // YCB layout: <class>/textured_simple.obj
    m.name = std::filesystem::path(path).parent_path().filename().string();
  m.source = path;
  mesh.name = m.name;
  // Principal axes of the surface (area-weighted samples) for the bounding-box faces.
  const auto pts = sample_surface_points(mesh, 4000, 12345);
  Vec3 mean = Vec3::Zero();
  for (const auto& p : pts) mean += p;
  mean /= static_cast<double>(std::max<size_t>(1, pts.size()));
  Mat3 cov = Mat3::Zero();
  for (const auto& p : pts) cov += (p - mean) * (p - mean).transpose();
  Eigen::SelfAdjointEigenSolver<Mat3> es(cov);
  Mat3 axes = es.eigenvectors();
  if (axes.determinant() < 0) axes.col(0) = -axes.col(0);
  // Candidate faces to rest on: dominant face-normal directions and the principal axes. Scanned
  // meshes have slightly bulging faces: points within 1 % of the size count as contact.
  std::vector<Vec3> ups;
  for (const Vec3& down : candidate_down_directions(mesh, axes)) ups.push_back(-down);
  m.resting_poses = compute_resting_poses_for(mesh, ups, std::vector<double>(ups.size(), 1.0),
                                              std::max(0.002, 0.01 * extent));
  m.mesh = std::make_shared<TriangleMesh>(std::move(mesh));
  return m;
}

std::vector<Eigen::Vector2d> convex_hull_2d(std::vector<Eigen::Vector2d> p) {
  return convex_hull(std::move(p));
}

Vec3 mesh_centroid(const TriangleMesh& mesh) {
  double vol = 0;
  Vec3 acc = Vec3::Zero();
  double area = 0;
  Vec3 acc_a = Vec3::Zero();
  for (const auto& t : mesh.triangles) {
    const Vec3 a = mesh.vertices[t[0]].cast<double>(), b = mesh.vertices[t[1]].cast<double>(),
               c = mesh.vertices[t[2]].cast<double>();
    const double v = a.dot(b.cross(c)) / 6.0;
    vol += v;
    acc += v * (a + b + c) / 4.0;
    const double ar = 0.5 * (b - a).cross(c - a).norm();
    area += ar;
    acc_a += ar * (a + b + c) / 3.0;
  }
  const auto bx = mesh.bounds();
  const double bbox_vol = static_cast<double>((bx.max() - bx.min()).prod());
  if (std::abs(vol) > 1e-3 * bbox_vol && std::abs(vol) > 0) return acc / vol;
  return area > 0 ? Vec3(acc_a / area) : Vec3::Zero();
}

namespace {
double polygon_area(const std::vector<Eigen::Vector2d>& poly) {
  double a = 0;
  for (size_t i = 0; i < poly.size(); ++i) {
    const auto& p = poly[i];
    const auto& q = poly[(i + 1) % poly.size()];
    a += p.x() * q.y() - q.x() * p.y();
  }
  return 0.5 * a;
}
/// Signed distance of p inside a CCW convex polygon (positive inside).
double inside_margin(const std::vector<Eigen::Vector2d>& poly, const Eigen::Vector2d& p) {
  double m = 1e9;
  for (size_t i = 0; i < poly.size(); ++i) {
    const Eigen::Vector2d a = poly[i], b = poly[(i + 1) % poly.size()];
    const Eigen::Vector2d e = b - a;
    const double len = e.norm();
    if (len <= 0) continue;
    m = std::min(m, (e.x() * (p.y() - a.y()) - e.y() * (p.x() - a.x())) / len);
  }
  return m;
}
}  // namespace

std::vector<RestingPose> compute_resting_poses_for(const TriangleMesh& mesh,
                                                   const std::vector<Vec3>& ups,
                                                   const std::vector<double>& up_weights,
                                                   double contact_tol_m) {
  const Vec3 com = mesh_centroid(mesh);
  std::vector<RestingPose> stable, all;
  for (size_t k = 0; k < ups.size(); ++k) {
    if (up_weights[k] <= 0) continue;
    const Vec3 up = ups[k].normalized();
    const Vec3 b1 = up.unitOrthogonal();
    const Vec3 b2 = up.cross(b1);
    Mat3 R;
    R.row(0) = b1.transpose();
    R.row(1) = b2.transpose();
    R.row(2) = up.transpose();
    double zmin = 1e30, zmax = -1e30;
    std::vector<Vec3> rv(mesh.vertices.size());
    for (size_t i = 0; i < rv.size(); ++i) {
      rv[i] = R * mesh.vertices[i].cast<double>();
      zmin = std::min(zmin, rv[i].z()), zmax = std::max(zmax, rv[i].z());
    }
    std::vector<Eigen::Vector2d> contact, all_xy;
    all_xy.reserve(rv.size());
    for (const auto& p : rv) {
      all_xy.emplace_back(p.x(), p.y());
      if (p.z() < zmin + contact_tol_m) contact.emplace_back(p.x(), p.y());
    }
    const auto support = convex_hull_2d(contact);
    const double area = support.size() >= 3 ? polygon_area(support) : 0.0;
    const Vec3 c = R * com;
    const bool is_stable = area > 1e-6 && inside_margin(support, c.head<2>()) > 0;
    RestingPose rp;
    rp.R_support_obj = R;
    rp.z_offset_m = -zmin;
    rp.height_m = zmax - zmin;
    rp.footprint = convex_hull_2d(all_xy);
    rp.weight = area * up_weights[k];
    all.push_back(rp);
    if (is_stable) stable.push_back(rp);
  }
  if (!stable.empty()) return stable;
  if (all.empty())
    throw std::invalid_argument("compute_resting_poses: every orientation has weight 0");
  // Nothing statically stable (e.g. a banana): keep the orientation with the largest support.
  auto best = std::max_element(all.begin(), all.end(),
                               [](const auto& a, const auto& b) { return a.weight < b.weight; });
  RestingPose r = *best;
  r.weight = 1;
  return {r};
}

std::vector<RestingPose> compute_resting_poses(const TriangleMesh& mesh, const Mat3& axes,
                                               const std::array<double, 6>& up_weights,
                                               double contact_tol_m) {
  std::vector<Vec3> ups;
  for (int k = 0; k < 6; ++k) ups.push_back((k % 2 == 0 ? 1.0 : -1.0) * axes.col(k / 2));
  return compute_resting_poses_for(
      mesh, ups, std::vector<double>(up_weights.begin(), up_weights.end()), contact_tol_m);
}

std::vector<Vec3> candidate_down_directions(const TriangleMesh& mesh, const Mat3& pca_axes) {
  // Area-weighted histogram of outward face normals on a Fibonacci sphere: flat faces (even of a
  // scanned, slightly crumpled box) show up as modes; each mode, refined by the mean normal around
  // it, is a candidate "down" direction. The principal axes are added as fallback candidates.
  const Vec3 com = mesh_centroid(mesh);
  const int bins = 400;
  std::vector<Vec3> dirs(bins);
  for (int k = 0; k < bins; ++k) {
    const double z = 1.0 - (2.0 * k + 1.0) / bins, r = std::sqrt(std::max(0.0, 1 - z * z)),
                 phi = k * 2.399963229728653;
    dirs[k] = Vec3(r * std::cos(phi), r * std::sin(phi), z);
  }
  std::vector<Vec3> normals;
  std::vector<double> areas;
  std::vector<double> hist(bins, 0.0);
  double total = 0;
  for (const auto& t : mesh.triangles) {
    const Vec3 a = mesh.vertices[t[0]].cast<double>(), b = mesh.vertices[t[1]].cast<double>(),
               c = mesh.vertices[t[2]].cast<double>();
    Vec3 n = (b - a).cross(c - a);
    const double area = 0.5 * n.norm();
    if (area <= 0) continue;
    n.normalize();
    if (n.dot((a + b + c) / 3.0 - com) < 0) n = -n;  // outward, whatever the winding
    int best = 0;
    double bd = -2;
    for (int k = 0; k < bins; ++k)
      if (dirs[k].dot(n) > bd) bd = dirs[k].dot(n), best = k;
    hist[best] += area;
    normals.push_back(n);
    areas.push_back(area);
    total += area;
  }
  std::vector<int> order(bins);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(),
            [&](int a, int b) { return hist[a] > hist[b] || (hist[a] == hist[b] && a < b); });
  std::vector<Vec3> out;
  auto add = [&](const Vec3& d) {
    for (const auto& o : out)
      if (o.dot(d) > std::cos(10.0 * M_PI / 180.0)) return;
    out.push_back(d.normalized());
  };
  for (int k : order) {
    if (hist[k] < 0.02 * total || out.size() >= 10) break;
    Vec3 mean = Vec3::Zero();
    for (size_t i = 0; i < normals.size(); ++i)
      if (normals[i].dot(dirs[k]) > std::cos(12.0 * M_PI / 180.0)) mean += areas[i] * normals[i];
    if (mean.norm() > 0) add(mean.normalized());
  }
  for (int k = 0; k < 6; ++k) add((k % 2 == 0 ? 1.0 : -1.0) * pca_axes.col(k / 2));
  return out;
}

}  // namespace orpe::synth
