#include "orpe/eval/mask_metrics.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <tuple>

#include "orpe/core/error.h"

namespace orpe {
namespace {

int class_of(const LabelClasses& classes, std::int32_t label, const char* which) {
  const auto it = classes.find(label);
  if (it == classes.end())
    throw std::invalid_argument(fmt::format("{} label value {} has no class", which, label));
  return it->second;
}

nlohmann::json summary_json(const MaskClassSummary& s) {
  return {{"class_id", s.class_id},
          {"name", s.name},
          {"gt_instances", s.gt_instances},
          {"matched", s.matched},
          {"mean_instance_iou", s.mean_instance_iou},
          {"mean_matched_iou", s.mean_matched_iou},
          {"pixel_iou", s.pixel_iou},
          {"true_positive_px", s.pixels.true_positive},
          {"false_positive_px", s.pixels.false_positive},
          {"false_negative_px", s.pixels.false_negative}};
}

}  // namespace

bool MaskMetricsParams::IsValid(std::string* why) const {
  if (!(min_match_iou >= 0 && min_match_iou < 1)) {
    if (why) *why = "min_match_iou must be in [0, 1)";
    return false;
  }
  if (min_gt_area_px < 0) {
    if (why) *why = "min_gt_area_px must be >= 0";
    return false;
  }
  return true;
}

double PixelCounts::iou() const {
  const size_t uni = true_positive + false_positive + false_negative;
  return uni ? static_cast<double>(true_positive) / static_cast<double>(uni) : 0.0;
}

MaskFrameResult evaluate_instance_masks(const LabelImage& gt_labels, const LabelClasses& gt_classes,
                                        const LabelImage& pred_labels,
                                        const LabelClasses& pred_classes,
                                        const MaskMetricsParams& params) {
  std::string why;
  if (!params.IsValid(&why)) throw ConfigError("mask metrics: " + why);
  if (gt_labels.width() != pred_labels.width() || gt_labels.height() != pred_labels.height())
    throw std::invalid_argument(fmt::format(
        "mask metrics: ground truth is {}x{} but the prediction is {}x{}", gt_labels.width(),
        gt_labels.height(), pred_labels.width(), pred_labels.height()));
  std::map<std::int32_t, size_t> gt_area, pred_area;
  std::map<std::pair<std::int32_t, std::int32_t>, size_t> overlap;
  MaskFrameResult result;
  for (size_t i = 0; i < gt_labels.size(); ++i) {
    const std::int32_t g = gt_labels[i] > 0 ? gt_labels[i] : 0;
    const std::int32_t p = pred_labels[i] > 0 ? pred_labels[i] : 0;
    if (g) ++gt_area[g];
    if (p) ++pred_area[p];
    if (g && p) ++overlap[{g, p}];
  }
  // Pixel counts per class, from the areas (one pass above; classes looked up once per label).
  for (const auto& [g, area] : gt_area)
    result.class_pixels[class_of(gt_classes, g, "ground-truth")];
  for (const auto& [p, area] : pred_area)
    result.class_pixels[class_of(pred_classes, p, "predicted")];
  std::map<int, size_t> gt_class_area, pred_class_area, same_class_overlap;
  for (const auto& [g, area] : gt_area) gt_class_area[gt_classes.at(g)] += area;
  for (const auto& [p, area] : pred_area) pred_class_area[pred_classes.at(p)] += area;
  for (const auto& [gp, count] : overlap) {
    const int c = gt_classes.at(gp.first);
    if (c == pred_classes.at(gp.second)) same_class_overlap[c] += count;
  }
  for (auto& [c, counts] : result.class_pixels) {
    counts.true_positive = same_class_overlap[c];
    counts.false_negative = gt_class_area[c] - counts.true_positive;
    counts.false_positive = pred_class_area[c] - counts.true_positive;
  }

  // Instance matching.
  struct Candidate {
    double iou;
    std::int32_t g, p;
  };
  std::vector<Candidate> candidates;
  for (const auto& [gp, count] : overlap) {
    const auto [g, p] = gp;
    if (!params.class_agnostic_matching && gt_classes.at(g) != pred_classes.at(p)) continue;
    const double iou =
        static_cast<double>(count) / static_cast<double>(gt_area[g] + pred_area[p] - count);
    if (iou > params.min_match_iou) candidates.push_back({iou, g, p});
  }
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
    return std::make_tuple(-a.iou, a.g, a.p) < std::make_tuple(-b.iou, b.g, b.p);
  });
  std::map<std::int32_t, const Candidate*> match_of_gt;
  std::map<std::int32_t, bool> pred_used;
  for (const auto& c : candidates) {
    if (match_of_gt.count(c.g) || pred_used[c.p]) continue;
    match_of_gt[c.g] = &c;
    pred_used[c.p] = true;
  }
  double sum = 0;
  for (const auto& [g, area] : gt_area) {
    if (area < static_cast<size_t>(params.min_gt_area_px)) continue;
    MaskInstanceIoU inst;
    inst.class_id = gt_classes.at(g);
    inst.gt_label = g;
    inst.gt_pixels = area;
    if (const auto it = match_of_gt.find(g); it != match_of_gt.end()) {
      inst.pred_label = it->second->p;
      inst.iou = it->second->iou;
    }
    sum += inst.iou;
    result.instances.push_back(inst);
  }
  // A prediction matched to an unscored (tiny) object is neither scored nor a false positive.
  result.false_positive_instances = pred_area.size() - match_of_gt.size();
  result.mean_iou =
      result.instances.empty() ? 0.0 : sum / static_cast<double>(result.instances.size());
  return result;
}

