#include "orpe/eval/pose_metrics.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <limits>
#include <nanoflann.hpp>
#include <nlohmann/json.hpp>
#include <set>
#include <stdexcept>
#include <tuple>

#include "orpe/core/error.h"
#include "orpe/core/text_lines.h"
#include "orpe/core/parse_number.h"
#include "orpe/io/dataset.h"
#include "orpe/io/model_io.h"

namespace orpe {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

struct PointsAdaptor {
  const std::vector<Vec3>* points;
  size_t kdtree_get_point_count() const { return points->size(); }
  double kdtree_get_pt(size_t i, size_t dim) const { return (*points)[i][static_cast<int>(dim)]; }
  template <class Bbox>
  bool kdtree_get_bbox(Bbox&) const {
    return false;
  }
};

// nanoflann 1.4: the index type defaults to uint32_t (unsigned int).
using KdTree =
    nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, PointsAdaptor>,
                                        PointsAdaptor, 3, unsigned int>;

std::string percent(double fraction_or_percent) {
  return fmt::format("{:.2f}", fraction_or_percent);
}

nlohmann::json summary_json(const PoseClassSummary& s) {
  return {{"class_id", s.class_id},      {"name", s.name},
          {"symmetric", s.symmetric},    {"instances", s.instances},
          {"estimated", s.estimated},    {"adds_auc", s.adds_auc},
          {"add_s_auc", s.add_s_auc},    {"add_auc", s.add_auc},
          {"adds_below", s.adds_below},  {"add_s_below", s.add_s_below},
          {"adds_mean_m", s.adds_mean_m}};
}

}  // namespace

struct ModelPoints::Tree {
  PointsAdaptor adaptor;
  KdTree index;
  explicit Tree(const std::vector<Vec3>* points)
      : adaptor{points}, index(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(10)) {}
};

ModelPoints::ModelPoints(std::vector<Vec3> points_obj) : points_obj_(std::move(points_obj)) {
  if (points_obj_.empty()) throw std::invalid_argument("ModelPoints: empty point set");
  tree_ = std::make_unique<Tree>(&points_obj_);
}
ModelPoints::~ModelPoints() = default;
// The tree's adaptor points at the vector object (not its buffer), so re-point it after a move.
ModelPoints::ModelPoints(ModelPoints&& o) noexcept
    : points_obj_(std::move(o.points_obj_)), tree_(std::move(o.tree_)) {
  if (tree_) tree_->adaptor.points = &points_obj_;
}
ModelPoints& ModelPoints::operator=(ModelPoints&& o) noexcept {
  points_obj_ = std::move(o.points_obj_);
  tree_ = std::move(o.tree_);
  if (tree_) tree_->adaptor.points = &points_obj_;
  return *this;
}

double ModelPoints::closest_distance(const Vec3& q_obj) const {
  unsigned int index = 0;
  double dist_sq = 0;
  tree_->index.knnSearch(q_obj.data(), 1, &index, &dist_sq);
  // The tree's squared distance is exact up to rounding; recompute from the point for symmetry with
  // the brute force reference.
  return (points_obj_[index] - q_obj).norm();
}

bool PoseMetricsParams::IsValid(std::string* why) const {
  auto fail = [&](const std::string& msg) {
    if (why) *why = msg;
    return false;
  };
  if (!(auc_max_distance_m > 0) || !std::isfinite(auc_max_distance_m))
    return fail("auc_max_distance_m must be a positive distance (m)");
  if (!(accuracy_threshold_m > 0) || !std::isfinite(accuracy_threshold_m))
    return fail("accuracy_threshold_m must be a positive distance (m)");
  if (!(min_visible_fraction >= 0 && min_visible_fraction <= 1))
    return fail("min_visible_fraction must be in [0, 1]");
  return true;
}

double add_distance(const std::vector<Vec3>& points_obj, const SE3& T_cam_obj_gt,
                    const SE3& T_cam_obj_est) {
  if (points_obj.empty()) throw std::invalid_argument("add_distance: empty point set");
  double sum = 0;
  for (const Vec3& x : points_obj) sum += (T_cam_obj_est * x - T_cam_obj_gt * x).norm();
  return sum / static_cast<double>(points_obj.size());
}

