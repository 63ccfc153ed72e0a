#include "orpe/synth/scene.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <optional>
#include <stdexcept>

#include "orpe/render/primitives.h"
#include "orpe/synth/textures.h"

namespace orpe::synth {
namespace {

using Poly = std::vector<Eigen::Vector2d>;

double polygon_area(const Poly& p) {
  double a = 0;
  for (size_t i = 0; i < p.size(); ++i)
    a += p[i].x() * p[(i + 1) % p.size()].y() - p[(i + 1) % p.size()].x() * p[i].y();
  return 0.5 * std::abs(a);
}

/// Smallest signed distance of p to the edges of a CCW convex polygon (positive inside).
double inside_margin(const Poly& poly, const Eigen::Vector2d& p) {
  double m = 1e9;
  for (size_t i = 0; i < poly.size(); ++i) {
    const Eigen::Vector2d a = poly[i], e = poly[(i + 1) % poly.size()] - a;
    const double len = e.norm();
    if (len > 0) m = std::min(m, (e.x() * (p.y() - a.y()) - e.y() * (p.x() - a.x())) / len);
  }
  return m;
}

Poly rect(double x0, double y0, double x1, double y1) {
  return {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};
}

Mat3 rot_z(double a) {
  return Eigen::AngleAxisd(a, Vec3::UnitZ()).toRotationMatrix();
}

std::shared_ptr<TriangleMesh> textured(TriangleMesh m, std::shared_ptr<const ColorImage> tex) {
  m.texture = std::move(tex);
  return std::make_shared<TriangleMesh>(std::move(m));
}

std::shared_ptr<TriangleMesh> coloured(TriangleMesh m, Rgb8 c) {
  m.uvs.clear();
  m.base_color = c;
  return std::make_shared<TriangleMesh>(std::move(m));
}

/// A box of `size` whose faces map the texture at `px_per_m` (repeating) — for boards and slabs.
TriangleMesh slab(const Eigen::Vector3f& size, float px_per_m, int tex_w, int tex_h) {
  auto fw = [&](float a) { return a * px_per_m / tex_w; };
  auto fh = [&](float b) { return b * px_per_m / tex_h; };
  std::array<UvRect, 6> uv;
  const float d[6][2] = {{size.y(), size.z()}, {size.y(), size.z()}, {size.x(), size.z()},
                         {size.x(), size.z()}, {size.x(), size.y()}, {size.x(), size.y()}};
  for (int f = 0; f < 6; ++f) uv[f] = {0, 0, fw(d[f][0]), fh(d[f][1])};
  return make_box(size, 0.25f, &uv);
}

/// The floor, and four walls `wall_distance_m` from the origin facing it.
void add_floor_and_walls(SynthScene& s, std::uint64_t seed, double wall_distance_m = 7.0) {
  auto concrete = std::make_shared<ColorImage>(draw_concrete(512, seed));
  s.environment.push_back({textured(make_quad(16.0f, 16.0f, 8, 8, 8, 8), concrete), SE3()});
  auto wall_tex = std::make_shared<ColorImage>(draw_painted_wall(256, seed + 1, {214, 216, 210}));
  auto wall = textured(make_quad(16.0f, 5.0f, 8, 3, 4, 1), wall_tex);
  Mat3 R;  // quad x -> world x, quad y -> world z, quad normal -> world -y: a wall at +y facing the
           // centre
  R.col(0) = Vec3::UnitX(), R.col(1) = Vec3::UnitZ(), R.col(2) = -Vec3::UnitY();
  for (int k = 0; k < 4; ++k) {
    const Mat3 Rz = rot_z(k * M_PI / 2);
    s.environment.push_back({wall, SE3(Rz * R, Rz * Vec3(0, wall_distance_m, 2.5))});
  }
}

void add_table(SynthScene& s, std::uint64_t seed) {
  const float L = 1.6f, D = 0.9f, top_t = 0.04f, H = 0.75f, leg = 0.05f;
  auto wood = std::make_shared<ColorImage>(draw_wood(512, 512, seed + 2, {180, 140, 95}));
  s.environment.push_back({textured(slab({L, D, top_t}, 220, 512, 512), wood),
                           SE3(Mat3::Identity(), Vec3(0, 0, H - top_t / 2))});
  auto leg_mesh = coloured(make_box({leg, leg, H - top_t}, 0.25f), {70, 70, 75});
  for (int i = 0; i < 4; ++i) {
    const double x = (i % 2 ? 1 : -1) * (L / 2 - 0.08), y = (i / 2 ? 1 : -1) * (D / 2 - 0.08);
    s.environment.push_back({leg_mesh, SE3(Mat3::Identity(), Vec3(x, y, (H - top_t) / 2))});
  }
  s.supports.push_back({rect(-L / 2, -D / 2, L / 2, D / 2), H, 1e9, -1});
  s.default_elevation_deg = 40;
}

/// A rack of width W (four levels, a back panel at +y) placed by T_world_rack (a turn about z and a
/// shift); its boards become supports.
void add_shelf(SynthScene& s, std::uint64_t seed, const SE3& T_world_rack = SE3(),
               const float W = 2.0f) {
  const float D = 0.6f, board_t = 0.03f, beam_h = 0.08f, post = 0.07f, top_h = 1.95f;
  const float levels[4] = {0.12f, 0.58f, 1.04f, 1.50f};  // top surfaces of the boards
  auto chip = std::make_shared<ColorImage>(draw_wood(512, 512, seed + 3, {200, 175, 130}));
  auto board = textured(slab({W, D, board_t}, 250, 512, 512), chip);
  auto beam = coloured(make_box({W + post, 0.05f, beam_h}, 0.25f), {235, 110, 20});
  auto upright = coloured(make_box({post, post, top_h}, 0.25f), {30, 70, 150});
  for (int i = 0; i < 4; ++i) {
    const double x = (i % 2 ? 1 : -1) * (W / 2 + post / 2),
                 y = (i / 2 ? 1 : -1) * (D / 2 - post / 2);
    s.environment.push_back({upright, T_world_rack * SE3(Mat3::Identity(), Vec3(x, y, top_h / 2))});
  }
  for (int l = 0; l < 4; ++l) {
    const double z = levels[l];
    s.environment.push_back(
        {board, T_world_rack * SE3(Mat3::Identity(), Vec3(0, 0, z - board_t / 2))});
    for (int side = -1; side <= 1; side += 2)
      s.environment.push_back(
          {beam, T_world_rack * SE3(Mat3::Identity(),
                                    Vec3(0, side * (D / 2 - 0.025), z - board_t - beam_h / 2))});
    const double next_bottom = l + 1 < 4 ? levels[l + 1] - board_t - beam_h : top_h + 0.3;
    Poly board_xy = rect(-W / 2, -D / 2, W / 2, D / 2);
    for (auto& q : board_xy) q = (T_world_rack * Vec3(q.x(), q.y(), 0)).head<2>();
    s.supports.push_back({board_xy, z, next_bottom - z, -1});
  }
  // Back panel (mesh-like grey sheet) behind the shelf.
  auto back = coloured(make_box({W, 0.01f, top_h}, 0.25f), {150, 152, 155});
  s.environment.push_back(
      {back, T_world_rack * SE3(Mat3::Identity(), Vec3(0, D / 2 + 0.01, top_h / 2))});
  s.view_azimuth_rad = -M_PI / 2;  // cameras in front (-y side)
  s.default_elevation_deg = 15;
}

/// A 6 x 6 m room: walls 3 m from the centre, a 3 m rack against each wall facing the centre (its
/// front 2.05 m from it), for camera loops inside the room.
void add_room(SynthScene& s, std::uint64_t seed) {
  for (int k = 0; k < 4; ++k) {
    const Mat3 Rz = rot_z(k * M_PI / 2);
    add_shelf(s, seed + 10 * static_cast<std::uint64_t>(k), SE3(Rz, Rz * Vec3(0, 2.35, 0)), 3.0f);
  }
  s.default_elevation_deg = 0;
}

double max_footprint_area(const ObjectModel& m) {
  double a = 0;
  for (const auto& r : m.resting_poses) a = std::max(a, polygon_area(r.footprint));
  return a;
}

template <class T>
size_t pick_weighted(const std::vector<T>& weights, std::mt19937_64& rng) {
  const double total = std::accumulate(weights.begin(), weights.end(), 0.0);
  if (!(total > 0)) return 0;
  double r = std::uniform_real_distribution<double>(0, total)(rng);
  for (size_t i = 0; i < weights.size(); ++i) {
    r -= weights[i];
    if (r < 0) return i;
  }
  return weights.size() - 1;
}

/// The placement's random draws. One normal distribution for the whole scene: it caches every
/// second value, so sharing it keeps the sequence of draws (and the scenes) what they were.
struct PlacementSampler {
  std::mt19937_64& rng;
  std::uniform_real_distribution<double> U;
  std::normal_distribution<double> N;
};

/// A support for `model`: sometimes another object's top (not for pallets), else an environment
/// surface (by area).
size_t pick_support(const SynthScene& s, const ObjectModel& model, size_t env_supports,
                    const SceneLayoutParams& p, PlacementSampler& rs) {
  std::vector<double> w_env, w_top;
  std::vector<size_t> env_idx, top_idx;
  for (size_t k = 0; k < s.supports.size(); ++k) {
    const double a = polygon_area(s.supports[k].polygon);
    if (k < env_supports)
      env_idx.push_back(k), w_env.push_back(a);
    else if (!model.is_pallet)
      top_idx.push_back(k), w_top.push_back(a);
  }
  if (!top_idx.empty() && rs.U(rs.rng) < p.stack_probability)
    return top_idx[pick_weighted(w_top, rs.rng)];
  return env_idx[pick_weighted(w_env, rs.rng)];
}

/// Up to p.max_attempts random placements of `model` (a resting pose, a yaw, a spot on a support);
/// the first that stays inside its support, fits under the next level and keeps its prism clear
/// of every obstacle's prism. `owners`: the instances that supports with owner >= 0 refer to.
std::optional<ObjectInstance> find_place(const SynthScene& s, const ObjectModel& model, int type,
                                         size_t env_supports,
                                         const std::vector<const ObjectInstance*>& obstacles,
                                         const std::vector<ObjectInstance>& owners,
                                         const SceneLayoutParams& p, PlacementSampler& rs) {
  auto& U = rs.U;
  auto& rng = rs.rng;
  for (int attempt = 0; attempt < p.max_attempts; ++attempt) {
    const size_t sup = pick_support(s, model, env_supports, p, rs);
    const SupportSurface& support = s.supports[sup];
    std::vector<double> w_pose;
    for (const auto& r : model.resting_poses) w_pose.push_back(r.weight);
    const size_t pose_i = pick_weighted(w_pose, rng);
    const RestingPose& rp = model.resting_poses[pose_i];
    const double yaw =
        U(rng) < 0.5 ? std::floor(U(rng) * 4) * M_PI / 2 + 0.08 * rs.N(rng) : 2 * M_PI * U(rng);
    const Eigen::Matrix2d R2 = Eigen::Rotation2Dd(yaw).toRotationMatrix();
    Poly fp;
    for (const auto& q : rp.footprint) fp.push_back(R2 * q);
    if (support.owner >= 0) {
      // On another object: smaller than its top; on a pallet deck wide enough to span the board
      // gaps.
      if (polygon_area(fp) > 0.7 * polygon_area(support.polygon)) continue;
      if (s.types[owners[support.owner].type].is_pallet) {
        Eigen::Vector2d lo(1e9, 1e9), hi(-1e9, -1e9);
        for (const auto& q : rp.footprint) lo = lo.cwiseMin(q), hi = hi.cwiseMax(q);
        if ((hi - lo).minCoeff() < 0.15) continue;
      }
    }
    if (rp.height_m > support.clearance_m - 0.01) continue;
    Eigen::Vector2d lo(1e9, 1e9), hi(-1e9, -1e9);
    for (const auto& q : support.polygon) lo = lo.cwiseMin(q), hi = hi.cwiseMax(q);
    const Eigen::Vector2d xy(lo.x() + U(rng) * (hi.x() - lo.x()),
                             lo.y() + U(rng) * (hi.y() - lo.y()));
    Poly fpw;
    bool inside = true;
    for (const auto& q : fp) {
      fpw.push_back(q + xy);
      inside &= inside_margin(support.polygon, fpw.back()) >= p.edge_margin_m;
    }
    if (!inside) continue;
    const double bottom = support.height_m, top = bottom + rp.height_m;
    const bool collide = std::any_of(obstacles.begin(), obstacles.end(), [&](const auto* o) {
      return bottom < o->top_m - 1e-9 && o->bottom_m < top - 1e-9 &&
             polygons_overlap(fpw, o->footprint_world, p.min_gap_m);
    });
    if (collide) continue;
    ObjectInstance inst;
    inst.type = type;
    inst.resting_pose = static_cast<int>(pose_i);
    inst.support = static_cast<int>(sup);
    inst.footprint_world = fpw;
    inst.bottom_m = bottom;
    inst.top_m = top;
    inst.T_world_obj =
        SE3(rot_z(yaw) * rp.R_support_obj, Vec3(xy.x(), xy.y(), bottom + rp.z_offset_m));
    return inst;
  }
  return std::nullopt;
}

}  // namespace

bool polygons_overlap(const Poly& a, const Poly& b, double gap) {
  for (const Poly* p : {&a, &b}) {
    for (size_t i = 0; i < p->size(); ++i) {
      const Eigen::Vector2d e = (*p)[(i + 1) % p->size()] - (*p)[i];
      if (e.norm() <= 0) continue;
      const Eigen::Vector2d n(-e.y() / e.norm(), e.x() / e.norm());
      double a0 = 1e30, a1 = -1e30, b0 = 1e30, b1 = -1e30;
      for (const auto& q : a) a0 = std::min(a0, n.dot(q)), a1 = std::max(a1, n.dot(q));
      for (const auto& q : b) b0 = std::min(b0, n.dot(q)), b1 = std::max(b1, n.dot(q));
      if (a1 + gap <= b0 || b1 + gap <= a0) return false;
    }
  }
  return true;
}

SynthScene build_scene(std::vector<ObjectModel> types, const std::vector<int>& instance_types,
                       const SceneLayoutParams& p, std::mt19937_64& rng) {
  SynthScene s;
  s.kind = p.kind;
  s.types = std::move(types);
  for (int t : instance_types)
    if (t < 0 || t >= static_cast<int>(s.types.size()))
      throw std::invalid_argument("build_scene: bad type index");
  const std::uint64_t env_seed = rng();
  add_floor_and_walls(s, env_seed, p.kind == "room" ? 3.0 : 7.0);
  double total_area = 0, max_len = 0;
  for (int t : instance_types) {
    total_area += max_footprint_area(s.types[t]);
    for (const auto& r : s.types[t].resting_poses)
      for (const auto& q : r.footprint) max_len = std::max(max_len, q.norm());
  }
  if (p.kind == "floor") {
    const double half =
        std::max({0.5, 0.5 * std::sqrt(total_area / std::max(0.05, p.floor_fill)), max_len + 0.05});
    s.supports.push_back({rect(-half, -half, half, half), 0.0, 1e9, -1});
    s.default_elevation_deg = 38;
  } else if (p.kind == "table") {
    add_table(s, env_seed);
  } else if (p.kind == "shelf") {
    add_shelf(s, env_seed);
  } else if (p.kind == "room") {
    add_room(s, env_seed);
  } else {
    throw std::invalid_argument("scene kind must be floor, table, shelf or room (got '" + p.kind +
                                "')");
  }
  const size_t env_supports = s.supports.size();

  // Placement order: pallets first, then larger footprints (stable: ties keep the given order).
  std::vector<size_t> order(instance_types.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    const auto& ta = s.types[instance_types[a]];
    const auto& tb = s.types[instance_types[b]];
    if (ta.is_pallet != tb.is_pallet) return ta.is_pallet;
    return max_footprint_area(ta) > max_footprint_area(tb) + 1e-9;
  });

