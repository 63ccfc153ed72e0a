// evaluate_bop_pose_results: targets, estimates and their errors from datasets in BOP layout.
#include <fmt/format.h>
#include <omp.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <tuple>

#include "orpe/core/error.h"
#include "orpe/eval/bop_pose_errors.h"
#include "orpe/eval/bop_pose_metrics.h"
#include "orpe/io/dataset.h"
#include "orpe/io/model_io.h"
#include "orpe/render/mesh_io.h"

namespace orpe {
namespace fs = std::filesystem;
namespace {

using ImageKey = std::pair<int, int>;     // scene_id, im_id
using TargetCounts = std::map<int, int>;  // obj_id -> inst_count
using TargetsFile = std::map<ImageKey, TargetCounts>;

/// test_targets_bop19.json: a list of {"scene_id", "im_id", "obj_id", "inst_count"}.
TargetsFile read_targets_file(const std::string& path) {
  std::ifstream is(path);
  if (!is) throw IoError(path, "cannot open the targets file");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(is);
  } catch (const nlohmann::json::exception& e) {
    throw IoError(path, std::string("malformed JSON: ") + e.what());
  }
  if (!j.is_array()) throw IoError(path, "expected a list of targets");
  TargetsFile out;
  for (size_t k = 0; k < j.size(); ++k) {
    const auto& t = j[k];
    for (const char* key : {"scene_id", "im_id", "obj_id", "inst_count"})
      if (!t.is_object() || !t.contains(key) || !t.at(key).is_number_integer())
        throw IoError(path, fmt::format("target {}: '{}' must be an integer", k, key));
    out[{t.at("scene_id").get<int>(), t.at("im_id").get<int>()}][t.at("obj_id").get<int>()] =
        t.at("inst_count").get<int>();
  }
  return out;
}

/// The dataset root's test_targets_bop19.json, looked for in the opened folder and two above.
std::string find_targets_file(const std::string& root) {
  fs::path p = fs::absolute(root);
  for (int up = 0; up < 3 && !p.empty(); ++up, p = p.parent_path())
    if (fs::is_regular_file(p / "test_targets_bop19.json"))
      return (p / "test_targets_bop19.json").string();
  return {};
}

struct ObjectModelData {
  BopModelInfo info;
  std::vector<SE3> symmetries;
  std::vector<Vec3> points;  ///< MSSD / MSPD points (models_eval vertices when present)
  TriangleMesh mesh;         ///< VSD renders, metres
};

/// Models of one dataset, loaded on first use.
class BopModels {
 public:
  BopModels(const DatasetInfo& info, const BopPoseMetricsParams& params)
      : info_(info), params_(params) {
    if (info.model_mesh_paths.empty())
      throw IoError(info.root,
                    "the dataset has no object models (the BOP metrics need models/ with "
                    "models_info.json)");
    const fs::path dir = fs::path(info.model_mesh_paths.begin()->second).parent_path();
    const std::string file = (dir / "models_info.json").string();
    if (!fs::is_regular_file(file))
      throw IoError(file, "missing: the BOP metrics need the models' diameters and symmetries");
    models_info_path_ = file;
    infos_ = read_bop_models_info(file);
  }

  const ObjectModelData& get(int obj_id) {
    auto it = cache_.find(obj_id);
    if (it != cache_.end()) return it->second;
    const auto info = infos_.find(obj_id);
    if (info == infos_.end())
      throw IoError(models_info_path_, fmt::format("no entry for object {}", obj_id));
    const auto mesh = info_.model_mesh_paths.find(obj_id);
    const auto pts = info_.model_points_paths.find(obj_id);
    if (mesh == info_.model_mesh_paths.end() || pts == info_.model_points_paths.end())
      throw IoError(info_.root, fmt::format("no model file for object {}", obj_id));
    ObjectModelData d;
    d.info = info->second;
    d.symmetries = bop_symmetry_transformations(d.info, params_.max_sym_disc_step);
    d.points = read_model_points(pts->second, info_.model_units_per_m);
    MeshLoadOptions opt;
    opt.metres_per_unit = 1.0 / info_.model_units_per_m;
    opt.load_texture = false;
    d.mesh = load_mesh(mesh->second, opt);
    return cache_.emplace(obj_id, std::move(d)).first->second;
  }

