#include "orpe/pipeline/pipeline_params.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "orpe/core/error.h"

namespace orpe {
namespace {

struct NamedAblation {
  const char* name;
  bool mask, depth, color, ekf;
};
constexpr std::array<NamedAblation, 5> kAblations = {{
    {"DF", false, false, false, false},
    {"DF-PM", true, false, false, false},
    {"DF-PM-PD", true, true, false, false},
    {"DF-PM-PD-PC", true, true, true, false},
    {"Object-RPE", true, true, true, true},
}};

}  // namespace

int PipelineParams::min_pose_mask_px_for(int width, int height) const {
  if (min_pose_mask_px > 0) return min_pose_mask_px;
  constexpr double kPixels = 200, kReferenceArea = 640.0 * 480.0;
  const double area = static_cast<double>(std::max(width, 0)) * std::max(height, 0);
  return std::max(1, static_cast<int>(std::lround(kPixels * std::min(1.0, area / kReferenceArea))));
}

bool PipelineParams::IsValid(std::string* why) const {
  auto fail = [&](const char* reason) {
    if (why) *why = reason;
    return false;
  };
  if (pose_every_n_keyframes < 1) return fail("pose_every_n_keyframes must be >= 1");
  if (min_pose_mask_px < 0) return fail("min_pose_mask_px must be >= 0 (0 = auto)");
  if (ekf_report_min_mask_px < 0) return fail("ekf_report_min_mask_px must be >= 0");
  if (min_instance_detections < 0) return fail("min_instance_detections must be >= 0");
  if (!(min_class_probability >= 0 && min_class_probability <= 1))
    return fail("min_class_probability must be in [0, 1]");
  if (!(output_min_confidence >= 0)) return fail("output_min_confidence must be >= 0");
  if (ekf_symmetry != "geometric" && ekf_symmetry != "dataset" && ekf_symmetry != "none")
    return fail("ekf_symmetry must be geometric, dataset or none");
  if (ekf_init_views < 1) return fail("ekf_init_views must be >= 1");
  if (skip_min_fused_views < 0) return fail("skip_min_fused_views must be >= 0");
  if (!(skip_max_translation_m >= 0) || !(skip_max_rotation_deg >= 0))
    return fail("skip_max_translation_m and skip_max_rotation_deg must be >= 0");
  if (skip_max_consecutive < 0) return fail("skip_max_consecutive must be >= 0");
  if (prior_max_consecutive < 0) return fail("prior_max_consecutive must be >= 0");
  if (prior_max_consecutive_limit < 0) return fail("prior_max_consecutive_limit must be >= 0");
  if (!(prior_mode_weight >= 0 && prior_mode_weight <= 10))
    return fail("prior_mode_weight must be in [0, 10]");
  if (segmentation_delay_frames < 0 || segmentation_delay_frames > 1000)
    return fail("segmentation_delay_frames must be in [0, 1000]");
  if (render_margin_px < 0 || render_margin_px > 10000)
    return fail("render_margin_px must be in [0, 10000]");
  if (progress_every_n_frames < 0) return fail("progress_every_n_frames must be >= 0");
  return true;
}

const std::vector<std::string>& PipelineParams::ablation_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const auto& a : kAblations) n.push_back(a.name);
    return n;
  }();
  return names;
}

void PipelineParams::apply_ablation(const std::string& name) {
  for (const auto& a : kAblations)
    if (name == a.name) {
      use_projected_mask = a.mask;
      use_projected_depth = a.depth;
      use_projected_color = a.color;
      use_ekf = a.ekf;
      return;
    }
  std::string list;
  for (const auto& a : kAblations) list += std::string(list.empty() ? "" : ", ") + a.name;
  throw ConfigError("unknown ablation '" + name + "' (expected one of " + list + ")");
}

std::string PipelineParams::ablation_name() const {
  for (const auto& a : kAblations)
    if (use_projected_mask == a.mask && use_projected_depth == a.depth &&
        use_projected_color == a.color && use_ekf == a.ekf)
      return a.name;
  return "custom";
}

}  // namespace orpe
