// Where the stray surfels of the semantic map's object segments come from (issue #14,
// docs/SEMANTIC.md "Stray surfels"). Runs SLAM tracking + semantic mapping as `orpe run --mode
// semantic` does, and at every keyframe diffs the surfels' instance ids across the semantic update:
// each surfel that takes an instance while lying more than --far-m (2 cm) from that object's model
// surface (at the ground-truth pose, in the map's frame) is a new stray, classified by how it got
// its label:
//   - direct, in gt mask: its pixel is in the detection's mask AND in the object's ground-truth
//   mask,
//     i.e. the pixel's depth belongs to something behind/beside the object (depth bleeding, or the
//     colour/depth misregistration of the sensor);
//   - direct, outside gt mask: the detection's mask is larger than the object there (degraded /
//     dilated masks, spurious blobs);
//   - boundary: joined by the boundary refinement;  merge: moved by an instance merge.
// and by whether its depth along the view ray lies behind the object's other surfels. At the end
// (after finalize) the strays still in the map are listed by their observation count and p_o.
//
//   build/bin/orpe_bench_segment_strays [--data DIR] [--scene NNNN]... [--far-m 0.02]
//                                       [--set section.key=value]...
#include <fmt/format.h>

#include <iostream>
#include <map>

#include "bench_args.h"
#include "orpe/core/error.h"
#include "orpe/pipeline/config.h"
#include "orpe/pipeline/reconstruction_error.h"
#include "orpe/semantic/semantic_mapper.h"
#include "orpe/slam/slam_system.h"

