#include "orpe/semantic/mask_eval.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <algorithm>
#include <nlohmann/json.hpp>
#include <tuple>

namespace orpe {

std::vector<int> match_by_iou(const std::vector<std::vector<long>>& intersections,
                              const std::vector<long>& row_areas,
                              const std::vector<long>& column_areas, std::vector<double>* row_iou) {
  struct Pair {
    double iou;
    int r, c;
  };
  std::vector<Pair> pairs;
  for (size_t r = 0; r < intersections.size(); ++r)
    for (size_t c = 0; c < intersections[r].size(); ++c) {
      const long inter = intersections[r][c];
      if (inter <= 0) continue;
      const long uni = row_areas[r] + column_areas[c] - inter;
      pairs.push_back({static_cast<double>(inter) / static_cast<double>(uni), static_cast<int>(r),
                       static_cast<int>(c)});
    }
  std::sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) {
    return std::tie(b.iou, a.r, a.c) < std::tie(a.iou, b.r, b.c);  // IoU desc, then indices asc
  });
  std::vector<int> match(intersections.size(), -1);
  std::vector<bool> used(column_areas.size(), false);
  if (row_iou) row_iou->assign(intersections.size(), 0.0);
  for (const Pair& p : pairs) {
    if (match[p.r] >= 0 || used[p.c]) continue;
    match[p.r] = p.c;
    used[p.c] = true;
    if (row_iou) (*row_iou)[p.r] = p.iou;
  }
  return match;
}

bool SemanticMaskEvaluator::add_frame(const RgbdFrame& frame,
                                      const std::vector<Detection>& detections,
                                      const LabelImage& projected,
                                      const std::map<int, InstanceInfo>& instances) {
  const LabelImage& gt = frame.labels_gt;
  if (gt.empty() || frame.objects_gt.empty()) return false;
  const int num_objects = static_cast<int>(frame.objects_gt.size());
  const size_t npix = gt.size();
  const bool have_projection = projected.width() == gt.width() && projected.height() == gt.height();
  ++frames_;

  // Rows: ground-truth objects (label k = objects_gt[k - 1]). Columns: detections / instances.
  std::vector<long> gt_area(num_objects, 0);
  for (size_t i = 0; i < npix; ++i)
    if (gt[i] > 0 && gt[i] <= num_objects) ++gt_area[gt[i] - 1];

  const int num_det = static_cast<int>(detections.size());
  std::vector<std::vector<long>> det_inter(num_objects, std::vector<long>(num_det, 0));
  std::vector<long> det_area(num_det, 0);
  for (int d = 0; d < num_det; ++d) {
    const ProbabilityImage& p = detections[d].probability;
    if (p.size() != npix) continue;
    for (size_t i = 0; i < npix; ++i) {
      if (p[i] < threshold_) continue;
      ++det_area[d];
      if (gt[i] > 0 && gt[i] <= num_objects) ++det_inter[gt[i] - 1][d];
    }
  }
  std::map<int, int> column_of;  // instance id -> column
  std::vector<int> column_instance;
  std::vector<long> inst_area;
  std::vector<std::vector<long>> inst_inter(num_objects);
  if (have_projection) {
    for (size_t i = 0; i < npix; ++i) {
      const int id = projected[i];
      if (id <= 0) continue;
      auto [it, added] = column_of.try_emplace(id, static_cast<int>(column_instance.size()));
      if (added) {
        column_instance.push_back(id);
        inst_area.push_back(0);
        for (auto& row : inst_inter) row.push_back(0);
      }
      ++inst_area[it->second];
      const int g = gt[i] > 0 && gt[i] <= num_objects ? gt[i] : 0;
      if (g > 0) ++inst_inter[g - 1][it->second];
      ++instance_overlap_[id][g > 0 ? frame.objects_gt[g - 1].instance_id : 0];
    }
  }
  std::vector<double> det_iou, inst_iou;
  const auto det_match = match_by_iou(det_inter, gt_area, det_area, &det_iou);
  const auto inst_match = match_by_iou(inst_inter, gt_area, inst_area, &inst_iou);

  for (int k = 0; k < num_objects; ++k) {
    const ObjectGroundTruth& obj = frame.objects_gt[k];
    object_class_[obj.instance_id] = obj.class_id;
    if (gt_area[k] < min_gt_area_px_) continue;
    for (Accum* a : {&per_class_[obj.class_id], &per_class_[0]}) {
      ++a->samples;
      if (det_match[k] < 0) {
        ++a->input_missed;
      } else {
        a->input_sum += det_iou[k];
        a->input_correct += detections[det_match[k]].class_id == obj.class_id;
      }
      if (inst_match[k] < 0) {
        ++a->projected_missed;
      } else {
        a->projected_sum += inst_iou[k];
        const auto it = instances.find(column_instance[inst_match[k]]);
        a->projected_correct += it != instances.end() && it->second.argmax_class() == obj.class_id;
      }
    }
  }
  return true;
}

