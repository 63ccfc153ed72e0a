// Recognition of known models (segmentation.backend=model) per frame, against the ground truth of
// YCB-Video clips or orpe synth scenes: per annotated object (>= 100 visible pixels) whether a
// detection of the right class covers it (mask IoU >= 0.5), its ADD-S, spurious detections, time.
//
//   build/bin/orpe_bench_recognition_ycbv [--data DIR] [--scene 0000]... [--dataset DIR]
//       [--stride N] [--context 0|1] [--log info|debug|trace] [--dump DIR]
//       [--set section.key=value]...
// --data: the shared data root (default $ORPE_DATA_DIR, else ../shared/data), the clips in
// DIR/ycbv; --dataset: any other dataset folder instead (e.g. an `orpe synth` output; default
// scene: the first found). --context 1: one recogniser per clip fed the frames in order with the
// ground-truth camera pose (its tracks then refine known objects); default: every frame on its
// own. --dump: per frame DIR/<scene>_<frame>_regions.png, the scene geometry the recogniser sees
// (support planes grey, regions coloured) beside the kept detections.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <string>
#include <vector>

#include "bench_args.h"
#include "orpe/eval/pose_metrics.h"
#include "orpe/io/dataset.h"
#include "orpe/io/image_io.h"
#include "orpe/pipeline/config.h"
#include "orpe/pipeline/object_models.h"
#include "orpe/recognition/model_recognizer.h"
#include "orpe/semantic/detection.h"

