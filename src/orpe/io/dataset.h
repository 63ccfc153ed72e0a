// One interface over the dataset layouts orpe reads: a random-access sequence of RGB-D frames plus
// whatever ground truth the dataset has. Readers convert to library conventions at this edge:
// depth in metres (per-dataset depth scale), colour RGB8, poses as T_world_cam / T_cam_obj in
// metres. Layouts, presets, detection rules and depth scales: docs/DATASETS.md.
#pragma once

#include <array>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "orpe/core/frame.h"

namespace orpe {

/// Dataset selection and per-dataset overrides. Zero / empty means "use the layout's preset".
struct DatasetParams {
  std::string format = "auto";  ///< auto | tum | 7scenes | ycbv | bop | plain | rosbag
  int first_frame = 0;          ///< index into the layout's frame list (after sorting), inclusive
  int last_frame = -1;          ///< inclusive; -1 = to the end
  int stride = 1;               ///< take every stride-th frame
  /// Frames [cut_first, cut_last] (indices into the layout's list, inclusive) left out, as if the
  /// camera had been covered or frames dropped (a kidnapping, docs/SLAM.md); -1 = none.
  int cut_first = -1;
  int cut_last = -1;
  double depth_units_per_m =
      0;  ///< raw depth units per metre; 0 = preset (TUM 5000, 7-Scenes 1000, ...)
  double fx = 0, fy = 0, cx = 0, cy = 0;  ///< intrinsics override, pixels; 0 = preset / from files
  double max_depth_m = 0;  ///< depth beyond this is marked invalid on read; 0 = keep all
  std::string scene;  ///< YCB-Video video ("0001") or BOP scene ("000000"); empty = first found
  /// BOP: accept a models/ folder without models_info.json, every object then asymmetric (ADD,
  /// never ADD-S). Off: such a dataset is refused, since its symmetries would be lost silently.
  bool bop_without_models_info = false;
  std::string models_dir;  ///< folder of object meshes replacing the dataset's models; empty = none
  std::string
      models_unit;  ///< unit of models_dir's files: m | mm; empty = detect (error if unclear)
  std::string camera_file;  ///< camera YAML (ORB-SLAM2/3 or OpenCV style) overriding the layout's
  // ROS 1 bags (a .bag file as the dataset path; docs/DATASETS.md "ROS bags"). Defaults: the topics
  // of the TUM RGB-D bags.
  std::string bag_colour_topic = "/camera/rgb/image_color";  ///< sensor_msgs/Image, 8-bit colour
  std::string bag_depth_topic =
      "/camera/depth/image";  ///< sensor_msgs/Image, 16UC1 (raw units) or 32FC1 (metres)
  std::string bag_camera_info_topic =
      "/camera/rgb/camera_info";  ///< sensor_msgs/CameraInfo of the colour camera
  /// Set by open_dataset, not a setting: the camera file has a depth camera of its own, which is
  /// registered into colour after loading, so colour and depth may differ in size at load.
  bool depth_registered_later = false;

