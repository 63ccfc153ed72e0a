// Replays the per-object fusion of `orpe run` offline from its single_view.csv (every single-view
// estimate with the tracked camera pose), so that EKF settings can be compared without re-running
// SLAM and the single-view estimator. Writes the causal per-frame rows and the final-pose rows as
// BOP CSVs, exactly as the pipeline would (same ObjectPoseFusion, same reporting rule).
//
//   build/bin/orpe_bench_ekf_replay --dataset DIR --single-view OUT/ablation/Object-RPE/single_view.csv
//       --out-rows rows.csv [--out-final final.csv] [--set pose_ekf.r_rotation_scale=10]
//       [--set pipeline.ekf_init_views=3] [--set dataset.scene=0002]
//       [--gt-measurements] [--gt-cameras]
// --verbose: one line per measurement (gate decision, errors; with pose_ekf.hypotheses > 1 the live
// hypotheses as evidence/views, the reported one starred).
// --gt-measurements replaces every single-view estimate by the frame's ground-truth T_cam_obj and
// --gt-cameras the tracked camera poses by the ground-truth ones: the error floors of the fusion.
// then: build/bin/orpe eval poses --dataset DIR --result rows.csv --keyframes OUT/evaluated_frames.txt
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "orpe/core/error.h"
#include "orpe/eval/pose_metrics.h"
#include "orpe/io/bop_results.h"
#include "orpe/io/model_io.h"
#include "orpe/io/dataset.h"
#include "orpe/pipeline/config.h"
#include "orpe/pipeline/object_fusion.h"
#include "orpe/pipeline/object_models.h"