  PlacementSampler rs{rng, {}, {}};
  std::vector<ObjectInstance> placed_by_slot(instance_types.size());
  std::vector<bool> placed(instance_types.size(), false);
  std::vector<const ObjectInstance*> obstacles;  // in placement order
  for (size_t slot : order) {
    const int type = instance_types[slot];
    const ObjectModel& model = s.types[type];
    if (model.is_pallet && p.kind != "floor") {
      s.warnings.push_back(model.name + ": pallets are placed on the floor scene only; dropped");
      continue;
    }
    const auto inst = find_place(s, model, type, env_supports, obstacles, placed_by_slot, p, rs);
    if (!inst) {
      s.warnings.push_back(model.name + ": no free place found after " +
                           std::to_string(p.max_attempts) + " attempts; dropped");
      continue;
    }
    placed_by_slot[slot] = *inst;
    placed[slot] = true;
    obstacles.push_back(&placed_by_slot[slot]);
    // Its top becomes a support for smaller objects.
    const RestingPose& rp = model.resting_poses[inst->resting_pose];
    const SupportSurface support = s.supports[inst->support];
    if (rp.flat_top && polygon_area(inst->footprint_world) > 0.02 &&
        support.clearance_m - rp.height_m > 0.08) {
      Poly top_poly = convex_hull_2d(inst->footprint_world);
      s.supports.push_back(
          {top_poly, inst->top_m, support.clearance_m - rp.height_m, static_cast<int>(slot)});
    }
  }
  // Instances in the caller's order (skipping dropped ones); support owners refer to slots, remap.
  std::vector<int> slot_to_instance(instance_types.size(), -1);
  for (size_t slot = 0; slot < instance_types.size(); ++slot)
    if (placed[slot]) {
      slot_to_instance[slot] = static_cast<int>(s.objects.size());
      s.objects.push_back(placed_by_slot[slot]);
    }
  for (auto& sup : s.supports)
    if (sup.owner >= 0) sup.owner = slot_to_instance[sup.owner];