double adds_distance(const ModelPoints& model, const SE3& T_cam_obj_gt, const SE3& T_cam_obj_est) {
  // min_y ||(R x + t) - (R' y + t')|| = min_y ||R'^T (R x + t - t') - y||: query in the estimated
  // object's frame, so one tree per model serves every pose.
  const SE3 T_est_gt = T_cam_obj_est.inverse() * T_cam_obj_gt;
  double sum = 0;
  for (const Vec3& x : model.points()) sum += model.closest_distance(T_est_gt * x);
  return sum / static_cast<double>(model.points().size());
}

double adds_distance_brute_force(const std::vector<Vec3>& points_obj, const SE3& T_cam_obj_gt,
                                 const SE3& T_cam_obj_est) {
  if (points_obj.empty()) throw std::invalid_argument("adds_distance: empty point set");
  std::vector<Vec3> est_cam;
  for (const Vec3& y : points_obj) est_cam.push_back(T_cam_obj_est * y);
  double sum = 0;
  for (const Vec3& x : points_obj) {
    const Vec3 q = T_cam_obj_gt * x;
    double best = kInf;
    for (const Vec3& p : est_cam) best = std::min(best, (q - p).norm());
    sum += best;
  }
  return sum / static_cast<double>(points_obj.size());
}

double ycb_auc_percent(const std::vector<double>& distances_m, double max_distance_m) {
  // The YCB-Video toolbox's evaluation, step by step (evaluate_poses_keyframe.m + VOCap.m).
  const size_t n = distances_m.size();
  if (n == 0) return 0.0;
  std::vector<double> d = distances_m;
  for (double& x : d)
    if (!(x <= max_distance_m)) x = kInf;  // above the maximum, a miss (inf) or NaN
  std::sort(d.begin(), d.end());
  std::vector<double> mrec{0.0}, mpre{0.0};
  for (size_t k = 0; k < n; ++k) {
    if (!std::isfinite(d[k])) break;  // sorted: the rest are inf
    mrec.push_back(d[k]);
    mpre.push_back(static_cast<double>(k + 1) / static_cast<double>(n));
  }
  if (mrec.size() == 1) return 0.0;  // no finite distance (the toolbox's VOCap has no rec(end))
  mrec.push_back(max_distance_m);
  mpre.push_back(mpre.back());
  for (size_t i = 1; i < mpre.size(); ++i) mpre[i] = std::max(mpre[i], mpre[i - 1]);
  double area = 0;
  for (size_t i = 1; i < mrec.size(); ++i)
    if (mrec[i] != mrec[i - 1]) area += (mrec[i] - mrec[i - 1]) * mpre[i];
  return area * (1.0 / max_distance_m) * 100.0;
}

double fraction_below(const std::vector<double>& distances_m, double threshold_m) {
  if (distances_m.empty()) return 0.0;
  const auto below = std::count_if(distances_m.begin(), distances_m.end(),
                                   [&](double d) { return d < threshold_m; });
  return static_cast<double>(below) / static_cast<double>(distances_m.size());
}

namespace {

PoseClassSummary summarize(const std::vector<const PoseInstanceScore*>& scores,
                           const PoseMetricsParams& params) {
  PoseClassSummary s;
  std::vector<double> adds, add_s, add;
  double adds_sum = 0;
  for (const PoseInstanceScore* p : scores) {
    const double a = p->estimated ? p->adds_m : kInf;
    const double b = p->estimated ? p->add_or_adds_m() : kInf;
    const double c = p->estimated ? p->add_m : kInf;
    adds.push_back(a);
    add_s.push_back(b);
    add.push_back(c);
    if (p->estimated) {
      ++s.estimated;
      adds_sum += p->adds_m;
    }
  }
  s.instances = scores.size();
  s.adds_auc = ycb_auc_percent(adds, params.auc_max_distance_m);
  s.add_s_auc = ycb_auc_percent(add_s, params.auc_max_distance_m);
  s.add_auc = ycb_auc_percent(add, params.auc_max_distance_m);
  s.adds_below = fraction_below(adds, params.accuracy_threshold_m);
  s.add_s_below = fraction_below(add_s, params.accuracy_threshold_m);
  s.adds_mean_m = s.estimated ? adds_sum / static_cast<double>(s.estimated) : 0.0;
  return s;
}

}  // namespace

