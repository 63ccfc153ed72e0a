// Camera files (`dataset.camera_file`, `--camera FILE`, a plain folder's camera.yaml): YAML read
// with cv::FileStorage, in three shapes (docs/DATASETS.md, "Camera file"):
//  - ORB-SLAM2 settings: Camera.fx fy cx cy, Camera.k1 k2 p1 p2 [k3], Camera.width / height,
//    DepthMapFactor (raw depth units per metre);
//  - ORB-SLAM3 settings (File.version "1.0"): Camera1.fx ... Camera1.k1 ..., Camera.width / height,
//    RGBD.DepthMapFactor;
//  - OpenCV calibration style: camera_matrix (3x3 !!opencv-matrix), distortion_coefficients (4 or
//  5:
//    k1 k2 p1 p2 [k3]), image_width, image_height, depth_units_per_m.
// Any shape may add: depth_camera_matrix + depth_distortion_coefficients (+ depth_image_width /
// height) and T_colour_depth (4x4, metres: depth-camera points into the colour frame) for a sensor
// whose depth is not registered, and min_depth_m / max_depth_m. Keys the shape does not use (an
// ORB-SLAM file's ORBextractor.*, Viewer.*) are ignored.
#pragma once

#include <string>
#include <vector>

#include "orpe/core/image.h"
#include "orpe/io/dataset.h"

namespace orpe {

/// Names of the built-in sensor presets accepted by read_camera_file in place of a path
/// (`--camera realsense_d435`): nominal intrinsics and depth scales, docs/DATASETS.md.
std::vector<std::string> camera_preset_names();

/// Reads a camera file, or a sensor preset by name when no file of that name exists. Throws IoError
/// naming the file and the key for a missing file, an unknown shape, a missing or non-numeric
/// value, a non-positive focal length / size / depth scale, a non-finite distortion, a
/// T_colour_depth that is not rigid, or min_depth_m >= max_depth_m.
CameraFileInfo read_camera_file(const std::string& path);

/// Applies a camera file to one frame read in the layout's own way: undistorts colour (bilinear),
/// labels and depth (nearest); registers depth into the colour camera when the file has a depth
/// camera (z-buffered forward projection through T_colour_depth); clears depth outside
/// [min_depth_m, max_depth_m]; sets the frame's intrinsics to the colour camera. Throws IoError
/// naming `frame_name` when the images' sizes differ from the file's.
void apply_camera_file(const CameraFileInfo& camera, const std::string& frame_name,
                       RgbdFrame& frame);

/// Registers a depth image of the depth camera into the colour camera (both as in `camera`, the
/// colour output undistorted: ideal pinhole with camera.colour). Exposed for tests.
DepthImage register_depth_to_colour(const DepthImage& depth, const CameraFileInfo& camera);

}  // namespace orpe