SemanticMaskResult SemanticMaskEvaluator::result(
    const std::map<int, InstanceInfo>& final_instances) const {
  SemanticMaskResult r;
  r.frames = frames_;
  auto row = [](int class_id, const Accum& a) {
    MaskIouRow out;
    out.class_id = class_id;
    out.samples = a.samples;
    out.input_missed = a.input_missed;
    out.projected_missed = a.projected_missed;
    out.input_class_correct = a.input_correct;
    out.projected_class_correct = a.projected_correct;
    if (a.samples) {
      out.input_miou = a.input_sum / a.samples;
      out.projected_miou = a.projected_sum / a.samples;
    }
    if (a.samples - a.input_missed > 0)
      out.input_miou_matched = a.input_sum / (a.samples - a.input_missed);
    if (a.samples - a.projected_missed > 0)
      out.projected_miou_matched = a.projected_sum / (a.samples - a.projected_missed);
    return out;
  };
  for (const auto& [c, a] : per_class_) {
    if (c == 0)
      r.overall = row(0, a);
    else
      r.per_class.push_back(row(c, a));
  }
  // Instance ownership over the run (only instances that still exist).
  std::map<int, std::vector<std::pair<long, int>>> owned;  // object -> (pixels, instance)
  for (const auto& [id, overlap] : instance_overlap_) {
    if (!final_instances.count(id)) continue;
    int owner = 0;
    long best = -1;
    for (const auto& [obj, px] : overlap)
      if (px > best || (px == best && obj < owner)) {
        best = px;
        owner = obj;
      }
    if (owner == 0)
      r.spurious_instances.push_back(id);
    else
      owned[owner].push_back({best, id});
  }
  for (const auto& [obj, cls] : object_class_) {
    ObjectInstanceRow o;
    o.object_instance_id = obj;
    o.class_id = cls;
    auto it = owned.find(obj);
    if (it != owned.end()) {
      auto list = it->second;
      std::sort(list.begin(), list.end(), std::greater<>());
      for (const auto& [px, id] : list) o.instances.push_back(id);
      o.argmax_class = final_instances.at(list.front().second).argmax_class();
    }
    if (o.instances.size() == 1) {
      ++r.objects_with_exactly_one_instance;
      r.objects_with_correct_class += o.argmax_class == o.class_id;
    }
    r.objects.push_back(o);
  }
  return r;
}

std::string SemanticMaskResult::report() const {
  std::string s = fmt::format(
      "mask IoU over {} frames ({} object samples): input {:.3f} ({:.3f} matched, "
      "{} missed), map-projected {:.3f} ({:.3f} matched, {} missed)\n",
      frames, overall.samples, overall.input_miou, overall.input_miou_matched, overall.input_missed,
      overall.projected_miou, overall.projected_miou_matched, overall.projected_missed);
  s += "  class  samples  input_mIoU  projected_mIoU  input_class_ok  projected_class_ok\n";
  for (const auto& c : per_class)
    s += fmt::format("  {:5d}  {:7d}  {:10.3f}  {:14.3f}  {:14d}  {:18d}\n", c.class_id, c.samples,
                     c.input_miou, c.projected_miou, c.input_class_correct,
                     c.projected_class_correct);
  s += fmt::format(
      "instances: {} of {} objects have exactly one instance, {} with the right class; "
      "{} spurious instances\n",
      objects_with_exactly_one_instance, objects.size(), objects_with_correct_class,
      spurious_instances.size());
  for (const auto& o : objects)
    s +=
        fmt::format("  object {} (class {}): instances [{}], argmax class {}\n",
                    o.object_instance_id, o.class_id, fmt::join(o.instances, ", "), o.argmax_class);
  return s;
}

std::string SemanticMaskResult::to_json() const {
  auto row = [](const MaskIouRow& c) {
    return nlohmann::json{{"class_id", c.class_id},
                          {"samples", c.samples},
                          {"input_miou", c.input_miou},
                          {"projected_miou", c.projected_miou},
                          {"input_miou_matched", c.input_miou_matched},
                          {"projected_miou_matched", c.projected_miou_matched},
                          {"input_missed", c.input_missed},
                          {"projected_missed", c.projected_missed},
                          {"input_class_correct", c.input_class_correct},
                          {"projected_class_correct", c.projected_class_correct}};
  };
  nlohmann::json j;
  j["frames"] = frames;
  j["overall"] = row(overall);
  j["per_class"] = nlohmann::json::array();
  for (const auto& c : per_class) j["per_class"].push_back(row(c));
  j["objects"] = nlohmann::json::array();
  for (const auto& o : objects)
    j["objects"].push_back({{"object_instance_id", o.object_instance_id},
                            {"class_id", o.class_id},
                            {"instances", o.instances},
                            {"argmax_class", o.argmax_class}});
  j["spurious_instances"] = spurious_instances;
  j["objects_with_exactly_one_instance"] = objects_with_exactly_one_instance;
  j["objects_with_correct_class"] = objects_with_correct_class;
  return j.dump(2);
}

}  // namespace orpe