namespace {

using namespace orpe;

struct Tally {
  int objects = 0, found = 0, wrong_class = 0, spurious = 0;
  std::vector<double> first_ms, first_cpu_ms, later_ms, later_cpu_ms, adds;
  std::map<std::string, std::pair<int, int>> per_class;
  std::map<std::string, int> spurious_on;  ///< target (fragment, duplicate), distractor, background
};

Rgb8 region_colour(int r) {
  const unsigned h = static_cast<unsigned>(r + 1) * 2654435761u;
  return {static_cast<std::uint8_t>(64 + (h >> 8) % 192),
          static_cast<std::uint8_t>(64 + (h >> 16) % 192),
          static_cast<std::uint8_t>(64 + (h >> 24) % 192)};
}

/// The geometry the recogniser works on (left: planes grey, regions coloured) and the detections
/// (right), one PNG.
void dump_frame(const std::string& path, const RgbdFrame& frame, const OrpeConfig& config,
                const std::vector<Detection>& dets) {
  PinholeIntrinsics K = frame.intrinsics;
  K.width = frame.depth.width(), K.height = frame.depth.height();
  SceneGrid g = make_scene_grid(frame.depth, K, config.recognition_geometry);
  remove_support_planes(g, config.recognition_geometry);
  split_regions(g, config.recognition_geometry);
  const int W = frame.depth.width(), H = frame.depth.height();
  ColorImage out(2 * W, H, Rgb8{0, 0, 0});
  for (int v = 0; v < H; ++v)
    for (int u = 0; u < W; ++u) {
      const int c = g.cell(u / g.stride, v / g.stride);
      Rgb8 col{0, 0, 0};
      if (g.region[c] >= 0)
        col = region_colour(g.region[c]);
      else if (g.kept[c])
        col = {255, 255, 255};  // kept, in a region too small
      else if (g.valid[c])
        col = {70, 70, 70};  // a support plane or beyond the height limit
      out.at(u, v) = col;
      if (!frame.color.empty()) {
        const Rgb8 im = frame.color.at(u, v);
        out.at(W + u, v) = {static_cast<std::uint8_t>(im.r / 3),
                            static_cast<std::uint8_t>(im.g / 3),
                            static_cast<std::uint8_t>(im.b / 3)};
      }
    }
  for (size_t d = 0; d < dets.size(); ++d)
    for (int v = 0; v < H; ++v)
      for (int u = 0; u < W; ++u)
        if (dets[d].probability.at(u, v) >= 0.5f)
          out.at(W + u, v) = region_colour(dets[d].class_id * 7);
  write_color_png(path, out);
}

/// What a spurious detection lies on, by the majority of its mask pixels: "t<name>" an annotated
/// object (a fragment or duplicate of it), "d<id>" a distractor of an `orpe synth` scene (its
/// distractor/ image, when there is one), "bg" anything else.
std::string spurious_on(const RgbdFrame& frame, const DatasetInfo& info,
                        const LabelImage& distractors, const Detection& det) {
  std::map<std::string, int> votes;
  for (size_t p = 0; p < frame.labels_gt.size(); ++p) {
    if (det.probability[p] < 0.5f) continue;
    const int l = frame.labels_gt[p];
    if (l > 0 && l <= static_cast<int>(frame.objects_gt.size()))
      ++votes["t" + info.class_names.at(frame.objects_gt[static_cast<size_t>(l) - 1].class_id)];
    else if (!distractors.empty() && distractors[p] > 0)
      ++votes[fmt::format("d{}", distractors[p])];
    else
      ++votes["bg"];
  }
  std::string best = "bg";
  int most = 0;
  for (const auto& [k, n] : votes)
    if (n > most) most = n, best = k;
  return best;
}

/// The distractor image of frame `index` of an `orpe synth` scene (DIR/test/SCENE/distractor/),
/// empty when the dataset has none.
LabelImage distractor_labels(const std::string& root, const std::string& scene, int index) {
  const std::string path = fmt::format("{}/test/{}/distractor/{:06d}.png", root,
                                       scene.empty() ? "000000" : scene, index);
  return std::filesystem::exists(path) ? read_label_image(path) : LabelImage();
}

/// Scores one frame's detections against its annotations; returns the per-frame summary.
std::string score_frame(const RgbdFrame& frame, const DatasetInfo& info,
                        const ObjectModelLibrary& library, const ModelRecognizer& rec,
                        const std::vector<Detection>& dets, const LabelImage& distractors,
                        Tally& t) {
  std::vector<int> used(dets.size(), 0);
  std::string line;
  for (size_t k = 0; k < frame.objects_gt.size(); ++k) {
    const auto& gt = frame.objects_gt[k];
    const int label = static_cast<int>(k) + 1;
    int area = 0;
    for (auto l : frame.labels_gt) area += l == label;
    if (area < 100) continue;
    ++t.objects;
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
      if (iou > best_iou) best_iou = iou, best = static_cast<int>(d);
    }
    const std::string name = info.class_names.at(gt.class_id);
    spdlog::debug("ground truth: {} at {:.3f} {:.3f} {:.3f}", name, gt.T_cam_obj.translation().x(),
                  gt.T_cam_obj.translation().y(), gt.T_cam_obj.translation().z());
    if (spdlog::should_log(spdlog::level::debug)) {
      const RecognizedObject s = rec.score_pose(frame, gt.class_id, gt.T_cam_obj);
      spdlog::debug(
          "  scored at its true pose: explains {}, fit {:.0f}, support {:.2f}, violation "
          "{:.2f}, in image {:.2f}, solo leak {:.2f}, rank {:.0f}, stands {}",
          s.explained_points, s.fit, s.support, s.violation, s.in_image, s.solo_leak, s.rank,
          s.stands);
    }
    auto& pc = t.per_class[name];
    ++pc.second;
    double e = 1.0;
    if (best >= 0 && best_iou >= 0.5) {
      used[best] = 1;
      if (dets[best].class_id == gt.class_id) {
        ++t.found;
        ++pc.first;
        const auto& o = rec.last_objects()[best];
        line += fmt::format(" ok:{}[n{} s{:.2f} v{:.2f}]", name, o.explained_points, o.support,
                            o.violation);
        std::vector<Vec3> pts;
        for (const auto& p : library.get(gt.class_id).points) pts.push_back(p.cast<double>());
        e = adds_distance(ModelPoints(pts), gt.T_cam_obj, o.T_cam_obj);
      } else {
        ++t.wrong_class;
        line += " " + name + "->" + info.class_names.at(dets[best].class_id);
      }
    } else {
      line += fmt::format(" miss:{}({}px)", name, area);
    }
    t.adds.push_back(e);
  }
  for (size_t d = 0; d < dets.size(); ++d) {
    if (used[d]) continue;
    ++t.spurious;
    const auto& o = rec.last_objects()[d];
    const auto& b = dets[d].box;
    const std::string on = spurious_on(frame, info, distractors, dets[d]);
    ++t.spurious_on[on[0] == 't' ? "target" : on[0] == 'd' ? "distractor" : "background"];
    line += fmt::format(" spurious:{}[on {} n{} s{:.2f} v{:.2f} px {}-{},{}-{}]",
                        info.class_names.at(dets[d].class_id), on, o.explained_points, o.support,
                        o.violation, b.u_min, b.u_max, b.v_min, b.v_max);
  }
  return line;
}