PoseEvaluation summarize_pose_scores(std::vector<PoseInstanceScore> instances,
                                     const std::map<int, std::string>& class_names,
                                     const PoseMetricsParams& params) {
  std::string why;
  if (!params.IsValid(&why)) throw ConfigError("pose metrics: " + why);
  PoseEvaluation ev;
  ev.params = params;
  ev.instances = std::move(instances);
  std::map<int, std::vector<const PoseInstanceScore*>> by_class;
  std::vector<const PoseInstanceScore*> all;
  for (const auto& p : ev.instances) {
    by_class[p.class_id].push_back(&p);
    all.push_back(&p);
  }
  for (const auto& [class_id, scores] : by_class) {
    PoseClassSummary s = summarize(scores, params);
    s.class_id = class_id;
    const auto it = class_names.find(class_id);
    s.name = it != class_names.end() ? it->second : fmt::format("class_{}", class_id);
    s.symmetric = scores.front()->symmetric;
    ev.classes.push_back(s);
  }
  ev.all = summarize(all, params);
  ev.all.class_id = -1;
  ev.all.name = "ALL";
  return ev;
}

PoseEvaluation evaluate_pose_results(const std::vector<PoseGroundTruthInstance>& ground_truth,
                                     const std::vector<PoseResultRow>& rows,
                                     const std::map<int, ModelPoints>& models,
                                     const std::vector<int>& symmetric_classes,
                                     const std::map<int, std::string>& class_names,
                                     const PoseMetricsParams& params) {
  using Key = std::tuple<int, int, int>;  // scene_id, im_id, class id
  std::map<Key, std::vector<size_t>> gt_by_key;
  std::set<int> gt_scenes;
  for (size_t i = 0; i < ground_truth.size(); ++i) {
    const auto& g = ground_truth[i];
    if (!models.count(g.class_id))
      throw std::invalid_argument(fmt::format("no model points for class {}", g.class_id));
    gt_by_key[{g.scene_id, g.im_id, g.class_id}].push_back(i);
    gt_scenes.insert(g.scene_id);
  }
  std::map<Key, std::vector<size_t>> rows_by_key;
  size_t unmatched = 0, other_scene = 0;
  for (size_t r = 0; r < rows.size(); ++r) {
    const Key key{rows[r].scene_id, rows[r].im_id, rows[r].obj_id};
    if (!gt_scenes.count(rows[r].scene_id))
      ++other_scene;
    else if (!gt_by_key.count(key))
      ++unmatched;
    else
      rows_by_key[key].push_back(r);
  }
  const std::set<int> symmetric(symmetric_classes.begin(), symmetric_classes.end());

  std::vector<PoseInstanceScore> scores(ground_truth.size());
  for (size_t i = 0; i < ground_truth.size(); ++i) {
    const auto& g = ground_truth[i];
    scores[i].scene_id = g.scene_id;
    scores[i].im_id = g.im_id;
    scores[i].class_id = g.class_id;
    scores[i].symmetric = symmetric.count(g.class_id) > 0;
    scores[i].add_m = scores[i].adds_m = kInf;
  }
  for (const auto& [key, gt_indices] : gt_by_key) {
    auto it = rows_by_key.find(key);
    if (it == rows_by_key.end()) continue;
    std::vector<size_t> cand = it->second;
    // Highest score first; ties by file order, so the result does not depend on sort stability.
    std::stable_sort(cand.begin(), cand.end(),
                     [&](size_t a, size_t b) { return rows[a].score > rows[b].score; });
    if (cand.size() > gt_indices.size()) cand.resize(gt_indices.size());
    const ModelPoints& model = models.at(std::get<2>(key));
    // ADD-S of every (instance, row) pair, then greedy one-to-one by smallest ADD-S.
    struct Pair {
      double adds;
      size_t gi, ri;
    };
    std::vector<Pair> pairs;
    for (size_t gi = 0; gi < gt_indices.size(); ++gi)
      for (size_t ri = 0; ri < cand.size(); ++ri)
        pairs.push_back(
            {adds_distance(model, ground_truth[gt_indices[gi]].T_cam_obj, rows[cand[ri]].T_cam_obj),
             gi, ri});
    std::stable_sort(pairs.begin(), pairs.end(),
                     [](const Pair& a, const Pair& b) { return a.adds < b.adds; });
    std::vector<char> gt_used(gt_indices.size(), 0), row_used(cand.size(), 0);
    for (const Pair& p : pairs) {
      if (gt_used[p.gi] || row_used[p.ri]) continue;
      gt_used[p.gi] = row_used[p.ri] = 1;
      PoseInstanceScore& s = scores[gt_indices[p.gi]];
      const PoseResultRow& row = rows[cand[p.ri]];
      s.estimated = true;
      s.score = row.score;
      s.adds_m = p.adds;
      s.add_m =
          add_distance(model.points(), ground_truth[gt_indices[p.gi]].T_cam_obj, row.T_cam_obj);
    }
  }
  PoseEvaluation ev = summarize_pose_scores(std::move(scores), class_names, params);
  ev.result_rows = rows.size();
  ev.unmatched_rows = unmatched;
  ev.other_scene_rows = other_scene;
  return ev;
}

