#include "orpe/synth/synth_params.h"

namespace orpe {

bool SynthParams::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (frames < 1 || frames > 1000000) return fail("frames must be in 1..1000000");
  if (objects < 1 || objects > 500) return fail("objects must be in 1..500");
  if (scene != "floor" && scene != "table" && scene != "shelf" && scene != "room")
    return fail("scene must be floor, table, shelf or room (got '" + scene + "')");
  if (trajectory != "arc" && trajectory != "loop")
    return fail("trajectory must be arc or loop (got '" + trajectory + "')");
  if (!(loop_overlap_deg >= 0 && loop_overlap_deg <= 360))
    return fail("loop_overlap_deg must be in [0, 360]");
  if (!(loop_radius_m >= 0 && loop_radius_m <= 5.0))
    return fail("loop_radius_m must be in [0, 5] m (0 = automatic)");
  if (scene == "room" && trajectory != "loop")
    return fail(
        "the room scene needs trajectory=loop (--trajectory loop): an arc around it would "
        "put the camera inside its walls");
  if (scene == "room" && loop_radius_m > 1.3)
    return fail(
        "room: loop_radius_m must be <= 1.3 m (the racks' fronts are 2.05 m from the centre)");
  if (symmetries != "shape" && symmetries != "appearance")
    return fail("symmetries must be shape or appearance (got '" + symmetries + "')");
  if (distractors < 0 || distractors > 200) return fail("distractors must be in 0..200");
  if (model_unit_m < 0) return fail("model_unit_m must be >= 0 (0 = guess)");
  if (width < 16 || height < 16 || width > 8192 || height > 8192)
    return fail("width and height must be in 16..8192");
  if (fx < 0 || fy < 0 || cx < 0 || cy < 0)
    return fail("fx, fy, cx, cy must be >= 0 (0 = default)");
  if (!(fps > 0)) return fail("fps must be > 0");
  if (span_deg < 0 || span_deg > 360) return fail("span_deg must be in [0, 360]");
  if (baseline_m < 0 || distance_m < 0) return fail("baseline_m and distance_m must be >= 0");
  if (elevation_deg < 0 || elevation_deg > 85)
    return fail("elevation_deg must be in [0, 85] (0 = per scene)");
  if (shake_m < 0 || shake_deg < 0) return fail("shake_m and shake_deg must be >= 0");
  if (!(depth_min_m >= 0) || !(depth_max_m > depth_min_m) || depth_max_m > 6.5)
    return fail("need 0 <= depth_min_m < depth_max_m <= 6.5");
  if (depth_noise_scale < 0 || color_noise_sigma < 0) return fail("noise scales must be >= 0");
  if (illumination_variation < 0 || illumination_variation > 0.5)
    return fail("illumination_variation must be in [0, 0.5]");
  if (stack_probability < 0 || stack_probability > 1)
    return fail("stack_probability must be in [0, 1]");
  if (model_points < 1 || model_points > 1000000) return fail("model_points must be in 1..1000000");
  if (preview_stride < 0 || threads < 0) return fail("preview_stride and threads must be >= 0");
  return true;
}

}  // namespace orpe