  template <class V>
  void visit(V&& v) {
    v("format", format, "Dataset layout: auto | tum | 7scenes | ycbv | bop | plain | rosbag");
    v("first_frame", first_frame, "First frame (index into the sorted frame list), inclusive");
    v("last_frame", last_frame, "Last frame, inclusive; -1 = to the end");
    v("stride", stride, "Take every stride-th frame (>= 1)");
    v("cut_first", cut_first,
      "First frame of a range left out (a gap: the camera moves unseen); -1 = no gap");
    v("cut_last", cut_last, "Last frame of that range, inclusive");
    v("depth_units_per_m", depth_units_per_m,
      "Raw depth units per metre; 0 = the layout's preset (TUM 5000, 7-Scenes 1000, YCB meta.mat, "
      "BOP json)");
    v("fx", fx, "Focal length x override (pixels); 0 = from the dataset / preset");
    v("fy", fy, "Focal length y override (pixels); 0 = from the dataset / preset");
    v("cx", cx, "Principal point x override (pixels); 0 = from the dataset / preset");
    v("cy", cy, "Principal point y override (pixels); 0 = from the dataset / preset");
    v("max_depth_m", max_depth_m, "Depth beyond this is marked invalid on read (m); 0 = keep all");
    v("scene", scene,
      "YCB-Video video (e.g. 0001) or BOP scene (e.g. 000000); empty = first found");
    v("bop_without_models_info", bop_without_models_info,
      "BOP: accept models/ without models_info.json, treating every object as asymmetric (else "
      "refused)");
    v("models_dir", models_dir,
      "Folder of object meshes (one file or one folder per object) replacing the dataset's models; "
      "empty = the dataset's own (docs/DATASETS.md)");
    v("models_unit", models_unit,
      "Unit of the models_dir files: m | mm; empty = detect from their sizes (an error when "
      "unclear)");
    v("camera_file", camera_file,
      "Camera YAML (ORB-SLAM2/ORB-SLAM3 settings or OpenCV FileStorage style): intrinsics, "
      "distortion, depth scale, depth-to-colour extrinsics; or a sensor preset name "
      "(kinect_v1, xtion, primesense, realsense_d435, azure_kinect_720p); overrides the layout's "
      "(docs/DATASETS.md)");
    v("bag_colour_topic", bag_colour_topic,
      "ROS bag: colour sensor_msgs/Image topic (rgb8, bgr8, rgba8, bgra8, mono8)");
    v("bag_depth_topic", bag_depth_topic,
      "ROS bag: depth sensor_msgs/Image topic (16UC1: raw units, depth_units_per_m or 1000 per "
      "metre; 32FC1: metres)");
    v("bag_camera_info_topic", bag_camera_info_topic,
      "ROS bag: sensor_msgs/CameraInfo of the colour camera (intrinsics and plumb_bob distortion); "
      "unused when a camera file is given");
  }
  bool IsValid(std::string* why) const;
};

/// A symmetry stated for one model in a models folder's symmetry.yaml (docs/DATASETS.md).
struct ModelSymmetrySpec {
  std::string text;         ///< as written, for messages and summaries
  bool none = false;        ///< "none": no symmetry, scored with ADD
  bool detected = false;  ///< "symmetric": the detected group, scored with ADD-S
  bool continuous = false;  ///< "continuous x|y|z": about that object axis
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
  std::vector<Eigen::Vector3d> flip_axes;  ///< "flip x y ...": 180-degree turns about these axes
};

/// The camera a run used when a camera file was given (every value, for summary.json).
struct CameraFileInfo {
  std::string path;
  std::string style;         ///< orbslam2 | orbslam3 | opencv
  PinholeIntrinsics colour;  ///< colour camera (after undistortion: same K, no distortion)
  std::array<double, 5> colour_distortion{};  ///< k1 k2 p1 p2 k3 of the colour images
  bool has_depth_camera = false;  ///< depth in its own camera, registered into colour at load
  PinholeIntrinsics depth;
  std::array<double, 5> depth_distortion{};
  SE3 T_colour_depth;            ///< depth-camera points into the colour camera frame, metres
  double depth_units_per_m = 0;  ///< 0 = the layout's
  double min_depth_m = 0, max_depth_m = 0;  ///< 0 = no limit
};

/// Static facts about an opened dataset.
struct DatasetInfo {
  std::string format;            ///< tum | 7scenes | ycbv | bop
  std::string root;              ///< the folder that was opened
  int scene_id = 0;              ///< YCB video number / BOP scene id (for BOP result rows)
  PinholeIntrinsics intrinsics;  ///< of the first frame (frames may carry their own)
  double depth_units_per_m =
      0;  ///< the scale used (of the first selected frame; 0 if none was found)
  std::map<int, std::string> class_names;  ///< class id -> name (YCB: classes.txt; BOP: obj_XXXXXX)
  std::map<int, std::string>
      model_points_paths;  ///< class id -> points file (YCB points.xyz, BOP ply)
  std::map<int, std::string> model_mesh_paths;  ///< class id -> mesh (OBJ/PLY), when present
  std::vector<int> symmetric_classes;           ///< classes scored with ADD-S in ADD(-S)
  double model_units_per_m = 1.0;               ///< model files' units (BOP: 1000 = mm)
  std::string models_dir;  ///< dataset.models_dir when the models came from there
  std::map<int, ModelSymmetrySpec> model_symmetry;  ///< symmetry.yaml of models_dir, per class
  std::optional<CameraFileInfo> camera;             ///< dataset.camera_file, when given
};

/// A timestamped camera pose, T_world_cam.
struct StampedPose {
  double timestamp_s = 0;
  SE3 T_world_cam;
};

class DatasetReader {
 public:
  virtual ~DatasetReader() = default;
  virtual const DatasetInfo& info() const = 0;
  /// Number of frames after the first/last/stride selection.
  virtual size_t size() const = 0;
  /// Reads frame i (0 <= i < size()). Throws IoError naming the file for a bad frame
  /// (missing/corrupt file, colour/depth size mismatch, ...).
  virtual RgbdFrame read(size_t i) const = 0;
  /// Frame i without pixels: index, timestamp, name, intrinsics, T_world_cam_gt and objects_gt, but
  /// no colour, depth or labels_gt. Much cheaper than read() (no image decoding), e.g. for
  /// evaluation. Throws IoError like read() for bad annotation files (not for bad images).
  virtual RgbdFrame read_annotations(size_t i) const {
    RgbdFrame f = read(i);
    f.color = {};
    f.depth = {};
    f.labels_gt = {};
    return f;
  }
  /// Ground-truth camera trajectory of the selected frames, when the dataset has one.
  virtual std::vector<StampedPose> ground_truth_trajectory() const { return {}; }
};

/// Detects the layout of `path` ("tum", "7scenes", "ycbv", "bop"), or throws IoError explaining
/// what was looked for.
std::string detect_dataset_format(const std::string& path);

/// Opens a dataset folder. Throws IoError / ConfigError with a message naming the path and problem.
std::unique_ptr<DatasetReader> open_dataset(const std::string& path, const DatasetParams& params);

/// Iterates a reader, skipping bad frames: each is logged (file and problem) and counted.
class FrameStream {
 public:
  explicit FrameStream(const DatasetReader& reader) : reader_(reader) {}
  /// Reads the next good frame into `frame`; false at the end.
  bool next(RgbdFrame& frame);
  size_t skipped() const { return skipped_.size(); }
  /// (frame position, message) of each skipped frame.
  const std::vector<std::pair<size_t, std::string>>& skipped_frames() const { return skipped_; }

 private:
  const DatasetReader& reader_;
  size_t pos_ = 0;
  std::vector<std::pair<size_t, std::string>> skipped_;
};

}  // namespace orpe
