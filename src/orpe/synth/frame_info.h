// Per-frame object visibility as BOP's scene_gt_info.json defines it (bop_toolkit
// calc_gt_info): visible masks, pixel counts, boxes and the visible fraction, with the part of a
// silhouette cut off by the image border counted as not visible. Used by `orpe synth` and
// `orpe convert`.
#pragma once

#include <vector>

#include "orpe/core/camera.h"
#include "orpe/core/image.h"
#include "orpe/core/se3.h"
#include "orpe/render/mesh.h"
#include "orpe/render/rasterizer.h"
#include "orpe/synth/generator.h"

namespace orpe::synth {

/// Per instance k (label k + 1 in `visible`; `silhouettes[k]` its amodal mask inside the image):
/// the visible mask and the BOP scene_gt_info counts and boxes. `visible`, `depth` and every
/// silhouette have the same size; `masks_visib` and `info` are resized to silhouettes.size().
void object_frame_info(const LabelImage& visible, const std::vector<MaskImage>& silhouettes,
                       const DepthImage& depth, std::vector<MaskImage>& masks_visib,
                       std::vector<ObjectFrameInfo>& info);

/// Adds the pixels of the mesh's silhouette outside the image (within an image three times as
/// large, the original in its middle, as bop_toolkit renders it) to info.px_count_all, widens
/// info.bbox_obj to them and recomputes info.visib_fract. Objects entirely inside the image are
/// left alone (nothing is rendered).
void add_silhouette_outside_image(const TriangleMesh& mesh, const SE3& T_cam_obj,
                                  const PinholeIntrinsics& K, const RasterizerParams& rp,
                                  ObjectFrameInfo& info);

}  // namespace orpe::synth
