// Synthetic RGB-D sequences with exact ground truth: a scene of known objects (built-in warehouse
// set or user meshes), a hand-held camera path around it, per-frame rendering and a sensor model,
// written in BOP layout (see docs/SYNTH.md).
//
// Usage:
//   SyntheticSceneGenerator gen(params);       // builds models, scene and trajectory
//   (deterministic) SynthFrame f = gen.render_frame(i);        // in memory SynthReport r =
//   gen.write_bop(dir);        // everything to disk
#pragma once

#include <memory>
#include <random>
#include <string>
#include <vector>

#include "orpe/core/camera.h"
#include "orpe/core/frame.h"
#include "orpe/core/image.h"
#include "orpe/synth/scene.h"
#include "orpe/synth/sensor.h"
#include "orpe/synth/synth_params.h"

namespace orpe::synth {

struct BopFrameRecord;

/// Per object instance and frame, as in BOP's scene_gt_info.json.
struct ObjectFrameInfo {
  int px_count_all = 0;    ///< pixels of the object's silhouette in the image (occlusions ignored)
  int px_count_visib = 0;  ///< pixels where the object is the visible surface
  int px_count_valid = 0;  ///< visible pixels with valid (sensor) depth
  double visib_fract = 0;  ///< px_count_visib / px_count_all (0 when px_count_all is 0)
  int bbox_obj[4] = {-1, -1, -1, -1};    ///< x, y, w, h of the silhouette (in-image part)
  int bbox_visib[4] = {-1, -1, -1, -1};  ///< x, y, w, h of the visible part
};

struct SynthFrame {
  int index = 0;
  double timestamp_s = 0;
  SE3 T_world_cam;
  ColorImage rgb;
  DepthImage depth;                ///< sensor depth (= depth_clean when noise is off)
  DepthImage depth_clean;          ///< exact rendered z (m)
  Image<Eigen::Vector3f> normals;  ///< camera-frame unit normals of the visible surface (0 = none)
  LabelImage instances;            ///< 0 = background, k + 1 = instance k (visible surface)
  std::vector<MaskImage> masks;    ///< per instance: amodal silhouette (0/1)
  std::vector<MaskImage> masks_visib;  ///< per instance: visible part (0/1)
  std::vector<SE3> T_cam_obj;          ///< per instance
  std::vector<ObjectFrameInfo> info;   ///< per instance
  // Distractors (objects outside the model set): rendered into rgb/depth/normals like the objects,
  // but 0 (background) in `instances`, and no masks.
  LabelImage distractor_labels;       ///< j + 1 where distractor j is the visible surface, else 0
  std::vector<SE3> T_cam_distractor;  ///< per distractor
  std::vector<ObjectFrameInfo> distractor_info;  ///< per distractor
};

struct SynthReport {
  std::string out_dir;    ///< the BOP dataset root
  std::string scene_dir;  ///< its scene folder (bop_scene_dir(out_dir))
  int frames = 0;
  int objects = 0;
  int types = 0;
  int distractors = 0;  ///< placed
  std::string scene;
  double trajectory_extent_m = 0;  ///< largest distance between two camera centres
  double arc_deg = 0;              ///< azimuth swept around the scene centre
  double mean_visib_fract = 0;     ///< over instances and frames where px_count_all > 0
  double mean_valid_depth = 0;     ///< fraction of pixels with sensor depth
  double seconds = 0;              ///< wall time of write_bop
  std::vector<std::string> warnings;
  std::string report() const;
};

class SyntheticSceneGenerator {
 public:
  /// Validates the parameters (ConfigError), loads or builds the models (IoError for bad model
  /// files), composes the scene and the camera path.
  explicit SyntheticSceneGenerator(const SynthParams& params);
  ~SyntheticSceneGenerator();

  const SynthParams& params() const { return params_; }
  const SynthScene& scene() const { return scene_; }
  const PinholeIntrinsics& intrinsics() const { return K_; }
  const std::vector<SE3>& trajectory() const {
    return T_world_cam_;
  }  ///< camera-to-world per frame
  const DepthSensorParams& sensor() const { return sensor_; }
  int num_frames() const { return static_cast<int>(T_world_cam_.size()); }

  /// Renders frame i (0 <= i < num_frames()). Thread-safe (each call uses its own rasteriser);
  /// deterministic (the frame's random stream depends on the seed and i only). `render_threads`:
  /// OpenMP threads of the rasteriser (0 = default; 1 when frames are rendered in parallel).
  SynthFrame render_frame(int i, int render_threads = 0) const;

  /// Writes the whole sequence as a BOP dataset into `dir` (created; existing files are
  /// overwritten): models/, camera.json, test_targets_bop19.json and synth_info.json at its root,
  /// the scene's images and ground truth in bop_scene_dir(dir) = dir/test/000000.
  SynthReport write_bop(const std::string& dir) const;

 private:
  // The steps of the constructor, in order (they draw from one random stream in this order).
  /// K_ from the params (or 580 px focal length at 640 px wide), and the sensor model.
  void set_up_camera();
  /// The object types (built-in classes or the given models) and the type of each instance.
  void choose_object_types(std::mt19937_64& rng, std::vector<ObjectModel>* types,
                           std::vector<int>* instance_types);
  /// scene_: the objects placed; only the types in use kept, numbered by first appearance.
  void lay_out_scene(std::vector<ObjectModel> types, const std::vector<int>& instance_types,
                     const SceneLayoutParams& layout, std::mt19937_64& rng);
  /// T_world_cam_: the hand-held arc or the loop.
  void make_camera_path(std::mt19937_64& rng);
  void add_distractors(const SceneLayoutParams& layout);
  // The steps of write_bop().
  /// Per frame, what the report sums: visible fractions of the objects and valid depth.
  struct FrameSummary {
    double visib_sum = 0;
    int visib_count = 0;
    double valid_depth_fraction = 0;
  };
  /// Frame i rendered and its images written into `scene`; its record and summary filled.
  void write_frame_files(int i, const std::string& scene, double max_preview_depth,
                         BopFrameRecord& record, FrameSummary& summary) const;
  /// synth_info.json: the parameters and what the scene is made of.
  void write_synth_info(const std::string& dir) const;
  SynthReport report(const std::string& dir, const std::string& scene,
                     const std::vector<FrameSummary>& stats) const;

  SynthParams params_;
  PinholeIntrinsics K_;
  DepthSensorParams sensor_;
  SynthScene scene_;
  std::vector<SE3> T_world_cam_;
  std::vector<double> arc_azimuths_;
};

/// A frame as the pipeline sees it: colour, sensor depth, ground-truth camera pose, objects
/// (class_id = BOP obj_id, instance_id = instance + 1) and visible-instance labels.
RgbdFrame to_rgbd_frame(const SynthFrame& frame, const SyntheticSceneGenerator& generator);

/// Preview for people: RGB | colourised depth | instance overlay, side by side (RGB8).
ColorImage make_preview(const SynthFrame& frame, double max_depth_m);

}  // namespace orpe::synth