namespace {

using namespace orpe;

struct Counts {
  long direct_in_gt = 0, direct_outside_gt = 0, boundary = 0, merge = 0, behind_ray = 0,
       seen_once = 0;
  long total() const { return direct_in_gt + direct_outside_gt + boundary + merge; }
};

struct Scene {
  std::map<int, const ModelSurface*> surface_of_class;
  std::map<int, SE3> T_world_obj_of_class;  // first frame that lists the class
  std::map<int, int> gt_label_of_class;     // in the current frame: labels_gt value
};

double distance_to_object(const Scene& s, int cls, const Eigen::Vector3f& p_world) {
  const auto surf = s.surface_of_class.find(cls);
  const auto pose = s.T_world_obj_of_class.find(cls);
  if (surf == s.surface_of_class.end() || pose == s.T_world_obj_of_class.end()) return -1;
  return surf->second->distance_m((pose->second.inverse() * p_world.cast<double>()).cast<float>());
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const bench::BenchArgs args = bench::parse_bench_args(argc, argv, {"--far-m"});
    const std::string& data = args.data;
    std::vector<std::string> scenes = args.scenes;
    const OrpeConfig& config = args.config;
    const double far_m = args.number("--far-m", 0.02);
    if (!(far_m > 0)) throw ConfigError("--far-m must be positive");
    if (scenes.empty()) scenes = {"0000", "0001", "0002"};
    for (const std::string& scene : scenes) {
      DatasetParams dp = config.dataset;
      dp.format = "ycbv";
      dp.scene = scene;
      const auto reader = open_dataset(data + "/ycbv", dp);
      const DatasetInfo& info = reader->info();
      std::vector<int> class_ids;
      for (const auto& [id, name] : info.class_names) class_ids.push_back(id);
      SemanticMapper mapper(config.segmentation, config.semantic, class_ids);
      slam::SlamSystem system(config.slam_params());
      std::map<int, ModelSurface> surfaces;
      Scene s;
      Counts counts;
      std::map<int, Counts> per_class;
      FrameStream stream(*reader);
      RgbdFrame frame;
      bool first = true;
      while (stream.next(frame)) {
        if (first && frame.T_world_cam_gt) system.set_initial_pose(*frame.T_world_cam_gt);
        first = false;
        const auto res = system.process(frame);
        const SE3 T_world_cam = res.T_world_cam;
        slam::SurfelMap& map = system.map();
        s.gt_label_of_class.clear();
        for (size_t k = 0; k < frame.objects_gt.size(); ++k) {
          const auto& g = frame.objects_gt[k];
          s.gt_label_of_class[g.class_id] = static_cast<int>(k) + 1;
          if (!surfaces.count(g.class_id)) {
            surfaces.emplace(g.class_id, load_model_surface(info, g.class_id));
            s.surface_of_class[g.class_id] = &surfaces.at(g.class_id);
          }
          if (!s.T_world_obj_of_class.count(g.class_id))
            s.T_world_obj_of_class[g.class_id] = T_world_cam * g.T_cam_obj;
        }
        const std::vector<std::int32_t> before = map.instance_id;
        const SemanticStep& step = mapper.process(
            frame, T_world_cam, map, res.fused ? &system.last_pixel_surfel() : nullptr);
        if (!step.keyframe) continue;
        const auto& instances = mapper.fusion().instances();
        const LabelImage& det = mapper.fusion().last_detection_labels();
        const SE3 T_cam_world = T_world_cam.inverse();
        // Median camera depth of each instance's surfels seen from here (the "other surfels").
        std::map<int, std::vector<float>> inst_depth;
        for (size_t i = 0; i < map.size(); ++i)
          if (map.instance_id[i] > 0 && (i >= before.size() || before[i] == map.instance_id[i]))
            inst_depth[map.instance_id[i]].push_back(
                static_cast<float>((T_cam_world * map.position_world[i].cast<double>()).z()));
        std::map<int, float> median_depth;
        for (auto& [id, z] : inst_depth) {
          std::nth_element(z.begin(), z.begin() + z.size() / 2, z.end());
          median_depth[id] = z[z.size() / 2];
        }
        for (size_t i = 0; i < map.size() && i < before.size(); ++i) {
          const int id = map.instance_id[i];
          if (id <= 0 || id == before[i] || !instances.count(id)) continue;
          const int cls = instances.at(id).argmax_class();
          const double d = distance_to_object(s, cls, map.position_world[i]);
          if (d < far_m) continue;
          const Eigen::Vector3d p = T_cam_world * map.position_world[i].cast<double>();
          Counts& c = per_class[cls];
          const long u =
              p.z() > 0 ? std::lround(frame.intrinsics.fx * p.x() / p.z() + frame.intrinsics.cx)
                        : -1;
          const long v =
              p.z() > 0 ? std::lround(frame.intrinsics.fy * p.y() / p.z() + frame.intrinsics.cy)
                        : -1;
          const bool inside = u >= 0 && v >= 0 && u < det.width() && v < det.height();
          if (before[i] > 0) {
            ++c.merge;
          } else if (inside && det.at(static_cast<int>(u), static_cast<int>(v)) == id) {
            const auto gl = s.gt_label_of_class.find(cls);
            const bool in_gt =
                gl != s.gt_label_of_class.end() && !frame.labels_gt.empty() &&
                frame.labels_gt.at(static_cast<int>(u), static_cast<int>(v)) == gl->second;
            ++(in_gt ? c.direct_in_gt : c.direct_outside_gt);
          } else {
            ++c.boundary;
          }
          const auto md = median_depth.find(id);
          if (md != median_depth.end() && p.z() > md->second + far_m) ++c.behind_ray;
          if (map.object_obs_count[i] <= 1) ++c.seen_once;
        }
      }
      mapper.finalize(system.map());
      const slam::SurfelMap& map = system.map();
      std::cout << "=== scene " << scene << ": new strays (> " << far_m * 1000
                << " mm) at labelling, per class\n";
      fmt::print("{:<22} {:>9} {:>9} {:>9} {:>7} {:>8} {:>9}\n", "class", "in-gt", "outside",
                 "boundary", "merge", "behind", "1 obs");
      for (const auto& [cls, c] : per_class)
        fmt::print("{:<22} {:>9} {:>9} {:>9} {:>7} {:>8} {:>9}\n", info.class_names.at(cls),
                   c.direct_in_gt, c.direct_outside_gt, c.boundary, c.merge, c.behind_ray,
                   c.seen_once);
      // Final strays by observation count and p_o.
      std::map<int, std::array<long, 6>> final_hist;  // class -> [all, strays, obs<=2, p_o<0.5,
                                                      // conf<2, behind-cam]
      for (size_t i = 0; i < map.size(); ++i) {
        const int id = map.instance_id[i];
        if (id <= 0 || !mapper.fusion().instances().count(id)) continue;
        const int cls = mapper.fusion().instances().at(id).argmax_class();
        auto& h = final_hist[cls];
        ++h[0];
        if (distance_to_object(s, cls, map.position_world[i]) < far_m) continue;
        ++h[1];
        if (std::getenv("ORPE_STRAYS_DUMP")) {
          const Eigen::Vector3d q =
              s.T_world_obj_of_class.at(cls).inverse() * map.position_world[i].cast<double>();
          fmt::print(stderr, "stray {} {:.4f} {:.4f} {:.4f} d {:.4f} obs {} p {:.2f} conf {:.1f}\n",
                     cls, q.x(), q.y(), q.z(), distance_to_object(s, cls, map.position_world[i]),
                     map.object_obs_count[i], map.p_object[i], map.confidence[i]);
        }
        if (map.object_obs_count[i] <= 2) ++h[2];
        if (map.p_object[i] < 0.5f) ++h[3];
        if (map.confidence[i] < 2.0f) ++h[4];
      }
      std::cout << "final segments: surfels, strays, strays with <= 2 observations, p_o < 0.5, "
                   "confidence < 2\n";
      for (const auto& [cls, h] : final_hist)
        fmt::print("{:<22} {:>9} {:>7} {:>7} {:>7} {:>7}\n",
                   info.class_names.count(cls) ? info.class_names.at(cls) : std::to_string(cls),
                   h[0], h[1], h[2], h[3], h[4]);
    }
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