namespace {

orpe::SE3 parse_pose(const std::string& rot, const std::string& trans, const std::string& where) {
  std::istringstream r(rot), t(trans);
  orpe::Mat3 R;
  orpe::Vec3 tv;
  for (int i = 0; i < 9; ++i)
    if (!(r >> R(i / 3, i % 3))) throw orpe::IoError(where, "bad rotation");
  for (int i = 0; i < 3; ++i)
    if (!(t >> tv[i])) throw orpe::IoError(where, "bad translation");
  return orpe::SE3(orpe::orthonormalize(R), tv);
}

struct Record {
  int frame = 0, instance = 0, cls = 0;
  double class_probability = 0, score = 0, mu = 0;
  bool valid = false;
  int mask_px = -1;  // -1: not recorded (older single_view.csv)
  orpe::SE3 T_cam_obj, T_world_cam;
};

std::vector<Record> read_records(const std::string& path) {
  std::ifstream is(path);
  if (!is) throw orpe::IoError(path, "cannot open");
  std::vector<Record> out;
  std::string line;
  std::getline(is, line);  // header
  int no = 1;
  while (std::getline(is, line)) {
    ++no;
    if (line.empty()) continue;
    std::vector<std::string> f;
    std::stringstream ss(line);
    std::string item;
    while (std::getline(ss, item, ',')) f.push_back(item);
    const std::string where = path + ":" + std::to_string(no);
    if (f.size() != 13 && f.size() != 14) throw orpe::IoError(where, "expected 13 or 14 fields");
    Record r;
    r.frame = std::stoi(f[0]);
    r.instance = std::stoi(f[1]);
    r.cls = std::stoi(f[2]);
    r.class_probability = std::stod(f[3]);
    r.valid = f[4] == "1";
    r.score = std::stod(f[5]);
    r.mu = std::stod(f[6]);
    r.T_cam_obj = parse_pose(f[9], f[10], where);
    r.T_world_cam = parse_pose(f[11], f[12], where);
    r.mask_px = f.size() > 13 ? std::stoi(f[13]) : -1;
    out.push_back(r);
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  std::string dataset, single_view, out_rows, out_final;
  bool gt_measurements = false, gt_cameras = false, verbose = false;
  orpe::OrpeConfig config;
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      auto next = [&]() -> std::string {
        if (i + 1 >= argc) throw orpe::ConfigError("missing value after " + a);
        return argv[++i];
      };
      if (a == "--dataset") dataset = next();
      else if (a == "--single-view") single_view = next();
      else if (a == "--out-rows") out_rows = next();
      else if (a == "--out-final") out_final = next();
      else if (a == "--set") orpe::apply_config_override(config, next());
      else if (a == "--gt-measurements") gt_measurements = true;
      else if (a == "--gt-cameras") gt_cameras = true;
      else if (a == "--verbose") verbose = true;
      else throw orpe::ConfigError("unknown argument " + a);
    }
    if (dataset.empty() || single_view.empty() || out_rows.empty())
      throw orpe::ConfigError("usage: --dataset DIR --single-view CSV --out-rows CSV [--out-final CSV] [--set k=v]");
    std::string why;
    if (!config.IsValid(&why)) throw orpe::ConfigError(why);
    const auto reader = orpe::open_dataset(dataset, config.dataset);
    const orpe::ObjectModelLibrary models(reader->info());
    auto records = read_records(single_view);
    if (gt_measurements || gt_cameras) {
      std::map<int, orpe::RgbdFrame> frames;  // by frame index
      for (size_t i = 0; i < reader->size(); ++i) {
        orpe::RgbdFrame f = reader->read(i);
        frames.emplace(f.index, std::move(f));
      }
      for (Record& r : records) {
        const auto f = frames.find(r.frame);
        if (f == frames.end()) throw orpe::IoError(dataset, "no frame " + std::to_string(r.frame));
        if (gt_cameras) {
          if (!f->second.T_world_cam_gt) throw orpe::IoError(dataset, "no ground-truth camera pose");
          r.T_world_cam = *f->second.T_world_cam_gt;
        }
        if (gt_measurements) {
          r.valid = false;
          for (const auto& g : f->second.objects_gt)
            if (g.class_id == r.cls) {
              r.T_cam_obj = g.T_cam_obj;
              r.valid = true;
              r.mu = std::max(r.mu, 1e-3);
            }
        }
      }
    }

    // --verbose: per-frame ground truth (objects, has-gt flag) and model points by class.
    std::map<int, std::pair<std::vector<orpe::ObjectGroundTruth>, bool>> gt_frames;
    std::map<int, std::unique_ptr<orpe::ModelPoints>> points_by_class;
    if (verbose)
      for (size_t i = 0; i < reader->size(); ++i) {
        const orpe::RgbdFrame f = reader->read_annotations(i);
        gt_frames[f.index] = {f.objects_gt, true};
      }
    auto model_points = [&](int cls) -> const orpe::ModelPoints& {
      auto& p = points_by_class[cls];
      if (!p)
        p = std::make_unique<orpe::ModelPoints>(orpe::read_model_points(
            reader->info().model_points_paths.at(cls), reader->info().model_units_per_m));
      return *p;
    };
    struct Track {
      int cls = 0;
      std::unique_ptr<orpe::ObjectPoseFusion> fusion;
    };
    std::map<int, Track> tracks;
    std::vector<orpe::PoseResultRow> rows;
    struct Seen {
      int frame, instance, cls;
      double score;
      orpe::SE3 T_world_cam;
    };
    std::vector<Seen> seen;
    const auto& pp = config.pipeline;
    const int min_pose_mask_px = pp.min_pose_mask_px_for(reader->info().intrinsics.width,
                                                         reader->info().intrinsics.height);
    for (const Record& r : records) {
      if (r.instance <= 0) continue;
      // As the pipeline: a mask below min_pose_mask_px has no estimate; its record exists only
      // when the run reported fused poses for such masks (ekf_report_min_mask_px), and the replay
      // keeps it only when its own ekf_report_min_mask_px admits it.
      if (r.mask_px >= 0 && r.mask_px < min_pose_mask_px &&
          (pp.ekf_report_min_mask_px <= 0 || r.mask_px < pp.ekf_report_min_mask_px))
        continue;
      Track& t = tracks[r.instance];
      if (t.cls != r.cls) {
        t.cls = r.cls;
        t.fusion = std::make_unique<orpe::ObjectPoseFusion>(
            config.pose_ekf, models.ekf_symmetry(r.cls, pp.ekf_symmetry), pp.ekf_init_views,
            pp.ekf_init_majority_stop);
      }
      const double sv_score = std::clamp(r.score, 0.01, 1.0);
      if (r.valid) {
        orpe::PoseMeasurement m;
        m.frame_index = r.frame;
        m.T_world_cam = r.T_world_cam;
        m.T_cam_obj = r.T_cam_obj;
        m.mu_m = r.mu;
        const auto o = t.fusion->add(m, sv_score);
        if (verbose) {
          // One line per measurement: what the gate did, and (when the frame has ground truth) the
          // ADD-S of the measurement and of the state after it, and their translation errors.
          const orpe::SE3 z = r.T_world_cam * r.T_cam_obj;
          const bool has = t.fusion->has_estimate();
          const orpe::SE3 T = has ? t.fusion->T_world_obj() : z;
          // The measurement as the gate saw it (after the symmetry snap) and its Mahalanobis distance.
          const auto hist = t.fusion->result().history;
          const bool stepped = !hist.empty() && hist.back().frame_index == r.frame && !o.initialised;
          const orpe::SE3 zs = stepped ? hist.back().T_world_obj_measured : z;
          std::printf("frame %4d inst %2d class %2d mu %5.1f mm accepted %d init %d | d2 %7.1f angle(z, state) %6.1f "
                      "deg (snapped %5.1f), |dt| %6.1f mm",
                      r.frame, r.instance, r.cls, r.mu * 1e3, o.accepted, o.initialised,
                      stepped ? hist.back().mahalanobis_sq : 0.0,
                      orpe::rotation_distance_rad(z.rotation(), T.rotation()) * 180 / M_PI,
                      orpe::rotation_distance_rad(zs.rotation(), T.rotation()) * 180 / M_PI,
                      (z.translation() - T.translation()).norm() * 1e3);
          const auto f = gt_frames.find(r.frame);
          if (f != gt_frames.end() && f->second.second) {
            for (const auto& g : f->second.first)
              if (g.class_id == r.cls) {
                const orpe::ModelPoints& pts = model_points(r.cls);
                const orpe::SE3 Tc = r.T_world_cam.inverse() * T;
                std::printf(" | visib %.2f ADD-S sv %6.1f fused %6.1f mm, t err sv %6.1f fused %6.1f mm",
                            g.visible_fraction,
                            orpe::adds_distance(pts, g.T_cam_obj, r.T_cam_obj) * 1e3,
                            orpe::adds_distance(pts, g.T_cam_obj, Tc) * 1e3,
                            (g.T_cam_obj.translation() - r.T_cam_obj.translation()).norm() * 1e3,
                            (g.T_cam_obj.translation() - Tc.translation()).norm() * 1e3);
              }
          }
          if (config.pose_ekf.hypotheses > 1) {
            std::printf(" | hyp");
            for (const auto& h : t.fusion->filter().hypotheses())
              std::printf(" %s%.2f/%d", h.reported ? "*" : "", h.evidence, h.views);
          }
          std::printf("\n");
        }
      }
      orpe::PoseResultRow row;
      row.scene_id = reader->info().scene_id;
      row.im_id = r.frame;
      row.obj_id = r.cls;
      if (t.fusion->has_estimate()) {
        row.T_cam_obj = t.fusion->T_cam_obj(r.T_world_cam);
        row.score = r.class_probability * (t.fusion->accepted() ? t.fusion->score() : sv_score);
      } else if (r.valid) {
        row.T_cam_obj = r.T_cam_obj;
        row.score = r.class_probability * sv_score;
      } else {
        continue;
      }
      rows.push_back(row);
      seen.push_back({r.frame, r.instance, r.cls, row.score, r.T_world_cam});
    }
    orpe::write_bop_results(out_rows, rows);
    for (auto& [id, t] : tracks) t.fusion->flush();
    if (!out_final.empty()) {
      std::vector<orpe::PoseResultRow> final_rows;
      for (const auto& s : seen) {
        const Track& t = tracks.at(s.instance);
        if (t.cls != s.cls || !t.fusion->has_estimate()) continue;
        orpe::PoseResultRow row;
        row.scene_id = reader->info().scene_id;
        row.im_id = s.frame;
        row.obj_id = s.cls;
        row.score = s.score;
        row.T_cam_obj = s.T_world_cam.inverse() * t.fusion->T_world_obj();
        final_rows.push_back(row);
      }
      orpe::write_bop_results(out_final, final_rows);
    }
    int accepted = 0, rejected = 0;
    for (const auto& [id, t] : tracks) {
      accepted += t.fusion->accepted();
      rejected += t.fusion->rejected();
    }
    std::printf("%zu records, %zu instances, %zu rows; measurements in the states %d, rejected %d\n",
                records.size(), tracks.size(), rows.size(), accepted, rejected);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