 private:
  const DatasetInfo& info_;
  const BopPoseMetricsParams& params_;
  std::string models_info_path_;
  std::map<int, BopModelInfo> infos_;
  std::map<int, ObjectModelData> cache_;
};

/// Targets of one image: per object, the inst_count most visible instances are valid.
std::vector<BopTarget> image_targets(const RgbdFrame& f, int scene_id, const TargetCounts& counts) {
  std::vector<BopTarget> out;
  for (const auto& [obj, count] : counts) {
    std::vector<int> idx;
    for (size_t k = 0; k < f.objects_gt.size(); ++k)
      if (f.objects_gt[k].class_id == obj) idx.push_back(static_cast<int>(k));
    std::stable_sort(idx.begin(), idx.end(), [&](int a, int b) {
      return f.objects_gt[a].visible_fraction > f.objects_gt[b].visible_fraction;
    });
    for (size_t r = 0; r < idx.size(); ++r)
      out.push_back({scene_id, f.index, obj, idx[r], static_cast<int>(r) < count});
  }
  return out;
}

TargetCounts visible_counts(const RgbdFrame& f, double min_visible_fraction) {
  TargetCounts counts;
  for (const auto& o : f.objects_gt)  // unknown visibility (-1) counts as visible
    if (o.visible_fraction < 0 || o.visible_fraction >= min_visible_fraction) ++counts[o.class_id];
  return counts;
}

/// Errors of the estimates of one image against the instances of their objects.
void compute_errors(const RgbdFrame& frame, std::vector<BopEstimate>& estimates,
                    const std::vector<const PoseResultRow*>& rows, BopModels& models,
                    const BopPoseMetricsParams& params) {
  const PinholeIntrinsics& K = frame.intrinsics;
  std::vector<std::pair<size_t, int>> pairs;  // estimate, gt index
  for (size_t e = 0; e < estimates.size(); ++e) {
    models.get(estimates[e].obj_id);  // load outside the parallel loop
    for (size_t k = 0; k < frame.objects_gt.size(); ++k)
      if (frame.objects_gt[k].class_id == estimates[e].obj_id)
        pairs.emplace_back(e, static_cast<int>(k));
  }
  std::vector<BopPoseErrors> errors(pairs.size());
  const int threads = params.threads > 0 ? params.threads : omp_get_max_threads();
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
  for (size_t i = 0; i < pairs.size(); ++i) {
    const BopEstimate& e = estimates[pairs[i].first];
    const ObjectModelData& m = models.get(e.obj_id);
    const SE3& T_est = rows[pairs[i].first]->T_cam_obj;
    const SE3& T_gt = frame.objects_gt[pairs[i].second].T_cam_obj;
    std::vector<double> taus_m;
    for (double tau : bop_vsd_taus()) taus_m.push_back(tau * m.info.diameter_m);
    errors[i].vsd = vsd_errors(frame.depth, render_model_depth(m.mesh, T_est, K),
                               render_model_depth(m.mesh, T_gt, K), K, params.vsd_delta_m, taus_m);
    errors[i].mssd_m = mssd_m(m.points, T_est, T_gt, m.symmetries);
    errors[i].mspd_px = mspd_px(m.points, K, T_est, T_gt, m.symmetries);
  }
  for (size_t i = 0; i < pairs.size(); ++i)
    estimates[pairs[i].first].errors[pairs[i].second] = errors[i];
}

}  // namespace

BopPoseEvaluation evaluate_bop_pose_results(const std::vector<const DatasetReader*>& readers,
                                            const std::vector<PoseResultRow>& rows,
                                            const BopPoseMetricsParams& params,
                                            const FrameSet* only_frames) {
  std::string why;
  if (!params.IsValid(&why)) throw ConfigError("BOP metrics: " + why);
  BopPoseEvaluation ev;
  ev.params = params;
  ev.result_rows = rows.size();
  std::map<std::tuple<int, int, int>, std::vector<const PoseResultRow*>> rows_by_image;
  for (const auto& r : rows) rows_by_image[{r.scene_id, r.im_id, r.obj_id}].push_back(&r);
  for (auto& [key, list] : rows_by_image)
    std::stable_sort(list.begin(), list.end(),
                     [](const auto* a, const auto* b) { return a->score > b->score; });
  std::vector<BopTarget> targets;
  std::vector<BopEstimate> estimates;
  std::map<int, double> diameters;
  std::map<int, int> widths;
  for (const DatasetReader* reader : readers) {
    const DatasetInfo& info = reader->info();
    BopModels models(info, params);
    widths[info.scene_id] = info.intrinsics.width;
    const std::string targets_path = find_targets_file(info.root);
    const std::optional<TargetsFile> targets_file =
        targets_path.empty() ? std::nullopt : std::optional(read_targets_file(targets_path));
    ev.targets_source = targets_path.empty()
                            ? fmt::format("visib_fract >= {:g}", params.min_visible_fraction)
                            : targets_path;
    ev.class_names.insert(info.class_names.begin(), info.class_names.end());
    for (size_t i = 0; i < reader->size(); ++i) {
      const RgbdFrame a = reader->read_annotations(i);
      if (only_frames && !only_frames->count({info.scene_id, a.index})) continue;
      TargetCounts counts;
      if (targets_file) {
        const auto t = targets_file->find({info.scene_id, a.index});
        if (t == targets_file->end()) continue;
        counts = t->second;
      } else {
        counts = visible_counts(a, params.min_visible_fraction);
      }
      const auto image = image_targets(a, info.scene_id, counts);
      targets.insert(targets.end(), image.begin(), image.end());
      std::vector<BopEstimate> kept;
      std::vector<const PoseResultRow*> kept_rows;
      for (const auto& [obj, count] : counts) {
        diameters[obj] = models.get(obj).info.diameter_m;
        const auto r = rows_by_image.find({info.scene_id, a.index, obj});
        if (r == rows_by_image.end()) continue;
        for (size_t k = 0; k < r->second.size() && static_cast<int>(k) < count; ++k) {
          kept.push_back({info.scene_id, a.index, obj, r->second[k]->score, {}});
          kept_rows.push_back(r->second[k]);
        }
      }
      if (kept.empty()) continue;
      compute_errors(reader->read(i), kept, kept_rows, models, params);
      estimates.insert(estimates.end(), kept.begin(), kept.end());
    }
  }
  ev.estimates = estimates.size();
  ev.all = bop_recalls(targets, estimates, diameters, widths);
  for (const auto& t : targets) ev.targets += t.valid, ev.targets_per_object[t.obj_id] += t.valid;
  for (const auto& entry : ev.targets_per_object) {
    const int obj = entry.first;  // not a structured binding: clang 14 cannot capture one
    std::vector<BopTarget> t;
    std::vector<BopEstimate> e;
    std::copy_if(targets.begin(), targets.end(), std::back_inserter(t),
                 [&](const auto& x) { return x.obj_id == obj; });
    std::copy_if(estimates.begin(), estimates.end(), std::back_inserter(e),
                 [&](const auto& x) { return x.obj_id == obj; });
    ev.per_object[obj] = bop_recalls(t, e, diameters, widths);
  }
  return ev;
}

}  // namespace orpe
