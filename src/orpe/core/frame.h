// One RGB-D frame as it flows through the pipeline, plus whatever ground truth the dataset has.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "orpe/core/camera.h"
#include "orpe/core/image.h"
#include "orpe/core/se3.h"

namespace orpe {

/// Ground truth of one object instance visible in a frame.
struct ObjectGroundTruth {
  int class_id = 0;     ///< dataset class index (YCB-Video: 1..21, line of classes.txt; BOP: obj_id)
  int instance_id = 0;  ///< unique per scene; equals class_id where a dataset has one instance per class
  SE3 T_cam_obj;        ///< object model frame -> camera frame, metres
  double visible_fraction = -1.0;  ///< in [0, 1], or -1 when unknown
};

struct RgbdFrame {
  int index = 0;             ///< frame number within the sequence (dataset numbering)
  double timestamp_s = 0.0;  ///< seconds
  std::string name;          ///< human-readable id for messages, e.g. the colour file name
  PinholeIntrinsics intrinsics;
  ColorImage color;  ///< RGB8, same size as depth
  DepthImage depth;  ///< metres, 0 = invalid

  std::optional<SE3> T_world_cam_gt;  ///< camera -> world, when the dataset has it
  std::vector<ObjectGroundTruth> objects_gt;
  /// Ground-truth visible-object labels: 0 = background, k > 0 = objects_gt[k - 1]. Empty if unknown.
  LabelImage labels_gt;
};

}  // namespace orpe
