// Object models drawn over a camera image at poses (`orpe report`'s keyframe pictures): each
// object's silhouette outlined and its visible part tinted, in its class colour, rendered by the
// project's rasteriser (render/rasterizer.h) with the frame's intrinsics.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "orpe/core/camera.h"
#include "orpe/core/image.h"
#include "orpe/core/se3.h"
#include "orpe/io/dataset.h"
#include "orpe/render/mesh.h"

namespace orpe::report {

struct OverlayObject {
  const TriangleMesh* mesh = nullptr;
  SE3 T_cam_obj;
  Rgb8 colour;
};

/// A copy of `image` with every object's amodal silhouette outlined (`thickness_px` wide) and its
/// visible pixels tinted (`tint` = weight of the class colour, 0..1).
ColorImage draw_model_overlays(const ColorImage& image, const PinholeIntrinsics& K,
                               const std::vector<OverlayObject>& objects, int thickness_px = 2,
                               double tint = 0.3);

/// The dataset's class meshes (DatasetInfo::model_mesh_paths, else the points file when it is a
/// mesh), loaded once on first use, untextured, in metres. A class that cannot be loaded is
/// reported once (warning) and left out of the pictures.
class ModelMeshes {
 public:
  explicit ModelMeshes(const DatasetInfo& info) : info_(info) {}
  /// Null when the class has no loadable mesh.
  const TriangleMesh* get(int class_id);

 private:
  const DatasetInfo& info_;
  std::map<int, std::unique_ptr<TriangleMesh>> meshes_;
};

}  // namespace orpe::report
