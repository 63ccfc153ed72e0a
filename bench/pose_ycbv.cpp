// Single-view model-based pose on the YCB-Video frames of the shared data, with ground-truth masks
// (label.png): every annotated object of every frame. Prints ADD-S AUC, ADD(-S) AUC, < 2 cm per
// class and pooled, and the time per object; optionally one CSV row per instance.
//
//   build/bin/orpe_bench_pose_ycbv [--data DIR] [--format ycbv] [--videos 0000,0001,0002] [--stride N]
//       [--set key=value ...] [--csv FILE] [--markdown] [--diagnose] [--classes 5,10]
//       [--cut F] [--occlude F] [--dilate N] [--fuse] [--ekf key=value ...]
//
// --format: the dataset layout (dataset.format: ycbv, bop, ...), e.g. bop for a scene `orpe synth`
// wrote (--data its scene directory, --videos its scene id).
// --set takes ModelRegistrationParams fields (pose_registration.* without the prefix also works).
// --diagnose also scores the ground-truth pose with the estimator's score, to tell search failures
// (the truth scores higher than the estimate) from scoring failures (a wrong pose scores higher).
// --fuse also runs one pose EKF per object along each video (camera poses: the dataset's ground
// truth T_world_cam; the full pipeline uses the tracked ones) and scores the fused pose of each
// frame moved into that frame's camera, using only the measurements up to that frame. Stress
// options: --cut F drops the left fraction F of each mask's bounding box (a partial mask, as when a
// detector misses part of the object); --dilate N grows each mask by N pixels (boundary leaking
// into the background, as a detector's mask does); --occlude F is --cut F with an occluder: the cut
// part of the bounding box (plus 5 px) gets the depth of a surface 10 cm in front of the object.
// --colour-source: where the models' colour comes from (pose_registration.colour_*): `mesh`
// (default: the texture of the textured meshes), `none`, `other-clips` (learned from the
// ground-truth poses of the other listed videos' frames: never from the video being scored; a class
// seen in no other video has no colour) or `mesh+other-clips` (the texture where there is one, else
// learned).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "bench_args.h"
#include "orpe/core/frame_masks.h"
#include "orpe/core/error.h"
#include "orpe/core/params_io.h"
#include "orpe/eval/pose_metrics.h"
#include "orpe/io/dataset.h"
#include "orpe/pose/colour_score.h"
#include "orpe/pose/model_registration.h"
#include "orpe/pose/pose_ekf.h"
#include "orpe/pipeline/object_models.h"

namespace {

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, sep))
    if (!item.empty()) out.push_back(item);
  return out;
}

std::string default_data_dir() {
  return orpe::bench::shared_data_dir() + "/ycbv";
}

struct Row {
  std::string video;
  int frame = 0;
  int class_id = 0;
  orpe::SingleViewPose est;
  double adds_m = 0, add_m = 0;
  double score_gt = 0, inliers_gt = 0, violation_gt = 0;
  double colour_gt = 0, colour_est = 0;  // the colour evidence at the truth and at the estimate
  bool colour_diagnosed = false;
};

}  // namespace