MaskEvaluator::MaskEvaluator(const MaskMetricsParams& params) : params_(params) {
  std::string why;
  if (!params_.IsValid(&why)) throw ConfigError("mask metrics: " + why);
}

const MaskFrameResult& MaskEvaluator::add_frame(const LabelImage& gt_labels,
                                                const LabelClasses& gt_classes,
                                                const LabelImage& pred_labels,
                                                const LabelClasses& pred_classes) {
  frames_.push_back(
      evaluate_instance_masks(gt_labels, gt_classes, pred_labels, pred_classes, params_));
  return frames_.back();
}

MaskEvaluation MaskEvaluator::summary(const std::map<int, std::string>& class_names) const {
  MaskEvaluation ev;
  ev.frames = frames_.size();
  std::map<int, MaskClassSummary> by_class;
  std::map<int, double> iou_sum;
  double all_sum = 0;
  for (const auto& f : frames_) {
    ev.false_positive_instances += f.false_positive_instances;
    ev.frame_mean_iou.push_back(f.mean_iou);
    for (const auto& inst : f.instances) {
      MaskClassSummary& s = by_class[inst.class_id];
      ++s.gt_instances;
      if (inst.pred_label) ++s.matched;
      iou_sum[inst.class_id] += inst.iou;
      all_sum += inst.iou;
      ++ev.all.gt_instances;
      if (inst.pred_label) ++ev.all.matched;
    }
    for (const auto& [c, counts] : f.class_pixels) {
      PixelCounts& acc = by_class[c].pixels;
      acc.true_positive += counts.true_positive;
      acc.false_positive += counts.false_positive;
      acc.false_negative += counts.false_negative;
      ev.all.pixels.true_positive += counts.true_positive;
      ev.all.pixels.false_positive += counts.false_positive;
      ev.all.pixels.false_negative += counts.false_negative;
    }
  }
  double miou_sum = 0;
  for (auto& [c, s] : by_class) {
    s.class_id = c;
    const auto it = class_names.find(c);
    s.name = it != class_names.end() ? it->second : fmt::format("class_{}", c);
    s.mean_instance_iou = s.gt_instances ? iou_sum[c] / static_cast<double>(s.gt_instances) : 0.0;
    s.mean_matched_iou = s.matched ? iou_sum[c] / static_cast<double>(s.matched) : 0.0;
    s.pixel_iou = s.pixels.iou();
    miou_sum += s.pixel_iou;
    ev.classes.push_back(s);
  }
  ev.all.class_id = -1;
  ev.all.name = "ALL";
  ev.all.mean_instance_iou =
      ev.all.gt_instances ? all_sum / static_cast<double>(ev.all.gt_instances) : 0.0;
  ev.all.mean_matched_iou =
      ev.all.matched ? all_sum / static_cast<double>(ev.all.matched) : 0.0;
  ev.all.pixel_iou = ev.all.pixels.iou();
  ev.mean_class_pixel_iou =
      ev.classes.empty() ? 0.0 : miou_sum / static_cast<double>(ev.classes.size());
  return ev;
}

std::string MaskEvaluation::report() const {
  std::string out = fmt::format("{:<28} {:>9} {:>8} {:>13} {:>12} {:>10}\n", "class",
                                "instances", "matched", "instance IoU", "matched IoU", "pixel IoU");
  auto line = [&](const MaskClassSummary& s) {
    return fmt::format("{:<28} {:>9} {:>8} {:>13.4f} {:>12.4f} {:>10.4f}\n", s.name,
                       s.gt_instances, s.matched, s.mean_instance_iou, s.mean_matched_iou,
                       s.pixel_iou);
  };
  for (const auto& c : classes) out += line(c);
  out += line(all);
  out += fmt::format(
      "frames: {}, false-positive instances: {}, mIoU (mean of class pixel IoU): {:.4f}\n", frames,
      false_positive_instances, mean_class_pixel_iou);
  return out;
}

std::string MaskEvaluation::to_json() const {
  nlohmann::json j;
  j["frames"] = frames;
  j["false_positive_instances"] = false_positive_instances;
  j["mean_class_pixel_iou"] = mean_class_pixel_iou;
  j["classes"] = nlohmann::json::array();
  for (const auto& c : classes) j["classes"].push_back(summary_json(c));
  j["all"] = summary_json(all);
  j["frame_mean_iou"] = frame_mean_iou;
  return j.dump(2);
}

}  // namespace orpe