FrameSet read_keyframe_list(const std::string& path) {
  FrameSet frames;
  for_each_data_line(path, "keyframe list", [&](int line_no, const std::string& line) {
    const auto first = line.find_first_not_of(" \t");
    const auto slash = line.find('/', first);
    const auto end = line.find_last_not_of(" \t");
    auto all_digits = [&](size_t a, size_t b) {
      if (a >= b) return false;
      for (size_t i = a; i < b; ++i)
        if (!std::isdigit(static_cast<unsigned char>(line[i]))) return false;
      return true;
    };
    if (slash == std::string::npos || !all_digits(first, slash) ||
        !all_digits(slash + 1, end + 1) || end + 1 - (slash + 1) > 9 || slash - first > 9)
      throw IoError(path,
                    fmt::format("line {}: expected 'video/frame' such as 0048/000001", line_no));
    const std::string where = fmt::format("line {}", line_no);
    frames.emplace(parse_int_field(line.substr(first, slash - first), path, where, 0),
                   parse_int_field(line.substr(slash + 1, end - slash), path, where, 0));
  });
  if (frames.empty()) throw IoError(path, "no keyframes listed");
  return frames;
}

PoseEvaluation evaluate_pose_results(const std::vector<const DatasetReader*>& readers,
                                     const std::vector<PoseResultRow>& rows,
                                     const PoseMetricsParams& params, const FrameSet* only_frames) {
  std::vector<PoseGroundTruthInstance> gt;
  std::map<int, std::string> model_paths, class_names;
  std::map<int, double> model_units;
  std::vector<int> symmetric;
  for (const DatasetReader* reader : readers) {
    const DatasetInfo& info = reader->info();
    // Fail before reading every frame when the layout has no object ground truth (TUM, 7-Scenes).
    if (info.model_points_paths.empty())
      throw IoError(info.root, fmt::format("the dataset ({}) has no object models, so no object "
                                           "pose ground truth to evaluate against",
                                           info.format));
    for (const auto& [c, path] : info.model_points_paths)
      if (model_paths.emplace(c, path).second) model_units[c] = info.model_units_per_m;
    class_names.insert(info.class_names.begin(), info.class_names.end());
    if (symmetric.empty()) symmetric = info.symmetric_classes;
    for (size_t i = 0; i < reader->size(); ++i) {
      const RgbdFrame frame = reader->read_annotations(i);
      if (only_frames && !only_frames->count({info.scene_id, frame.index})) continue;
      for (const auto& o : frame.objects_gt) {
        // Synthetic scenes list every instance in every frame, also those outside the view.
        if (o.visible_fraction >= 0 && o.visible_fraction < params.min_visible_fraction) continue;
        gt.push_back({info.scene_id, frame.index, o.class_id, o.T_cam_obj});
      }
    }
  }
  std::map<int, ModelPoints> models;
  for (const auto& g : gt) {
    if (models.count(g.class_id)) continue;
    const auto it = model_paths.find(g.class_id);
    if (it == model_paths.end())
      throw IoError(readers.front()->info().root,
                    fmt::format("no model points file for class {} in the dataset", g.class_id));
    // YCB points.xyz (metres) or a BOP model PLY's vertices (mm), by extension.
    models.emplace(g.class_id, ModelPoints(read_model_points(it->second, model_units[g.class_id])));
  }
  return evaluate_pose_results(gt, rows, models, symmetric, class_names, params);
}