void run_scene(const std::string& root, const std::string& scene, const bench::BenchArgs& args,
               Tally& t) {
  DatasetParams dp = args.config.dataset;
  dp.scene = scene;
  dp.stride = static_cast<int>(args.number("--stride", 1));
  const bool context = args.number("--context", 0) != 0;
  const std::string dump = args.get("--dump", "");
  const auto reader = open_dataset(root, dp);
  const ObjectModelLibrary library(reader->info());
  std::vector<int> with_models;
  for (const auto& [id, path] : reader->info().model_points_paths) with_models.push_back(id);
  const auto classes = resolve_model_classes(args.config.segmentation.model_classes,
                                             reader->info().class_names, with_models);
  std::vector<ObjectModel> models;
  for (int id : classes) models.push_back(library.get(id));
  ModelRecognizer rec(args.config.segmentation, args.config.recognition,
                      args.config.recognition_geometry, models);
  for (size_t fi = 0; fi < reader->size(); ++fi) {
    const RgbdFrame frame = reader->read(fi);
    const auto t0 = std::chrono::steady_clock::now();
    SegmentationContext ctx;
    if (frame.T_world_cam_gt) ctx.T_world_cam = *frame.T_world_cam_gt;
    const auto dets = context ? rec.detect_in_context(frame, ctx) : rec.detect(frame);
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    const auto& tm = rec.last_timing();
    (fi == 0 ? t.first_ms : t.later_ms).push_back(ms);
    (fi == 0 ? t.first_cpu_ms : t.later_cpu_ms).push_back(tm.cpu_ms);
    const std::string line = score_frame(frame, reader->info(), library, rec, dets,
                                         distractor_labels(root, scene, frame.index), t);
    std::printf(
        "%s/%06d %zu det %.0f ms (cpu %.0f; geometry %.0f, tracks %.0f, search %.0f, verify %.0f, "
        "masks %.0f; "
        "%d refinements, %d searches)%s\n",
        (scene.empty() ? "scene" : scene).c_str(), frame.index, dets.size(), ms, tm.cpu_ms,
        tm.geometry_ms, tm.tracks_ms, tm.search_ms, tm.verify_ms, tm.detections_ms, tm.refinements,
        tm.searches, line.c_str());
    std::fflush(stdout);
    if (!dump.empty()) {
      std::filesystem::create_directories(dump);
      dump_frame(fmt::format("{}/{}_{:06d}_regions.png", dump, scene.empty() ? "scene" : scene,
                             frame.index),
                 frame, args.config, dets);
    }
  }
}

void print_tally(Tally& t) {
  std::printf("\nobjects %d, right class %d (%.1f %%), wrong class %d, spurious %d\n", t.objects,
              t.found, 100.0 * t.found / std::max(1, t.objects), t.wrong_class, t.spurious);
  std::printf("spurious on: targets %d, distractors %d, background %d\n", t.spurious_on["target"],
              t.spurious_on["distractor"], t.spurious_on["background"]);
  std::printf("ADD-S AUC (misses count) %.2f\n", ycb_auc_percent(t.adds));
  auto quantile = [](std::vector<double> v, double q) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    return v[static_cast<size_t>(std::min<double>(v.size() - 1, std::floor(q * v.size())))];
  };
  std::printf("first frame of each clip: wall ms median %.0f max %.0f, cpu ms median %.0f\n",
              quantile(t.first_ms, 0.5), quantile(t.first_ms, 1.0), quantile(t.first_cpu_ms, 0.5));
  std::printf("later frames (%zu): wall ms median %.0f p90 %.0f, cpu ms median %.0f p90 %.0f\n",
              t.later_ms.size(), quantile(t.later_ms, 0.5), quantile(t.later_ms, 0.9),
              quantile(t.later_cpu_ms, 0.5), quantile(t.later_cpu_ms, 0.9));
  for (const auto& [name, c] : t.per_class)
    std::printf("  %-22s %d / %d\n", name.c_str(), c.first, c.second);
}

}  // namespace

int main(int argc, char** argv) {
  try {
    OrpeConfig config;
    config.segmentation.backend = "model";
    const bench::BenchArgs args = bench::parse_bench_args(
        argc, argv, {"--dataset", "--stride", "--context", "--log", "--dump"}, config);
    const std::string log = args.get("--log", "info");
    if (log == "debug")
      spdlog::set_level(spdlog::level::debug);
    else if (log == "trace")
      spdlog::set_level(spdlog::level::trace);
    else if (log != "info")
      throw ConfigError("--log must be info, debug or trace");
    if (args.number("--stride", 1) < 1) throw ConfigError("--stride must be >= 1");
    const std::string own = args.get("--dataset", "");
    const std::string root = own.empty() ? args.data + "/ycbv" : own;
    std::vector<std::string> scenes = args.scenes;
    if (scenes.empty())
      scenes = own.empty() ? std::vector<std::string>{"0000", "0001", "0002"}
                           : std::vector<std::string>{""};
    Tally tally;
    for (const auto& scene : scenes) run_scene(root, scene, args, tally);
    print_tally(tally);
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
