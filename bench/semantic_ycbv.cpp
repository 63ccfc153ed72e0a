// The semantic stage on the shared YCB-Video clips (the paper's Fig. 2 claim and instance checks):
// surfel fusion at the ground-truth camera poses (or with SLAM tracking), degraded ground-truth
// detections (SegmentationParams gt_*), semantic fusion; then per scene
//   - mask IoU of the input detections vs the masks projected from the map, class-agnostic
//     (SemanticMaskEvaluator) and class-aware (eval's MaskEvaluator, as `orpe eval masks` scores);
//   - instance checks: every annotated object exactly one instance with the right argmax class, no
//     spurious instance.
//
//   build/bin/orpe_bench_semantic_ycbv [--data DIR] [--scene NNNN]... [--poses gt|slam] [--out DIR]
//                                      [--figures DIR] [--set section.key=value]...
// --figures writes, per frame, the ground truth, the input detections and the map's projected
// instances side by side (the paper's Fig. 2), plus the masks' error maps.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <filesystem>
#include <iostream>

#include "bench_args.h"
#include "orpe/core/atomic_file.h"
#include "orpe/core/error.h"
#include "orpe/eval/mask_metrics.h"
#include "orpe/io/image_io.h"
#include "orpe/io/point_cloud_io.h"
#include "orpe/pipeline/config.h"
#include "orpe/semantic/mask_eval.h"
#include "orpe/semantic/mask_output.h"
#include "orpe/semantic/semantic_mapper.h"
#include "orpe/semantic/semantic_output.h"
#include "orpe/slam/slam_system.h"

namespace {

using namespace orpe;

struct SceneResult {
  SemanticMaskResult semantic;
  int objects = 0, exactly_one = 0, correct_class = 0, spurious = 0, instances = 0;
  double ms_per_frame = 0;
};

}  // namespace

