#include "orpe/eval/bop_pose_metrics.h"

#include <fmt/format.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numeric>
#include <optional>
#include <tuple>

#include "orpe/core/error.h"
#include "orpe/eval/bop_pose_errors.h"
#include "orpe/io/dataset.h"
#include "orpe/io/model_io.h"
#include "orpe/render/mesh_io.h"

namespace orpe {
namespace fs = std::filesystem;
namespace {

std::vector<double> steps(double first, double last, double step) {
  std::vector<double> v;
  for (int i = 0; first + i * step <= last + 1e-9; ++i) v.push_back(first + i * step);
  return v;
}

using ImageObject = std::tuple<int, int, int>;  // scene_id, im_id, obj_id

/// Matched targets for one correctness test: `correct(estimate, gt_index, errors)` tells whether
/// the error is below the threshold and `value` orders the candidates (smaller is better).
template <class Value>
size_t count_matches(const std::map<ImageObject, std::vector<const BopTarget*>>& targets,
                     const std::map<ImageObject, std::vector<const BopEstimate*>>& estimates,
                     double threshold, Value value) {
  size_t matched = 0;
  for (const auto& [key, ests] : estimates) {
    const auto t = targets.find(key);
    if (t == targets.end()) continue;
    std::vector<bool> taken(t->second.size(), false);
    for (const BopEstimate* e : ests) {  // by decreasing score
      int best = -1;
      double best_value = threshold;
      for (size_t k = 0; k < t->second.size(); ++k) {
        const BopTarget& g = *t->second[k];
        const auto err = e->errors.find(g.gt_index);
        if (!g.valid || taken[k] || err == e->errors.end()) continue;
        const double v = value(*e, err->second);
        if (v < best_value) best = static_cast<int>(k), best_value = v;
      }
      if (best >= 0) taken[best] = true, ++matched;
    }
  }
  return matched;
}

double mean(const std::vector<double>& v) {
  return v.empty() ? 0.0 : std::accumulate(v.begin(), v.end(), 0.0) / v.size();
}

}  // namespace

bool BopPoseMetricsParams::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (!(vsd_delta_m > 0) || !std::isfinite(vsd_delta_m))
    return fail("vsd_delta_m must be a positive distance (m)");
  if (!(min_visible_fraction >= 0 && min_visible_fraction <= 1))
    return fail("min_visible_fraction must be in [0, 1]");
  if (!(max_sym_disc_step > 0.0001 && max_sym_disc_step <= 1))
    return fail("max_sym_disc_step must be in (0.0001, 1]");
  if (threads < 0) return fail("threads must be >= 0");
  return true;
}

const std::vector<double>& bop_vsd_taus() {
  static const std::vector<double> v = steps(0.05, 0.5, 0.05);
  return v;
}
const std::vector<double>& bop_fraction_thresholds() {
  static const std::vector<double> v = steps(0.05, 0.5, 0.05);
  return v;
}
const std::vector<double>& bop_mspd_thresholds_px() {
  static const std::vector<double> v = steps(5, 50, 5);
  return v;
}

BopRecalls bop_recalls(const std::vector<BopTarget>& targets,
                       const std::vector<BopEstimate>& estimates,
                       const std::map<int, double>& diameters_m,
                       const std::map<int, int>& image_width_px) {
  std::map<ImageObject, std::vector<const BopTarget*>> by_image;
  size_t n_targets = 0;
  for (const auto& t : targets) {
    by_image[{t.scene_id, t.im_id, t.obj_id}].push_back(&t);
    n_targets += t.valid;
  }
  std::map<ImageObject, std::vector<const BopEstimate*>> ests;
  for (const auto& e : estimates) ests[{e.scene_id, e.im_id, e.obj_id}].push_back(&e);
  for (auto& [key, list] : ests)
    std::stable_sort(list.begin(), list.end(),
                     [](const auto* a, const auto* b) { return a->score > b->score; });
  auto recall = [&](size_t matched) {
    return n_targets > 0 ? static_cast<double>(matched) / n_targets : 0.0;
  };
  auto diameter = [&](int obj) { return diameters_m.at(obj); };
  BopRecalls r;
  for (size_t ti = 0; ti < bop_vsd_taus().size(); ++ti)
    for (double th : bop_fraction_thresholds())
      r.vsd.push_back(recall(count_matches(
          by_image, ests, th, [&](const auto&, const auto& e) { return e.vsd.at(ti); })));
  for (double th : bop_fraction_thresholds())
    r.mssd.push_back(recall(count_matches(by_image, ests, th, [&](const auto& est, const auto& e) {
      return e.mssd_m / diameter(est.obj_id);
    })));
  for (double th : bop_mspd_thresholds_px())
    r.mspd.push_back(recall(count_matches(by_image, ests, th, [&](const auto& est, const auto& e) {
      return e.mspd_px * 640.0 / image_width_px.at(est.scene_id);
    })));
  r.ar_vsd = mean(r.vsd);
  r.ar_mssd = mean(r.mssd);
  r.ar_mspd = mean(r.mspd);
  r.ar = (r.ar_vsd + r.ar_mssd + r.ar_mspd) / 3.0;
  return r;
}

std::string BopPoseEvaluation::report() const {
  std::string out = fmt::format("{:<24} {:>8} {:>8} {:>8} {:>8} {:>8}\n", "object", "targets",
                                "AR_VSD", "AR_MSSD", "AR_MSPD", "AR");
  auto line = [&](const std::string& name, size_t n, const BopRecalls& r) {
    return fmt::format("{:<24} {:>8} {:>8.2f} {:>8.2f} {:>8.2f} {:>8.2f}\n", name, n,
                       100 * r.ar_vsd, 100 * r.ar_mssd, 100 * r.ar_mspd, 100 * r.ar);
  };
  for (const auto& [obj, r] : per_object) {
    const auto name = class_names.find(obj);
    out += line(name != class_names.end() ? name->second : std::to_string(obj),
                targets_per_object.at(obj), r);
  }
  out += line("ALL", targets, all);
  out += fmt::format(
      "BOP 2019-2023 average recall in percent (VSD delta {:g} mm, taus and thresholds of "
      "bop_toolkit); targets: {}; {} estimates kept of {} result rows\n",
      params.vsd_delta_m * 1000, targets_source, estimates, result_rows);
  return out;
}

std::string BopPoseEvaluation::to_json() const {
  auto recalls = [](const BopRecalls& r) {
    return nlohmann::json{{"ar", r.ar},
                          {"ar_vsd", r.ar_vsd},
                          {"ar_mssd", r.ar_mssd},
                          {"ar_mspd", r.ar_mspd},
                          {"recalls_vsd", r.vsd},
                          {"recalls_mssd", r.mssd},
                          {"recalls_mspd", r.mspd}};
  };
  nlohmann::json j = recalls(all);
  j["targets"] = targets;
  j["estimates"] = estimates;
  j["result_rows"] = result_rows;
  j["targets_source"] = targets_source;
  j["vsd_delta_m"] = params.vsd_delta_m;
  j["vsd_taus"] = bop_vsd_taus();
  j["thresholds_vsd_mssd"] = bop_fraction_thresholds();
  j["thresholds_mspd_px"] = bop_mspd_thresholds_px();
  j["objects"] = nlohmann::json::array();
  for (const auto& [obj, r] : per_object) {
    nlohmann::json o = recalls(r);
    o["obj_id"] = obj;
    o["targets"] = targets_per_object.at(obj);
    j["objects"].push_back(o);
  }
  return j.dump(2);
}

}  // namespace orpe
