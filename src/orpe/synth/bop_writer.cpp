#include "orpe/synth/bop_writer.h"

#include <fmt/format.h>

#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <ostream>
#include <stdexcept>

#include "orpe/core/atomic_file.h"
#include "orpe/io/image_io.h"
#include "orpe/render/mesh_io.h"

namespace orpe::synth {
namespace {

using ojson = nlohmann::ordered_json;

ojson row_major(const Mat3& R) {
  ojson a = ojson::array();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) a.push_back(R(r, c));
  return a;
}

ojson mm(const Vec3& t_m) {
  return ojson::array({t_m.x() * 1000.0, t_m.y() * 1000.0, t_m.z() * 1000.0});
}

void write_json(const std::string& path, const ojson& j) {
  write_file_atomic(path, [&](std::ostream& os) { os << j.dump(1) << "\n"; });
}

/// Model sizes come from float vertices: round to 1e-6 mm so that 1200 mm prints as 1200, not
/// 1200.0000476.
double tidy(double x) {
  const double r = std::round(x * 1e6) / 1e6;
  return r == 0.0 ? 0.0 : r;
}

ojson bbox(const int b[4]) {
  return ojson::array({b[0], b[1], b[2], b[3]});
}

/// One image's entries of scene_gt.json (`gt`) and scene_gt_info.json (`gt_info`).
void add_gt_entries(const std::vector<SE3>& T_cam_obj, const std::vector<int>& ids,
                    const char* id_key, const std::vector<ObjectFrameInfo>& info, ojson& gt,
                    ojson& gt_info) {
  gt = ojson::array();
  gt_info = ojson::array();
  for (size_t k = 0; k < T_cam_obj.size(); ++k) {
    gt.push_back({{"cam_R_m2c", row_major(T_cam_obj[k].rotation())},
                  {"cam_t_m2c", mm(T_cam_obj[k].translation())},
                  {id_key, ids[k]}});
    const ObjectFrameInfo& o = info[k];
    gt_info.push_back({{"bbox_obj", bbox(o.bbox_obj)},
                       {"bbox_visib", bbox(o.bbox_visib)},
                       {"px_count_all", o.px_count_all},
                       {"px_count_valid", o.px_count_valid},
                       {"px_count_visib", o.px_count_visib},
                       {"visib_fract", o.visib_fract}});
  }
}

}  // namespace

std::string bop_image_name(int im_id) {
  return fmt::format("{:06d}", im_id);
}
std::string bop_mask_name(int im_id, int gt_index) {
  return fmt::format("{:06d}_{:06d}", im_id, gt_index);
}

void write_bop_models(const std::string& dir, const std::vector<ObjectModel>& types, int points,
                      std::uint64_t seed, const std::vector<int>& obj_ids) {
  if (!obj_ids.empty() && obj_ids.size() != types.size())
    throw std::invalid_argument("write_bop_models: one obj_id per model");
  ojson info = ojson::object();
  for (size_t i = 0; i < types.size(); ++i) {
    const ObjectModel& m = types[i];
    const int obj_id = obj_ids.empty() ? static_cast<int>(i) + 1 : obj_ids[i];
    const std::string stem = fmt::format("obj_{:06d}", obj_id);
    PlyWriteOptions w;
    w.units_per_metre = 1000.0;
    if (m.mesh->has_texture()) {
      w.texture_file = stem + ".png";
      write_color_png(dir + "/" + w.texture_file, *m.mesh->texture);
    }
    write_ply(dir + "/" + stem + ".ply", *m.mesh, w);
    const auto pts = sample_surface_points(*m.mesh, static_cast<size_t>(points),
                                           seed + static_cast<std::uint64_t>(obj_id));
    write_file_atomic(dir + "/" + stem + "_points.xyz", [&](std::ostream& os) {
      for (const auto& p : pts) os << fmt::format("{:.6f} {:.6f} {:.6f}\n", p.x(), p.y(), p.z());
    });
    const auto b = m.mesh->bounds();
    ojson e = ojson::object();
    e["diameter"] = tidy(m.mesh->diameter() * 1000.0);
    e["min_x"] = tidy(b.min().x() * 1000.0);
    e["min_y"] = tidy(b.min().y() * 1000.0);
    e["min_z"] = tidy(b.min().z() * 1000.0);
    e["size_x"] = tidy((b.max().x() - b.min().x()) * 1000.0);
    e["size_y"] = tidy((b.max().y() - b.min().y()) * 1000.0);
    e["size_z"] = tidy((b.max().z() - b.min().z()) * 1000.0);
    if (!m.symmetries.discrete.empty()) {
      ojson d = ojson::array();
      for (const SE3& S : m.symmetries.discrete) {
        ojson a = ojson::array();
        const Mat4 M = S.matrix();
        for (int r = 0; r < 4; ++r)
          for (int c = 0; c < 4; ++c)
            a.push_back(tidy(c == 3 && r < 3 ? M(r, c) * 1000.0 : M(r, c)));
        d.push_back(a);
      }
      e["symmetries_discrete"] = d;
    }
    if (!m.symmetries.continuous.empty()) {
      ojson c = ojson::array();
      for (const auto& s : m.symmetries.continuous)
        c.push_back(
            {{"axis", ojson::array({tidy(s.axis.x()), tidy(s.axis.y()), tidy(s.axis.z())})},
             {"offset", ojson::array({tidy(s.offset_m.x() * 1000), tidy(s.offset_m.y() * 1000),
                                      tidy(s.offset_m.z() * 1000)})}});
      e["symmetries_continuous"] = c;
    }
    info[std::to_string(obj_id)] = e;
  }
  write_json(dir + "/models_info.json", info);
}

