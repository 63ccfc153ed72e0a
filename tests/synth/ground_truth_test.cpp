// End-to-end checks of the generator's ground truth, read back from the BOP files it writes:
// poses, masks, depth and model points must agree with each other and with an independent ray
// caster.
#include <gtest/gtest.h>

#include <climits>
#include <filesystem>
#include <map>

#include "orpe/io/image_io.h"
#include "orpe/render/mesh_io.h"
#include "orpe/render/rasterizer.h"
#include "orpe/synth/bop_writer.h"
#include "orpe/synth/generator.h"
#include "support/test_data.h"
#include "synth_test_util.h"

namespace orpe::test {
namespace {

namespace fs = std::filesystem;

/// A BOP folder generated for the current test (ctest runs tests in parallel processes: one folder
/// each).
std::string generated(int seed, bool noise, const std::string& scene) {
  const std::string dir = scratch_dir(std::to_string(seed) + (noise ? "n" : "c") + scene);
  SynthParams p = small_synth(seed, 5, noise);
  p.scene = scene;
  synth::SyntheticSceneGenerator(p).write_bop(dir);
  return dir;
}

struct ModelData {
  TriangleMesh mesh;          // metres
  std::vector<Vec3> points;   // metres
  std::vector<Vec3> normals;  // of the triangle each point lies on
};

ModelData load_model(const std::string& dir, int obj_id) {
  char stem[32];
  std::snprintf(stem, sizeof(stem), "/models/obj_%06d", obj_id);
  ModelData m;
  m.mesh = load_ply(dir + stem + ".ply", {0.001, false});
  m.points = read_xyz(dir + stem + "_points.xyz");
  // The triangle each point lies on: inside its projection and closest to its plane.
  for (const auto& p : m.points) {
    double best = 1e9;
    Vec3 n = Vec3::UnitZ();
    for (const auto& t : m.mesh.triangles) {
      const Vec3 a = m.mesh.vertices[t[0]].cast<double>(), b = m.mesh.vertices[t[1]].cast<double>(),
                 c = m.mesh.vertices[t[2]].cast<double>();
      const Vec3 nn = (b - a).cross(c - a);
      if (nn.norm() < 1e-12) continue;
      const Vec3 un = nn.normalized();
      const double dist = std::abs(un.dot(p - a));
      if (dist >= best) continue;
      // Barycentric inside test of p projected onto the plane.
      const Vec3 q = p - un * un.dot(p - a);
      const double area = nn.norm();
      const double w0 = (b - q).cross(c - q).dot(un) / area,
                   w1 = (c - q).cross(a - q).dot(un) / area;
      if (w0 < -1e-4 || w1 < -1e-4 || 1 - w0 - w1 < -1e-4) continue;
      best = dist;
      n = un;
    }
    m.normals.push_back(n);
  }
  return m;
}

PinholeIntrinsics camera_of(const nlohmann::json& cam, int w, int h) {
  PinholeIntrinsics K;
  K.width = w;
  K.height = h;
  K.fx = cam["cam_K"][0].get<double>();
  K.cx = cam["cam_K"][2].get<double>();
  K.fy = cam["cam_K"][4].get<double>();
  K.cy = cam["cam_K"][5].get<double>();
  return K;
}

TEST(SynthGroundTruth, ModelPointsLandOnTheirOwnVisibleMask) {
  for (const std::string scene : {"floor", "table"}) {
    const std::string dir = generated(3, false, scene);
    const auto cams = read_json(synth::bop_scene_dir(dir) + "/scene_camera.json");
    const auto gts = read_json(synth::bop_scene_dir(dir) + "/scene_gt.json");
    ASSERT_DOUBLE_EQ(cams["0"]["depth_scale"].get<double>(), 0.1);
    std::map<int, ModelData> models;
    size_t visible = 0, on_mask = 0;
    for (auto it = gts.begin(); it != gts.end(); ++it) {
      const int im = std::stoi(it.key());
      char name[32];
      std::snprintf(name, sizeof(name), "%06d", im);
      const DepthImage depth = read_depth_image(
          synth::bop_scene_dir(dir) + "/depth/" + name + ".png", 10000.0);  // 1000 / depth_scale
      const PinholeIntrinsics K = camera_of(cams[it.key()], depth.width(), depth.height());
      for (size_t k = 0; k < it.value().size(); ++k) {
        const auto& e = it.value()[k];
        const int obj_id = e["obj_id"].get<int>();
        if (!models.count(obj_id)) models[obj_id] = load_model(dir, obj_id);
        const ModelData& m = models[obj_id];
        const SE3 T = bop_pose(e);
        char mname[48];
        std::snprintf(mname, sizeof(mname), "%06d_%06zu", im, k);
        const LabelImage mask =
            read_label_image(synth::bop_scene_dir(dir) + "/mask_visib/" + mname + ".png");
        for (size_t i = 0; i < m.points.size(); ++i) {
          const Vec3 p = T * m.points[i];
          if (p.z() <= 0.05) continue;
          const Eigen::Vector2d uv = K.project(p);
          const int u = static_cast<int>(std::lround(uv.x())),
                    v = static_cast<int>(std::lround(uv.y()));
          if (!depth.in_bounds(u, v) || depth.at(u, v) <= 0) continue;
          // Visible: facing the camera, and the surface seen at the pixel lies on the point's own
          // tangent plane (1 mm). (A bottom face resting on a support is coplanar with it, but
          // faces away.)
          const Vec3 q = K.backproject(u, v, depth.at(u, v));
          const Vec3 n = T.rotation() * m.normals[i];
          if (n.dot(p.normalized()) > -0.05) continue;
          if (std::abs(n.dot(q - p)) > 0.001 || std::abs(q.z() - p.z()) > 0.02) continue;
          ++visible;
          on_mask += mask.at(u, v) > 0;
          if (!mask.at(u, v) && std::getenv("ORPE_DEBUG_SYNTH")) {
            const LabelImage inst =
                read_label_image(synth::bop_scene_dir(dir) + "/instance/" + name + ".png");
            std::cerr << scene << " im " << im << " obj " << k << " px " << uv.transpose()
                      << " inst " << inst.at(u, v) << " dz " << q.z() - p.z() << " plane "
                      << n.dot(q - p) << "\n";
          }
        }
      }
    }
    EXPECT_GT(visible, 2000u) << scene;
    EXPECT_GE(static_cast<double>(on_mask), 0.99 * visible)
        << scene << ": " << on_mask << " of " << visible;
  }
}

TEST(SynthGroundTruth, DepthWithoutNoiseIsTheExactModelSurface) {
  const std::string dir = generated(3, false, "floor");
  const auto cams = read_json(synth::bop_scene_dir(dir) + "/scene_camera.json");
  const auto gts = read_json(synth::bop_scene_dir(dir) + "/scene_gt.json");
  std::map<int, TriangleMesh> meshes;
  int checked = 0, edge_pixels = 0;
  double worst = 0;
  for (const std::string key : {"0", "4"}) {
    const DepthImage depth =
        read_depth_image(synth::bop_scene_dir(dir) + "/depth/00000" + key + ".png", 10000.0);
    const PinholeIntrinsics K = camera_of(cams[key], depth.width(), depth.height());
    for (size_t k = 0; k < gts[key].size(); ++k) {
      const auto& e = gts[key][k];
      const int obj_id = e["obj_id"].get<int>();
      char stem[32];
      std::snprintf(stem, sizeof(stem), "/models/obj_%06d.ply", obj_id);
      if (!meshes.count(obj_id)) meshes[obj_id] = load_ply(dir + stem, {0.001, false});
      char mname[48];
      std::snprintf(mname, sizeof(mname), "%06d_%06zu", std::stoi(key), k);
      const LabelImage mask =
          read_label_image(synth::bop_scene_dir(dir) + "/mask_visib/" + mname + ".png");
      int n = 0;
      for (int v = 0; v < mask.height(); ++v)
        for (int u = 0; u < mask.width(); ++u) {
          if (!mask.at(u, v)) continue;
          ASSERT_GT(depth.at(u, v), 0) << "no depth on a visible pixel without noise";
          if ((n++) % 7 != 0) continue;  // a subset keeps the brute-force ray casting fast
          const SE3 T = bop_pose(e);
          const Vec3 ray((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);
          const double t = ray_cast(meshes[obj_id], T, ray);
          double err = t > 0 ? std::abs(depth.at(u, v) - t) : 1e9;
          if (err > 1e-4) {
            // The rasteriser snaps vertices to 1/256 pixel: at a silhouette edge the pixel centre
            // may sit a hair outside (or inside) the exact triangle. Accept the surface seen by
            // slightly widened triangles there, but count such pixels.
            const double tw = ray_cast(meshes[obj_id], T, ray, nullptr, 2e-3);
            if (tw > 0 && std::abs(depth.at(u, v) - tw) <= 1e-4) err = 0, ++edge_pixels;
          }
          worst = std::max(worst, err);
          ++checked;
        }
    }
  }
  EXPECT_GT(checked, 300);
  // Depth PNG quantisation (0.1 mm: +-0.05 mm) and the PLY's 7 significant digits.
  EXPECT_LT(worst, 1e-4);
  EXPECT_LT(edge_pixels, checked / 50) << "too many pixels match only at snapped edges";
}

TEST(SynthGroundTruth, NoisyDepthStaysWithinTheSensorModelBound) {
  SynthParams p = small_synth(5, 3, true);
  p.width = 320;
  p.height = 240;
  const synth::SyntheticSceneGenerator gen(p);
  size_t interior = 0, within = 0, valid = 0;
  double sum_sq_norm = 0;
  double sum_abs = 0;
  for (int i = 0; i < gen.num_frames(); ++i) {
    const synth::SynthFrame f = gen.render_frame(i);
    const PinholeIntrinsics& K = gen.intrinsics();
    for (int v = 1; v + 1 < f.depth.height(); ++v)
      for (int u = 1; u + 1 < f.depth.width(); ++u) {
        const int id = f.instances.at(u, v);
        if (id <= 0) continue;
        bool inner = true;
        const float z0 = f.depth_clean.at(u, v);
        for (int dv = -1; dv <= 1; ++dv)
          for (int du = -1; du <= 1; ++du)
            inner &= f.instances.at(u + du, v + dv) == id &&
                     std::abs(f.depth_clean.at(u + du, v + dv) - z0) < gen.sensor().edge_jump_m;
        if (!inner) continue;
        ++interior;
        const float z = f.depth.at(u, v);
        if (z <= 0) continue;
        ++valid;
        const Vec3 ray = Vec3((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0).normalized();
        const double theta =
            std::acos(std::min(1.0, std::abs(ray.dot(f.normals.at(u, v).cast<double>()))));
        const double err = z - z0;
        within += std::abs(err) <= synth::depth_error_bound_m(z0, theta, K.fx, gen.sensor());
        const double sigma = synth::axial_noise_sigma_m(z0, theta);
        sum_sq_norm += (err / sigma) * (err / sigma);
        sum_abs += std::abs(err);
      }
  }
  ASSERT_GT(valid, 3000u);
  EXPECT_GE(static_cast<double>(within), 0.99 * valid);
  // The noise is really there, at the model's scale (quantisation adds a little).
  EXPECT_GT(sum_abs / valid, 0.0005);
  const double rms = std::sqrt(sum_sq_norm / valid);
  EXPECT_GT(rms, 0.7);
  EXPECT_LT(rms, 1.6);
  // Most interior pixels keep their depth (missing data only at grazing angles, shadows, dropouts).
  EXPECT_GT(static_cast<double>(valid), 0.8 * interior);
}

TEST(SynthGroundTruth, GtInfoIsConsistentWithTheMasks) {
  const std::string dir = generated(3, true, "floor");
  const auto info = read_json(synth::bop_scene_dir(dir) + "/scene_gt_info.json");
  const auto gts = read_json(synth::bop_scene_dir(dir) + "/scene_gt.json");
  ASSERT_EQ(info.size(), gts.size());
  for (auto it = info.begin(); it != info.end(); ++it) {
    ASSERT_EQ(it.value().size(), gts[it.key()].size());
    const LabelImage inst =
        read_label_image(synth::bop_scene_dir(dir) + "/instance/00000" + it.key() + ".png");
    for (size_t k = 0; k < it.value().size(); ++k) {
      const auto& e = it.value()[k];
      char mname[48];
      std::snprintf(mname, sizeof(mname), "%06d_%06zu", std::stoi(it.key()), k);
      const LabelImage vis =
          read_label_image(synth::bop_scene_dir(dir) + "/mask_visib/" + mname + ".png");
      const LabelImage all =
          read_label_image(synth::bop_scene_dir(dir) + "/mask/" + mname + ".png");
      int n_vis = 0, n_all = 0, vis_outside_all = 0, inst_agree = 0;
      for (size_t i = 0; i < vis.size(); ++i) {
        n_vis += vis[i] > 0;
        n_all += all[i] > 0;
        vis_outside_all += vis[i] > 0 && all[i] == 0;
        inst_agree += (vis[i] > 0) == (inst[i] == static_cast<int>(k) + 1);
      }
      EXPECT_EQ(e["px_count_visib"].get<int>(), n_vis);
      // px_count_all also counts the silhouette outside the image (as bop_toolkit): then bbox_obj
      // reaches beyond the image.
      const int px_all = e["px_count_all"].get<int>();
      const auto& b = e["bbox_obj"];
      const bool inside = b[0].get<int>() >= 0 && b[1].get<int>() >= 0 &&
                          b[0].get<int>() + b[2].get<int>() <= vis.width() &&
                          b[1].get<int>() + b[3].get<int>() <= vis.height();
      if (inside)
        EXPECT_EQ(px_all, n_all);
      else
        EXPECT_GT(px_all, n_all);
      EXPECT_EQ(vis_outside_all, 0);
      EXPECT_EQ(inst_agree, static_cast<int>(vis.size()));
      EXPECT_LE(e["px_count_valid"].get<int>(), n_vis);
      const double fract = e["visib_fract"].get<double>();
      EXPECT_NEAR(fract, px_all > 0 ? static_cast<double>(n_vis) / px_all : 0.0, 1e-12);
    }
  }
  // The TUM trajectory and the BOP cameras describe the same poses.
  std::ifstream tum(synth::bop_scene_dir(dir) + "/groundtruth.txt");
  std::string line;
  std::getline(tum, line);
  ASSERT_EQ(line[0], '#');
  const auto cams = read_json(synth::bop_scene_dir(dir) + "/scene_camera.json");
  for (int i = 0; std::getline(tum, line); ++i) {
    std::istringstream ls(line);
    double ts, tx, ty, tz, qx, qy, qz, qw;
    ls >> ts >> tx >> ty >> tz >> qx >> qy >> qz >> qw;
    const SE3 T_world_cam(Eigen::Quaterniond(qw, qx, qy, qz), Vec3(tx, ty, tz));
    const auto& c = cams[std::to_string(i)];
    Mat3 R;
    for (int j = 0; j < 9; ++j) R(j / 3, j % 3) = c["cam_R_w2c"][j].get<double>();
    const Vec3 t(c["cam_t_w2c"][0].get<double>() / 1000, c["cam_t_w2c"][1].get<double>() / 1000,
                 c["cam_t_w2c"][2].get<double>() / 1000);
    const SE3 T_cam_world(R, t);
    EXPECT_LT(((T_cam_world * T_world_cam).log()).norm(), 1e-6);
    EXPECT_NEAR(ts, i / 30.0, 1e-6);
  }
}

TEST(SynthGroundTruth, VisibleFractionCountsThePartOutsideTheImage) {
  // A long lens: objects are often cut by the image border. bop_toolkit renders each object into
  // an image three times as large (the original in its middle) and divides by all of its pixels.
  SynthParams p = small_synth(4, 6, false);
  p.fx = 4 * 145;
  const synth::SyntheticSceneGenerator g(p);
  PinholeIntrinsics big = g.intrinsics();
  const int W = big.width, H = big.height;
  big.width = 3 * W, big.height = 3 * H, big.cx += W, big.cy += H;
  Rasterizer rast;
  int cut = 0;
  for (int i = 0; i < g.num_frames(); ++i) {
    const synth::SynthFrame f = g.render_frame(i);
    for (size_t k = 0; k < f.info.size(); ++k) {
      const RenderItem item{g.scene().types[g.scene().objects[k].type].mesh.get(), f.T_cam_obj[k],
                            1};
      const RenderBuffers b = rast.render(big, std::span<const RenderItem>(&item, 1), kRenderDepth);
      int all = 0, x0 = INT_MAX, x1 = INT_MIN;
      for (int v = 0; v < b.depth.height(); ++v)
        for (int u = 0; u < b.depth.width(); ++u)
          if (b.depth.at(u, v) > 0) ++all, x0 = std::min(x0, u - W), x1 = std::max(x1, u - W);
      const auto& inf = f.info[k];
      int in_image = 0;
      for (const auto m : f.masks[k]) in_image += m > 0;
      EXPECT_EQ(inf.px_count_all, std::max(all, inf.px_count_visib)) << "frame " << i << " " << k;
      EXPECT_NEAR(inf.visib_fract, all > 0 ? double(inf.px_count_visib) / all : 0.0, 1e-12);
      if (all > 0) {
        EXPECT_EQ(inf.bbox_obj[0], x0);
        EXPECT_EQ(inf.bbox_obj[2], x1 - x0 + 1);
      }
      if (inf.px_count_visib > 0 && in_image < 0.8 * all) {
        ++cut;  // the old ratio (visible / in-image silhouette) would have been larger
        EXPECT_LT(inf.visib_fract, 0.81 * inf.px_count_visib / in_image);
      }
    }
  }
  EXPECT_GT(cut, 3) << "too few objects cut by the border to test anything";
}

}  // namespace
}  // namespace orpe::test
