// Parameters of `orpe synth` (config section "synth"). Light header: no Eigen/OpenCV.
#pragma once

#include <string>

namespace orpe {

struct SynthParams {
  int seed = 1;
  int frames = 300;
  int objects = 10;
  std::string scene = "floor";
  std::string models;  // comma-separated OBJ/PLY files or folders; empty = built-in warehouse set
  double model_unit_m = 0;  // metres per model-file unit; 0 = guess
  bool repeat_types = false;
  int distractors = 0;               // boxes and cylinders outside the model set (not targets)
  std::string symmetries = "shape";  // models_info.json symmetries: shape | appearance
  int width = 640;
  int height = 480;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  double fps = 30;
  std::string trajectory = "arc";  // arc | loop
  double loop_overlap_deg = 30;
  double loop_radius_m = 0;
  double span_deg = 140;
  double baseline_m = 0;
  double distance_m = 0;
  double elevation_deg = 0;
  double shake_m = 0.002;
  double shake_deg = 0.3;
  bool noise = true;
  double depth_min_m = 0.4;
  double depth_max_m = 4.5;
  double depth_noise_scale = 1.0;
  double color_noise_sigma = 2.0;
  double illumination_variation = 0.08;
  double stack_probability = 0.3;
  int model_points = 2620;
  bool write_masks = true;
  int preview_stride = 100;
  int threads = 0;

  template <class V>
  void visit(V&& v) {
    v("seed", seed, "Random seed: the same seed and parameters give byte-identical output");
    v("frames", frames, "Number of frames (30 Hz)");
    v("objects", objects, "Number of object instances placed in the scene");
    v("scene", scene,
      "Environment: floor | table | shelf | room (a 6 x 6 m room with a 3 m rack on each wall)");
    v("models", models,
      "Comma-separated OBJ/PLY files or folders (YCB layout <class>/textured_simple.obj); empty = "
      "built-in "
      "warehouse set");
    v("model_unit_m", model_unit_m,
      "Metres per model-file unit (0.001 for mm); 0 = guess from the model size");
    v("repeat_types", repeat_types,
      "Allow several instances of one object type (same obj_id); default: each instance its own "
      "type");
    v("distractors", distractors,
      "Distractors: plain-coloured boxes and cylinders of sizes unlike the objects', placed "
      "among them but not targets (not in scene_gt.json, models/, masks; see "
      "scene_gt_distractors.json); 0 = none, the scene is then the same as without the option");
    v("symmetries", symmetries,
      "Symmetries written to models_info.json (and so scored with ADD-S): shape = of the geometry "
      "(a printed box is symmetric) | appearance = only those that also map the print onto itself "
      "(a box whose front and back labels differ is not symmetric; ADD(-S) then scores its "
      "rotation)");
    v("width", width, "Image width (pixels)");
    v("height", height, "Image height (pixels)");
    v("fx", fx, "Focal length x (pixels); 0 = 580 * width / 640 (Xtion-like)");
    v("fy", fy, "Focal length y (pixels); 0 = fx");
    v("cx", cx, "Principal point x (pixels); 0 = (width - 1) / 2");
    v("cy", cy, "Principal point y (pixels); 0 = (height - 1) / 2");
    v("fps", fps, "Frame rate (Hz) of the timestamps and the hand-held motion");
    v("trajectory", trajectory,
      "Camera path: arc = hand-held arc around the scene (span_deg) | loop = a closed circle "
      "(room: inside the room looking out at the racks; other scenes: around them looking in) "
      "that returns to its start and goes on for loop_overlap_deg, over the first frames' path");
    v("loop_overlap_deg", loop_overlap_deg,
      "trajectory=loop: degrees travelled past 360, over the start of the path again (the "
      "revisit)");
    v("loop_radius_m", loop_radius_m,
      "trajectory=loop: mean radius of the camera's circle (m); 0 = room 0.9, other scenes the "
      "automatic camera distance");
    v("span_deg", span_deg,
      "Azimuth swept by the camera around the scene (deg); shelf scenes cap it at 110");
    v("baseline_m", baseline_m,
      "If > 0: distance between the first and last camera (m); overrides span_deg");
    v("distance_m", distance_m,
      "Mean camera distance to the scene centre (m); 0 = fit the scene in view");
    v("elevation_deg", elevation_deg,
      "Mean camera elevation seen from the scene (deg); 0 = per scene (floor 38, table 40, shelf "
      "15)");
    v("shake_m", shake_m, "Hand-shake amplitude, translation (m)");
    v("shake_deg", shake_deg, "Hand-shake amplitude, rotation (deg)");
    v("noise", noise,
      "Structured-light depth noise and colour noise; off = exact rendered depth and colour");
    v("depth_min_m", depth_min_m, "Sensor range: nearer depth is missing (m)");
    v("depth_max_m", depth_max_m,
      "Sensor range: farther depth is missing (m); <= 6.5 (16-bit PNG at 0.1 mm)");
    v("depth_noise_scale", depth_noise_scale,
      "Multiplies the axial noise sigma(z) of Nguyen et al.");
    v("color_noise_sigma", color_noise_sigma, "Colour noise, Gaussian sigma in 8-bit levels");
    v("illumination_variation", illumination_variation,
      "Relative amplitude of the slow brightness drift");
    v("stack_probability", stack_probability,
      "Chance that an object is placed on top of another object");
    v("model_points", model_points,
      "Points sampled on each model surface for models/obj_*_points.xyz");
    v("write_masks", write_masks, "Write mask/ and mask_visib/ PNGs per object and frame");
    v("preview_stride", preview_stride,
      "Write preview/NNNNNN.png every this many frames; 0 = none");
    v("threads", threads, "Threads generating frames; 0 = OpenMP default");
  }
  bool IsValid(std::string* why) const;
};

}  // namespace orpe