void write_bop_scene_json(const std::string& dir, const PinholeIntrinsics& K, double depth_scale,
                          const std::vector<BopFrameRecord>& frames) {
  ojson cam = ojson::object(), gt = ojson::object(), gt_info = ojson::object();
  ojson Kj = row_major(K.K());
  for (size_t i = 0; i < frames.size(); ++i) {
    const BopFrameRecord& f = frames[i];
    const std::string key = std::to_string(i);
    const SE3 T_cam_world = f.T_world_cam.inverse();
    cam[key] = {{"cam_K", Kj}, {"depth_scale", depth_scale}};
    if (f.has_camera_pose) {
      cam[key]["cam_R_w2c"] = row_major(T_cam_world.rotation());
      cam[key]["cam_t_w2c"] = mm(T_cam_world.translation());
    }
    add_gt_entries(f.T_cam_obj, f.obj_ids, "obj_id", f.info, gt[key], gt_info[key]);
  }
  write_json(dir + "/scene_camera.json", cam);
  write_json(dir + "/scene_gt.json", gt);
  write_json(dir + "/scene_gt_info.json", gt_info);
}

void write_distractor_json(const std::string& dir, const std::vector<BopFrameRecord>& frames) {
  ojson gt = ojson::object(), gt_info = ojson::object();
  for (size_t i = 0; i < frames.size(); ++i) {
    const BopFrameRecord& f = frames[i];
    std::vector<int> ids(f.T_cam_distractor.size());
    for (size_t j = 0; j < ids.size(); ++j) ids[j] = static_cast<int>(j) + 1;
    const std::string key = std::to_string(i);
    add_gt_entries(f.T_cam_distractor, ids, "distractor_id", f.distractor_info, gt[key],
                   gt_info[key]);
  }
  write_json(dir + "/scene_gt_distractors.json", gt);
  write_json(dir + "/scene_gt_info_distractors.json", gt_info);
}

std::string bop_scene_dir(const std::string& dataset_dir) {
  return fmt::format("{}/test/{:06d}", dataset_dir, kBopSceneId);
}

void write_bop_targets(const std::string& path, int scene_id,
                       const std::vector<BopFrameRecord>& frames, double min_visib) {
  ojson targets = ojson::array();
  for (size_t i = 0; i < frames.size(); ++i) {
    std::map<int, int> count;
    for (size_t k = 0; k < frames[i].obj_ids.size(); ++k)
      if (frames[i].info[k].visib_fract >= min_visib) ++count[frames[i].obj_ids[k]];
    for (const auto& [obj, n] : count)
      targets.push_back({{"im_id", static_cast<int>(i)},
                         {"inst_count", n},
                         {"obj_id", obj},
                         {"scene_id", scene_id}});
  }
  write_json(path, targets);
}

void write_tum_trajectory(const std::string& path, const std::vector<BopFrameRecord>& frames) {
  write_file_atomic(path, [&](std::ostream& os) {
    os << "# ground truth trajectory (orpe synth): timestamp tx ty tz qx qy qz qw, "
          "camera-to-world, metres\n";
    for (const auto& f : frames) {
      const Eigen::Quaterniond q = f.T_world_cam.quaternion();
      const Vec3& t = f.T_world_cam.translation();
      os << fmt::format("{:.6f} {:.9f} {:.9f} {:.9f} {:.9f} {:.9f} {:.9f} {:.9f}\n", f.timestamp_s,
                        t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w());
    }
  });
}

}  // namespace orpe::synth