int main(int argc, char** argv) {
  std::string data = default_data_dir();
  std::vector<std::string> videos = {"0000", "0001", "0002"};
  int stride = 1;
  std::string csv_path;
  bool markdown = false, diagnose = false;
  std::set<int> only_classes;
  bool fuse = false, prior_gt = false, compare_global = false;
  double prior_offset_mm = 0, prior_offset_deg = 0;
  orpe::PoseEkfParams ekf_params;
  double cut_fraction = 0, occlude_fraction = 0;
  int dilate_px = 0;
  orpe::ModelRegistrationParams params;
  std::string colour_source = "mesh";
  std::string format = "ycbv";
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      auto next = [&]() -> std::string {
        if (i + 1 >= argc) throw orpe::ConfigError("missing value after " + a);
        return argv[++i];
      };
      if (a == "--data")
        data = next();
      else if (a == "--format")
        format = next();
      else if (a == "--videos")
        videos = split(next(), ',');
      else if (a == "--colour-source") {
        colour_source = next();
        if (colour_source != "mesh" && colour_source != "none" && colour_source != "other-clips" &&
            colour_source != "mesh+other-clips")
          throw orpe::ConfigError(
              "--colour-source: expected mesh, none, other-clips or "
              "mesh+other-clips, got " +
              colour_source);
      } else if (a == "--stride")
        stride = std::stoi(next());
      else if (a == "--csv")
        csv_path = next();
      else if (a == "--markdown")
        markdown = true;
      else if (a == "--diagnose")
        diagnose = true;
      else if (a == "--prior-gt")
        prior_gt = true;
      else if (a == "--prior-offset") {  // implies --prior-gt
        const auto v = split(next(), ',');
        if (v.size() != 2) throw orpe::ConfigError("--prior-offset expects MM,DEG");
        prior_offset_mm = std::stod(v[0]);
        prior_offset_deg = std::stod(v[1]);
        prior_gt = true;
      } else if (a == "--compare-global")
        compare_global = true;
      else if (a == "--fuse")
        fuse = true;
      else if (a == "--ekf") {
        std::string kv = next();
        if (kv.rfind("pose_ekf.", 0) == 0) kv = kv.substr(9);
        const auto eq = kv.find('=');
        if (eq == std::string::npos) throw orpe::ConfigError("--ekf expects key=value, got " + kv);
        if (!orpe::params_set(ekf_params, kv.substr(0, eq), kv.substr(eq + 1), "pose_ekf"))
          throw orpe::ConfigError("unknown pose_ekf key '" + kv.substr(0, eq) + "'");
      } else if (a == "--cut")
        cut_fraction = std::stod(next());
      else if (a == "--occlude")
        occlude_fraction = std::stod(next());
      else if (a == "--dilate")
        dilate_px = std::stoi(next());
      else if (a == "--classes") {
        for (const auto& c : split(next(), ',')) only_classes.insert(std::stoi(c));
      } else if (a == "--set") {
        std::string kv = next();
        if (kv.rfind("pose_registration.", 0) == 0) kv = kv.substr(18);
        const auto eq = kv.find('=');
        if (eq == std::string::npos) throw orpe::ConfigError("--set expects key=value, got " + kv);
        if (!orpe::params_set(params, kv.substr(0, eq), kv.substr(eq + 1), "pose_registration"))
          throw orpe::ConfigError("unknown pose_registration key '" + kv.substr(0, eq) + "'");
      } else if (a == "--help" || a == "-h") {
        std::printf(
            "usage: %s [--data DIR] [--format ycbv|bop|...] [--videos 0000,0001] [--stride N] [--set key=value]... "
            "[--csv FILE] [--markdown] [--diagnose] [--classes ids] [--cut F] [--occlude F] "
            "[--dilate N] [--fuse] [--ekf key=value] [--colour-source mesh|none|other-clips|"
            "mesh+other-clips]\n",
            argv[0]);
        return 0;
      } else {
        throw orpe::ConfigError("unknown argument " + a);
      }
    }
    const orpe::ModelRegistrationEstimator estimator(params);
    // The prior offset: a fixed translation and rotation (camera frame), as a tracked, fused pose
    // may be off.
    const orpe::SE3 prior_offset(
        Eigen::AngleAxisd(prior_offset_deg * M_PI / 180.0, orpe::Vec3(1, -1, 0.5).normalized())
            .toRotationMatrix(),
        orpe::Vec3(1, 1, 1).normalized() * prior_offset_mm / 1000.0);
    int from_prior = 0;
    std::vector<double> global_ms, fast_ms, fast_vs_global_mm;

    std::map<int, orpe::ObjectModel> models;
    std::map<int, orpe::ModelPoints> eval_points;
    std::map<int, std::string> class_names;
    std::vector<int> symmetric;
    std::vector<orpe::PoseInstanceScore> scores, fused_scores;
    int ekf_rejected = 0, ekf_restarts = 0, ekf_objects = 0;
    std::vector<Row> rows;
    double total_ms = 0;
    std::vector<double> times_ms, cpu_ms;

    auto ensure_model = [&](const orpe::DatasetInfo& info, int class_id) {
      if (models.count(class_id)) return;
      // As the pipeline loads it (points file + mesh, or a mesh alone: BOP, orpe synth).
      models[class_id] = orpe::load_dataset_object_model(info, class_id);
      if (colour_source.rfind("mesh", 0) != 0) models[class_id].colour.reset();
      std::vector<orpe::Vec3> p;
      for (const auto& q : models[class_id].points) p.push_back(q.cast<double>());
      eval_points.emplace(class_id, orpe::ModelPoints(p));
      models[class_id].symmetric_for_metric =
          std::count(info.symmetric_classes.begin(), info.symmetric_classes.end(), class_id) > 0;
    };
    // Colour learned per (video, class) from the ground-truth poses, for --colour-source
    // *other-clips.
    std::map<std::pair<std::string, int>, orpe::ModelColourAccumulator> learned;
    if (colour_source.find("other-clips") != std::string::npos)
      for (const auto& video : videos) {
        orpe::DatasetParams dp;
        dp.format = format;
        dp.scene = video;
        dp.stride = 1;
        const auto reader = orpe::open_dataset(data, dp);
        for (size_t fi = 0; fi < reader->size(); ++fi) {
          const orpe::RgbdFrame frame = reader->read(fi);
          for (size_t k = 0; k < frame.objects_gt.size(); ++k) {
            const auto& gt = frame.objects_gt[k];
            ensure_model(reader->info(), gt.class_id);
            const orpe::MaskImage mask = orpe::ground_truth_mask(frame, k);
            auto it = learned.try_emplace({video, gt.class_id}, models.at(gt.class_id)).first;
            it->second.add_view(gt.T_cam_obj, frame.color, frame.depth, mask, frame.intrinsics);
          }
        }
      }
    // The models used on `video`: colour learned from the other videos only.
    auto models_for = [&](const std::string& video) {
      std::map<int, orpe::ObjectModel> out = models;
      if (learned.empty()) return out;
      for (auto& [cls, m] : out) {
        if (colour_source == "mesh+other-clips" && m.colour) continue;
        std::optional<orpe::ModelColourAccumulator> acc;
        for (const auto& [key, a] : learned)
          if (key.second == cls && key.first != video) {
            if (!acc) acc.emplace(m);
            acc->merge(a);
          }
        m.colour = acc ? acc->result("learned from other clips") : nullptr;
      }
      return out;
    };

    for (const auto& video : videos) {
      std::map<int, orpe::ObjectModel> video_models;
      orpe::DatasetParams dp;
      dp.format = format;
      dp.scene = video;
      dp.stride = stride;
      const auto reader = orpe::open_dataset(data, dp);
      const orpe::DatasetInfo& info = reader->info();
      class_names = info.class_names;
      symmetric = info.symmetric_classes;
      std::map<int, orpe::PoseEkf> filters;  // per class (one instance per class in YCB-Video)
      for (size_t fi = 0; fi < reader->size(); ++fi) {
        const orpe::RgbdFrame frame = reader->read(fi);
        if (frame.labels_gt.empty()) throw orpe::IoError(frame.name, "no ground-truth labels");
        for (size_t k = 0; k < frame.objects_gt.size(); ++k) {
          const auto& gt = frame.objects_gt[k];
          if (!only_classes.empty() && !only_classes.count(gt.class_id)) continue;
          if (!models.count(gt.class_id) || !video_models.count(gt.class_id)) {
            ensure_model(info, gt.class_id);
            video_models = models_for(video);
          }
          orpe::MaskImage mask = orpe::ground_truth_mask(frame, k);
          orpe::DepthImage occluded_depth;
          if (cut_fraction > 0 || occlude_fraction > 0) {
            const double fraction = cut_fraction > 0 ? cut_fraction : occlude_fraction;
            int umin = mask.width(), umax = -1, vmin = mask.height(), vmax = -1;
            std::vector<float> zs;
            for (int v = 0; v < mask.height(); ++v)
              for (int u = 0; u < mask.width(); ++u)
                if (mask.at(u, v)) {
                  umin = std::min(umin, u), umax = std::max(umax, u);
                  vmin = std::min(vmin, v), vmax = std::max(vmax, v);
                  if (frame.depth.at(u, v) > 0) zs.push_back(frame.depth.at(u, v));
                }
            const int ucut = umin + static_cast<int>(fraction * (umax - umin + 1));
            for (int v = 0; v < mask.height(); ++v)
              for (int u = std::max(umin, 0); u < std::min(ucut, mask.width()); ++u)
                mask.at(u, v) = 0;
            if (occlude_fraction > 0 && !zs.empty()) {
              // An occluder 10 cm in front of the object covers the cut part of its bounding box.
              std::nth_element(zs.begin(), zs.begin() + zs.size() / 2, zs.end());
              const float z_occ = std::max(0.1f, zs[zs.size() / 2] - 0.10f);
              occluded_depth = frame.depth;
              for (int v = std::max(vmin - 5, 0); v <= std::min(vmax + 5, mask.height() - 1); ++v)
                for (int u = std::max(umin - 5, 0); u < std::min(ucut, mask.width()); ++u)
                  occluded_depth.at(u, v) = z_occ;
            }
          }
          if (dilate_px > 0) {
            const orpe::MaskImage src = mask;
            for (int v = 0; v < mask.height(); ++v)
              for (int u = 0; u < mask.width(); ++u) {
                if (src.at(u, v)) continue;
                for (int dv = -dilate_px; dv <= dilate_px && !mask.at(u, v); ++dv)
                  for (int du = -dilate_px; du <= dilate_px; ++du)
                    if (src.in_bounds(u + du, v + dv) && src.at(u + du, v + dv)) {
                      mask.at(u, v) = 1;
                      break;
                    }
              }
          }
          orpe::SingleViewInput in;
          in.mask = &mask;
          in.depth = occluded_depth.empty() ? &frame.depth : &occluded_depth;
          in.color = &frame.color;
          in.intrinsics = frame.intrinsics;
          in.class_id = gt.class_id;
          in.model = &video_models.at(gt.class_id);
          if (prior_gt) {  // diagnosis: can ICP hold the truth? (--prior-offset: a nearby pose)
            const orpe::Vec3 c = gt.T_cam_obj.translation();
            in.T_cam_obj_prior = orpe::SE3(prior_offset.rotation() * gt.T_cam_obj.rotation(),
                                           c + prior_offset.translation());
          }

          Row row;
          row.video = video;
          row.frame = frame.index;
          row.class_id = gt.class_id;
          const std::clock_t cpu0 = std::clock();
          row.est = estimator.estimate(in);
          cpu_ms.push_back(1000.0 * static_cast<double>(std::clock() - cpu0) / CLOCKS_PER_SEC);
          total_ms += row.est.time_ms;
          times_ms.push_back(row.est.time_ms);
          from_prior += row.est.from_prior;
          if (compare_global && row.est.from_prior) {
            // The same input without a prior: the global search. How far apart, how much slower.
            orpe::SingleViewInput global_in = in;
            global_in.T_cam_obj_prior.reset();
            const orpe::SingleViewPose g = estimator.estimate(global_in);
            global_ms.push_back(g.time_ms);
            fast_ms.push_back(row.est.time_ms);
            fast_vs_global_mm.push_back(
                g.valid ? 1000 * orpe::adds_distance(eval_points.at(gt.class_id), g.T_cam_obj,
                                                     row.est.T_cam_obj)
                        : std::numeric_limits<double>::infinity());
          }
          orpe::PoseInstanceScore s;
          s.scene_id = info.scene_id;
          s.im_id = frame.index;
          s.class_id = gt.class_id;
          s.symmetric = models[gt.class_id].symmetric_for_metric;
          s.estimated = row.est.valid;
          s.score = row.est.score;
          if (row.est.valid) {
            s.adds_m = row.adds_m =
                orpe::adds_distance(eval_points.at(gt.class_id), gt.T_cam_obj, row.est.T_cam_obj);
            s.add_m = row.add_m = orpe::add_distance(eval_points.at(gt.class_id).points(),
                                                     gt.T_cam_obj, row.est.T_cam_obj);
          } else {
            s.adds_m = s.add_m = row.adds_m = row.add_m = std::numeric_limits<double>::infinity();
          }
          if (diagnose) {
            const orpe::SingleViewPose at_gt = estimator.evaluate(in, gt.T_cam_obj);
            row.score_gt = at_gt.score;
            row.inliers_gt = at_gt.inlier_fraction;
            row.violation_gt = at_gt.free_space_violation;
            if (const auto& mc = in.model->colour; mc && mc->num_known() > 0) {
              const auto evidence = [&](const orpe::SE3& T) {
                return orpe::pose_colour_evidence(*mc, T, frame.color, *in.depth, mask,
                                                  frame.intrinsics, params.colour)
                    .ncc;
              };
              row.colour_gt = evidence(gt.T_cam_obj), row.colour_est = evidence(row.est.T_cam_obj);
              row.colour_diagnosed = true;
            }
          }
          char colour_note[64] = "";
          if (row.colour_diagnosed)
            std::snprintf(colour_note, sizeof colour_note, " [evidence: est %.2f, gt %.2f]",
                          row.colour_est, row.colour_gt);
          std::fprintf(
              stderr,
              "%s/%06d %-22s ADD-S %7.1f mm  ADD %7.1f mm  score %.3f%s  colour %s%.2f (lead "
              "%.2f)%s  %s%6.0f ms\n",
              video.c_str(), frame.index, info.class_names.at(gt.class_id).c_str(),
              row.adds_m * 1000, row.add_m * 1000, row.est.score,
              diagnose ? (" (gt " + std::to_string(row.score_gt).substr(0, 5) + ")").c_str() : "",
              row.est.colour_used ? "" : "off ", row.est.colour_ncc, row.est.colour_margin,
              colour_note,
              row.est.valid ? "" : "INVALID ", row.est.time_ms);
          scores.push_back(s);
          rows.push_back(row);
          if (fuse) {
            if (!frame.T_world_cam_gt) throw orpe::IoError(frame.name, "no camera pose for --fuse");
            auto it = filters.find(gt.class_id);
            if (it == filters.end())
              it =
                  filters
                      .emplace(gt.class_id, orpe::PoseEkf(ekf_params, models[gt.class_id].symmetry))
                      .first;
            orpe::PoseEkf& ekf = it->second;
            ekf.predict();
            if (row.est.valid)
              ekf.update({frame.index, *frame.T_world_cam_gt, row.est.T_cam_obj, row.est.mu_m});
            orpe::PoseInstanceScore fs = s;
            fs.estimated = ekf.initialised();
            if (fs.estimated) {
              const orpe::SE3 T = ekf.T_cam_obj(*frame.T_world_cam_gt);
              fs.adds_m = orpe::adds_distance(eval_points.at(gt.class_id), gt.T_cam_obj, T);
              fs.add_m = orpe::add_distance(eval_points.at(gt.class_id).points(), gt.T_cam_obj, T);
            }
            fused_scores.push_back(fs);
          }
        }
      }
      for (const auto& [cls, ekf] : filters) {
        const orpe::FusedObjectPose r = ekf.result();
        ekf_rejected += r.num_rejected;
        ekf_restarts += r.num_reinitialisations;
        ++ekf_objects;
        std::fprintf(stderr, "%s %-22s EKF: %s\n", video.c_str(), class_names[cls].c_str(),
                     r.report().c_str());
      }
    }
    const orpe::PoseEvaluation ev =
        orpe::summarize_pose_scores(scores, class_names, orpe::PoseMetricsParams{});
    if (fuse) std::printf("single view:\n");
    std::printf("%s", markdown ? ev.markdown().c_str() : ev.report().c_str());
    if (fuse) {
      const orpe::PoseEvaluation fev =
          orpe::summarize_pose_scores(fused_scores, class_names, orpe::PoseMetricsParams{});
      std::printf("fused (EKF, measurements up to each frame):\n%s",
                  markdown ? fev.markdown().c_str() : fev.report().c_str());
      std::printf("EKF: %d objects, %d measurements rejected by the gate, %d restarts\n",
                  ekf_objects, ekf_rejected, ekf_restarts);
    }
    std::sort(times_ms.begin(), times_ms.end());
    if (!times_ms.empty())
      std::printf(
          "objects: %zu, time per object: mean %.0f ms, median %.0f ms, max %.0f ms (threads: "
          "%s)\n",
          times_ms.size(), total_ms / times_ms.size(), times_ms[times_ms.size() / 2],
          times_ms.back(),
          std::getenv("OMP_NUM_THREADS") ? std::getenv("OMP_NUM_THREADS") : "default");
    if (!cpu_ms.empty()) {
      double sum = 0;
      for (double c : cpu_ms) sum += c;
      std::sort(cpu_ms.begin(), cpu_ms.end());
      std::printf(
          "CPU time per object (all threads): mean %.0f ms, median %.0f ms (wall time depends on "
          "the load of the machine; with 2 free cores it is about half)\n",
          sum / cpu_ms.size(), cpu_ms[cpu_ms.size() / 2]);
    }
    if (prior_gt)
      std::printf("from the prior (local refinement, no global search): %d of %zu objects\n",
                  from_prior, times_ms.size());
    if (!global_ms.empty()) {
      double g = 0, f = 0;
      int close = 0;
      for (size_t i = 0; i < global_ms.size(); ++i) {
        g += global_ms[i];
        f += fast_ms[i];
        close += fast_vs_global_mm[i] < 2.0;
      }
      std::sort(fast_vs_global_mm.begin(), fast_vs_global_mm.end());
      std::printf(
          "prior fast path vs global search (same %zu inputs, same run): mean %.1f ms vs %.1f ms "
          "(ratio %.3f); ADD-S between the two poses: median %.2f mm, < 2 mm for %d of them\n",
          global_ms.size(), f / global_ms.size(), g / global_ms.size(), f / g,
          fast_vs_global_mm[fast_vs_global_mm.size() / 2], close);
    }
    if (diagnose) {
      int search_fail = 0, score_fail = 0;
      for (const auto& r : rows) {
        if (r.adds_m < 0.02) continue;
        (r.score_gt > r.est.score ? search_fail : score_fail)++;
      }
      std::printf(
          "instances with ADD-S >= 2 cm: %d search failures (truth scores higher), %d scoring "
          "failures (a wrong pose scores higher)\n",
          search_fail, score_fail);
    }
    if (!csv_path.empty()) {
      std::ofstream os(csv_path);
      if (!os) throw orpe::IoError(csv_path, "cannot write");
      os << "video,frame,class_id,class,valid,adds_mm,add_mm,score,inliers,violation,mu_mm,points,"
            "time_ms,"
            "score_gt,inliers_gt,violation_gt\n";
      for (const auto& r : rows)
        os << r.video << ',' << r.frame << ',' << r.class_id << ',' << class_names[r.class_id]
           << ',' << r.est.valid << ',' << r.adds_m * 1000 << ',' << r.add_m * 1000 << ','
           << r.est.score << ',' << r.est.inlier_fraction << ',' << r.est.free_space_violation
           << ',' << r.est.mu_m * 1000 << ',' << r.est.num_points << ',' << r.est.time_ms << ','
           << r.score_gt << ',' << r.inliers_gt << ',' << r.violation_gt << '\n';
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