int main(int argc, char** argv) {
  try {
    const bench::BenchArgs args =
        bench::parse_bench_args(argc, argv, {"--poses", "--out", "--figures"});
    const std::string& data = args.data;
    std::vector<std::string> scenes = args.scenes;
    const OrpeConfig& config = args.config;
    const std::string poses = args.get("--poses", "gt"), out_dir = args.get("--out", ""),
                      figures_dir = args.get("--figures", "");
    if (poses != "gt" && poses != "slam") throw ConfigError("--poses must be gt or slam");
    if (scenes.empty()) scenes = {"0000", "0001", "0002"};
    const std::string root = data + "/ycbv";

    MaskEvaluator input_eval(config.eval_masks), projected_eval(config.eval_masks);
    std::map<int, std::string> class_names;
    double sum_in = 0, sum_proj = 0, sum_in_m = 0, sum_proj_m = 0;
    int samples = 0, matched_in = 0, matched_proj = 0;
    int objects = 0, exactly_one = 0, correct = 0, spurious = 0;
    for (const std::string& scene : scenes) {
      DatasetParams dp = config.dataset;
      dp.format = "ycbv";
      dp.scene = scene;
      const auto reader = open_dataset(root, dp);
      class_names = reader->info().class_names;
      std::vector<int> class_ids;
      for (const auto& [id, name] : class_names) class_ids.push_back(id);
      SemanticMapper mapper(config.segmentation, config.semantic, class_ids);
      slam::SlamSystem system(config.slam_params());
      slam::FramePreprocessor pre(config.slam_preprocess);
      slam::SurfelFusion fusion(config.slam_fusion);
      slam::SurfelMap own_map;
      slam::FramePyramid pyramid;
      slam::IndexImage pixel_surfel;
      SemanticMaskEvaluator evaluator(static_cast<float>(config.segmentation.mask_threshold));
      const auto t0 = std::chrono::steady_clock::now();
      double semantic_ms = 0;
      FrameStream stream(*reader);
      RgbdFrame frame;
      int n = 0;
      while (stream.next(frame)) {
        if (!frame.T_world_cam_gt) throw IoError(frame.name, "no ground-truth camera pose");
        SE3 T_world_cam = *frame.T_world_cam_gt;
        slam::SurfelMap* map = &own_map;
        const slam::IndexImage* pix = &pixel_surfel;
        if (poses == "slam") {
          if (n == 0) system.set_initial_pose(T_world_cam);
          const auto res = system.process(frame);
          T_world_cam = res.T_world_cam;
          map = &system.map();
          pix = res.fused ? &system.last_pixel_surfel() : nullptr;
        } else {
          pre.process(frame, &pyramid);
          fusion.fuse(pyramid, T_world_cam, n, &own_map, &pixel_surfel);
        }
        const auto ts = std::chrono::steady_clock::now();
        const SemanticStep& step = mapper.process(frame, T_world_cam, *map, pix);
        semantic_ms +=
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - ts)
                .count();
        const LabelImage projected =
            mapper.render_instance_labels(*map, T_world_cam, frame.intrinsics);
        evaluator.add_frame(frame, step.detections, projected, mapper.fusion().instances());
        // Class-aware scores (eval's metric): gt labels with their classes, detections, projection.
        LabelClasses gt_classes, det_classes, proj_classes;
        for (size_t k = 0; k < frame.objects_gt.size(); ++k)
          gt_classes[static_cast<int>(k) + 1] = frame.objects_gt[k].class_id;
        const LabelImage det = detection_label_image(
            step.detections, frame.depth.width(), frame.depth.height(),
            static_cast<float>(config.segmentation.mask_threshold), &det_classes);
        for (const auto id : projected)
          if (id > 0 && !proj_classes.count(id))
            proj_classes[id] = mapper.fusion().instances().at(id).argmax_class();
        for (auto& [label, cls] :
             proj_classes)  // a detection's class id as colour key: 0 is not a class
          if (cls == 0) cls = -1;
        if (!figures_dir.empty()) {
          // gt | input | projected, coloured by class so the three panels are comparable.
          const int W = frame.depth.width(), H = frame.depth.height();
          ColorImage panel(3 * W, H);
          auto put = [&](int slot, const LabelImage& labels, const LabelClasses& classes) {
            for (int v = 0; v < H; ++v)
              for (int u = 0; u < W; ++u) {
                const int l = labels.at(u, v);
                const Rgb8 c = frame.color.at(u, v);
                const Rgb8 dim{static_cast<std::uint8_t>(c.r / 3),
                               static_cast<std::uint8_t>(c.g / 3),
                               static_cast<std::uint8_t>(c.b / 3)};
                panel.at(slot * W + u, v) = l > 0 ? label_color(classes.at(l)) : dim;
              }
          };
          put(0, frame.labels_gt, gt_classes);
          put(1, det, det_classes);
          put(2, projected, proj_classes);
          write_color_png(fmt::format("{}/{}/{:06d}.png", figures_dir, scene, frame.index), panel);
        }
        input_eval.add_frame(frame.labels_gt, gt_classes, det, det_classes);
        projected_eval.add_frame(frame.labels_gt, gt_classes, projected, proj_classes);
        if (step.keyframe && std::getenv("ORPE_SEMANTIC_REPORTS"))
          std::cout << step.report.report() << "\n";
        ++n;
      }
      const int removed = mapper.finalize(own_map.empty() ? system.map() : own_map);
      const double total_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      const SemanticMaskResult r = evaluator.result(mapper.fusion().instances());
      std::cout << "=== scene " << scene << ": " << n << " frames, " << mapper.summary() << "; "
                << removed << " instances removed at finalize; " << total_ms / std::max(1, n)
                << " ms/frame in all, semantic " << semantic_ms / std::max(1, n) << " ms/frame\n"
                << r.report();
      for (const auto& [id, info] : mapper.fusion().instances())
        std::cout << "  instance " << id << ": class " << info.argmax_class() << " ("
                  << class_names[info.argmax_class()] << ", p " << info.argmax_probability()
                  << "), " << info.detections << " detections\n";
      if (!out_dir.empty()) {
        const slam::SurfelMap& m = own_map.empty() ? system.map() : own_map;
        write_semantic_outputs(out_dir + "/" + scene, m, mapper.fusion().instances(), class_names);
        write_file_atomic(out_dir + "/" + scene + "/mask_eval.json",
                          [&](std::ostream& os) { os << r.to_json() << "\n"; });
      }
      sum_in += r.overall.input_miou * r.overall.samples;
      sum_proj += r.overall.projected_miou * r.overall.samples;
      samples += r.overall.samples;
      const int m_in = r.overall.samples - r.overall.input_missed,
                m_proj = r.overall.samples - r.overall.projected_missed;
      sum_in_m += r.overall.input_miou_matched * m_in;
      sum_proj_m += r.overall.projected_miou_matched * m_proj;
      matched_in += m_in;
      matched_proj += m_proj;
      objects += static_cast<int>(r.objects.size());
      exactly_one += r.objects_with_exactly_one_instance;
      correct += r.objects_with_correct_class;
      spurious += static_cast<int>(r.spurious_instances.size());
    }
    std::cout << "=== all scenes: class-agnostic mask IoU over " << samples
              << " object samples: input " << sum_in / std::max(1, samples) << " (matched "
              << sum_in_m / std::max(1, matched_in) << "), map-projected "
              << sum_proj / std::max(1, samples) << " (matched "
              << sum_proj_m / std::max(1, matched_proj) << ")\n"
              << "instances: " << exactly_one << " of " << objects
              << " objects exactly one instance, " << correct << " with the right class, "
              << spurious << " spurious\n";
    const MaskEvaluation ein = input_eval.summary(class_names),
                         eproj = projected_eval.summary(class_names);
    std::cout << "=== class-aware (eval masks) input detections:\n"
              << ein.report() << "\n"
              << "=== class-aware (eval masks) map-projected:\n"
              << eproj.report() << "\n";
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
