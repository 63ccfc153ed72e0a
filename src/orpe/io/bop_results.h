// BOP results CSV: `scene_id,im_id,obj_id,score,R,t,time` with R the 9 entries of R_cam_obj row-major
// separated by spaces, t the translation in millimetres separated by spaces, time in seconds (identical for
// all rows of one image, -1 if unknown). Inside the library poses are T_cam_obj in metres; the mm
// conversion happens here only.
#pragma once

#include <string>
#include <vector>

#include "orpe/core/se3.h"

namespace orpe {

struct PoseResultRow {
  int scene_id = 0;
  int im_id = 0;
  int obj_id = 0;
  double score = 1.0;
  SE3 T_cam_obj;        ///< metres
  double time_s = -1.0;
};

/// Writes rows atomically with the BOP header line.
void write_bop_results(const std::string& path, const std::vector<PoseResultRow>& rows);
/// Reads a BOP results CSV (header optional). Throws IoError naming the file and line.
std::vector<PoseResultRow> read_bop_results(const std::string& path);

}  // namespace orpe