  // Bounds of what the camera should look at.
  Eigen::AlignedBox3d box;
  for (const auto& o : s.objects)
    for (const auto& q : o.footprint_world) {
      box.extend(Vec3(q.x(), q.y(), o.bottom_m));
      box.extend(Vec3(q.x(), q.y(), o.top_m));
    }
  if (box.isEmpty()) box.extend(Vec3(-0.3, -0.3, 0)), box.extend(Vec3(0.3, 0.3, 0.3));
  s.centre_world = box.center();
  s.radius_m = 0;
  for (const auto& o : s.objects)
    for (const auto& q : o.footprint_world)
      for (double z : {o.bottom_m, o.top_m})
        s.radius_m = std::max(s.radius_m, (Vec3(q.x(), q.y(), z) - s.centre_world).norm());
  s.radius_m = std::max(s.radius_m, 0.15);
  return s;
}

void place_distractors(SynthScene& s, std::vector<ObjectModel> types, const SceneLayoutParams& p,
                       std::mt19937_64& rng) {
  s.distractor_types = std::move(types);
  s.distractors.clear();
  s.distractors.reserve(s.distractor_types.size());  // obstacles point into it
  size_t env_supports = 0;
  while (env_supports < s.supports.size() && s.supports[env_supports].owner < 0) ++env_supports;
  std::vector<const ObjectInstance*> obstacles;
  for (const auto& o : s.objects) obstacles.push_back(&o);
  PlacementSampler rs{rng, {}, {}};
  for (size_t d = 0; d < s.distractor_types.size(); ++d) {
    const ObjectModel& model = s.distractor_types[d];
    const auto inst =
        find_place(s, model, static_cast<int>(d), env_supports, obstacles, s.objects, p, rs);
    if (!inst) {
      s.warnings.push_back(model.name + ": no free place found after " +
                           std::to_string(p.max_attempts) + " attempts; dropped");
      continue;
    }
    s.distractors.push_back(*inst);
    obstacles.push_back(&s.distractors.back());
  }
  // Keep the types of the placed ones only (distractor_id = type + 1 stays contiguous).
  std::vector<ObjectModel> used;
  for (auto& d : s.distractors) {
    used.push_back(s.distractor_types[d.type]);
    d.type = static_cast<int>(used.size()) - 1;
  }
  s.distractor_types = std::move(used);
}

TriangleMesh scene_mesh_world(const SynthScene& s) {
  TriangleMesh out;
  out.name = "scene";
  auto add = [&out](const TriangleMesh& mesh, const SE3& T_world_mesh) {
    TriangleMesh m;
    m.vertices = mesh.vertices;
    m.triangles = mesh.triangles;
    m.transform(T_world_mesh);
    out.append(m);
  };
  for (const EnvironmentPart& p : s.environment) add(*p.mesh, p.T_world_part);
  for (const ObjectInstance& o : s.objects) add(*s.types[o.type].mesh, o.T_world_obj);
  for (const ObjectInstance& d : s.distractors)
    add(*s.distractor_types[d.type].mesh, d.T_world_obj);
  return out;
}

}  // namespace orpe::synth
