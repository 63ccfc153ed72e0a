// Recognition of known models (segmentation.backend=model) per frame, against the ground truth of
// YCB-Video clips or orpe synth scenes: per annotated object (>= 100 visible pixels) whether a
// detection of the right class covers it (mask IoU >= 0.5), its ADD-S, spurious detections, time.
//
//   build/bin/orpe_bench_recognition_ycbv [--data DIR] [--videos 0000,0001] [--stride N]
//       [--context] [--set recognition.key=value ...]
// --context: one recogniser per clip fed the frames in order with the ground-truth camera pose
// (its tracks then refine known objects); default: every frame on its own.
#include <spdlog/spdlog.h>

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "orpe/eval/pose_metrics.h"
#include "orpe/io/dataset.h"
#include "orpe/pipeline/config.h"
#include "orpe/pipeline/object_models.h"
#include "orpe/recognition/model_recognizer.h"
#include "orpe/semantic/detection.h"

int main(int argc, char** argv) {
  std::string data = "/work/shared/data/ycbv";
  std::string videos_arg = "0000,0001,0002";
  int stride = 1;
  bool context = false;
  orpe::OrpeConfig config;
  config.segmentation.backend = "model";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() { return std::string(i + 1 < argc ? argv[++i] : ""); };
    if (a == "--data")
      data = next();
    else if (a == "--videos")
      videos_arg = next();
    else if (a == "--stride")
      stride = std::stoi(next());
    else if (a == "--context")
      context = true;
    else if (a == "--verbose")
      spdlog::set_level(spdlog::level::debug);
    else if (a == "--trace")
      spdlog::set_level(spdlog::level::trace);
    else if (a == "--set")
      orpe::apply_config_override(config, next());
    else {
      std::fprintf(stderr, "unknown argument %s\n", a.c_str());
      return 2;
    }
  }
  std::vector<std::string> videos;
  std::stringstream ss(videos_arg);
  for (std::string v; std::getline(ss, v, ',');) videos.push_back(v);
  int objects = 0, found = 0, wrong_class = 0, spurious = 0;
  std::vector<double> first_ms, first_cpu_ms, later_ms, later_cpu_ms;
  std::vector<double> adds;
  std::map<std::string, std::pair<int, int>> per_class;
  for (const auto& video : videos) {
    orpe::DatasetParams dp;
    dp.scene = video;
    dp.stride = stride;
    const auto reader = orpe::open_dataset(data, dp);
    const orpe::ObjectModelLibrary library(reader->info());
    std::vector<int> with_models;
    for (const auto& [id, path] : reader->info().model_points_paths) with_models.push_back(id);
    const auto classes = orpe::resolve_model_classes(config.segmentation.model_classes,
                                                     reader->info().class_names, with_models);
    std::vector<orpe::ObjectModel> models;
    for (int id : classes) models.push_back(library.get(id));
    orpe::ModelRecognizer rec(config.segmentation, config.recognition, config.recognition_geometry,
                              models);
    for (size_t fi = 0; fi < reader->size(); ++fi) {
      const orpe::RgbdFrame frame = reader->read(fi);
      const auto t0 = std::chrono::steady_clock::now();
      orpe::SegmentationContext ctx;
      if (frame.T_world_cam_gt) ctx.T_world_cam = *frame.T_world_cam_gt;
      const auto dets = context ? rec.detect_in_context(frame, ctx) : rec.detect(frame);
      const double ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      const auto& tm = rec.last_timing();
      (fi == 0 ? first_ms : later_ms).push_back(ms);
      (fi == 0 ? first_cpu_ms : later_cpu_ms).push_back(tm.cpu_ms);
      std::vector<int> used(dets.size(), 0);
      std::string line;
      for (size_t k = 0; k < frame.objects_gt.size(); ++k) {
        const auto& gt = frame.objects_gt[k];
        const int label = static_cast<int>(k) + 1;
        int area = 0;
        for (auto l : frame.labels_gt) area += l == label;
        if (area < 100) continue;
        ++objects;
        int best = -1;
        double best_iou = 0;
        for (size_t d = 0; d < dets.size(); ++d) {
          int inter = 0, uni = 0;
          for (size_t p = 0; p < frame.labels_gt.size(); ++p) {
            const bool a = frame.labels_gt[p] == label, b = dets[d].probability[p] >= 0.5f;
            inter += a && b;
            uni += a || b;
          }
          const double iou = uni ? static_cast<double>(inter) / uni : 0;
          if (iou > best_iou) {
            best_iou = iou;
            best = static_cast<int>(d);
          }
        }
        const std::string name = reader->info().class_names.at(gt.class_id);
        auto& pc = per_class[name];
        ++pc.second;
        double e = 1.0;
        if (best >= 0 && best_iou >= 0.5) {
          used[best] = 1;
          if (dets[best].class_id == gt.class_id) {
            ++found;
            ++pc.first;
            const auto& o = rec.last_objects()[best];
            line += fmt::format(" ok:{}[n{} s{:.2f} v{:.2f}]", name, o.explained_points, o.support,
                                o.violation);
            const auto& m = library.get(gt.class_id);
            std::vector<orpe::Vec3> pts;
            for (const auto& p : m.points) pts.push_back(p.cast<double>());
            e = orpe::adds_distance(orpe::ModelPoints(pts), gt.T_cam_obj,
                                    rec.last_objects()[best].T_cam_obj);
          } else {
            ++wrong_class;
            line += " " + name + "->" + reader->info().class_names.at(dets[best].class_id);
          }
        } else {
          line += " miss:" + name;
        }
        adds.push_back(e);
      }
      for (size_t d = 0; d < dets.size(); ++d)
        if (!used[d]) {
          ++spurious;
          const auto& o = rec.last_objects()[d];
          const auto& b = dets[d].box;
          line += fmt::format(" spurious:{}[n{} s{:.2f} v{:.2f} px {}-{},{}-{}]",
                              reader->info().class_names.at(dets[d].class_id), o.explained_points,
                              o.support, o.violation, b.u_min, b.u_max, b.v_min, b.v_max);
        }
      std::printf(
          "%s/%06d %zu det %.0f ms (cpu %.0f; geometry %.0f, tracks %.0f, search %.0f, verify "
          "%.0f, "
          "masks %.0f; %d refinements, %d searches)%s\n",
          video.c_str(), frame.index, dets.size(), ms, tm.cpu_ms, tm.geometry_ms, tm.tracks_ms,
          tm.search_ms, tm.verify_ms, tm.detections_ms, tm.refinements, tm.searches, line.c_str());
      std::fflush(stdout);
    }
  }
  std::printf("\nobjects %d, right class %d (%.1f %%), wrong class %d, spurious %d\n", objects,
              found, 100.0 * found / std::max(1, objects), wrong_class, spurious);
  std::printf("ADD-S AUC (misses count) %.2f\n", orpe::ycb_auc_percent(adds));
  auto quantile = [](std::vector<double> v, double q) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    return v[static_cast<size_t>(std::min<double>(v.size() - 1, std::floor(q * v.size())))];
  };
  std::printf("first frame of each clip: wall ms median %.0f max %.0f, cpu ms median %.0f\n",
              quantile(first_ms, 0.5), quantile(first_ms, 1.0), quantile(first_cpu_ms, 0.5));
  std::printf("later frames (%zu): wall ms median %.0f p90 %.0f, cpu ms median %.0f p90 %.0f\n",
              later_ms.size(), quantile(later_ms, 0.5), quantile(later_ms, 0.9),
              quantile(later_cpu_ms, 0.5), quantile(later_cpu_ms, 0.9));
  for (const auto& [name, c] : per_class)
    std::printf("  %-22s %d / %d\n", name.c_str(), c.first, c.second);
  return 0;
}