PoseEvaluation evaluate_pose_results(const DatasetReader& reader,
                                     const std::vector<PoseResultRow>& rows,
                                     const PoseMetricsParams& params, const FrameSet* only_frames) {
  return evaluate_pose_results(std::vector<const DatasetReader*>{&reader}, rows, params,
                               only_frames);
}

std::string PoseEvaluation::report() const {
  const double thr_cm = params.accuracy_threshold_m * 100.0;
  std::string out =
      fmt::format("{:<28} {:>9} {:>9} {:>10} {:>12} {:>12}\n", "class", "instances", "estimated",
                  "ADD-S AUC", "ADD(-S) AUC", fmt::format("ADD-S<{:g}cm", thr_cm));
  auto line = [&](const PoseClassSummary& s) {
    return fmt::format("{:<28} {:>9} {:>9} {:>10} {:>12} {:>12}\n",
                       s.name + (s.symmetric ? " *" : ""), s.instances, s.estimated,
                       percent(s.adds_auc), percent(s.add_s_auc), percent(100.0 * s.adds_below));
  };
  for (const auto& c : classes) out += line(c);
  out += line(all);
  out += fmt::format(
      "AUC up to {:g} m as the YCB-Video toolbox, in percent; * = symmetric (ADD(-S) uses ADD-S).\n"
      "result rows: {} read, {} without a ground-truth instance, {} of other scenes (ignored)\n",
      params.auc_max_distance_m, result_rows, unmatched_rows, other_scene_rows);
  return out;
}

std::string PoseEvaluation::markdown() const {
  const double thr_cm = params.accuracy_threshold_m * 100.0;
  std::string out = fmt::format(
      "| class | instances | estimated | ADD-S AUC | ADD(-S) AUC | ADD-S < {:g} cm (%) |\n"
      "| --- | ---: | ---: | ---: | ---: | ---: |\n",
      thr_cm);
  auto line = [&](const PoseClassSummary& s, bool bold) {
    const std::string b = bold ? "**" : "";
    return fmt::format("| {}{}{}{} | {} | {} | {}{}{} | {}{}{} | {}{}{} |\n", b, s.name,
                       s.symmetric ? " \\*" : "", b, s.instances, s.estimated, b,
                       percent(s.adds_auc), b, b, percent(s.add_s_auc), b, b,
                       percent(100.0 * s.adds_below), b);
  };
  for (const auto& c : classes) out += line(c, false);
  out += line(all, true);
  return out;
}

std::string PoseEvaluation::to_json() const {
  nlohmann::json j;
  j["auc_max_distance_m"] = params.auc_max_distance_m;
  j["accuracy_threshold_m"] = params.accuracy_threshold_m;
  j["classes"] = nlohmann::json::array();
  for (const auto& c : classes) j["classes"].push_back(summary_json(c));
  j["all"] = summary_json(all);
  j["result_rows"] = result_rows;
  j["unmatched_rows"] = unmatched_rows;
  j["other_scene_rows"] = other_scene_rows;
  // Per instance, so that runs over several scenes can be pooled later; misses have null distances.
  j["instances"] = nlohmann::json::array();
  for (const auto& p : instances) {
    nlohmann::json i = {{"scene_id", p.scene_id},
                        {"im_id", p.im_id},
                        {"class_id", p.class_id},
                        {"estimated", p.estimated}};
    i["score"] = p.estimated ? nlohmann::json(p.score) : nlohmann::json(nullptr);
    i["add_m"] = p.estimated ? nlohmann::json(p.add_m) : nlohmann::json(nullptr);
    i["adds_m"] = p.estimated ? nlohmann::json(p.adds_m) : nlohmann::json(nullptr);
    j["instances"].push_back(i);
  }
  return j.dump(2);
}

}  // namespace orpe
