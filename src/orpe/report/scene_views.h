// The 3D pictures of `orpe report`: the surfel map and the semantic map rendered by the project's
// surfel renderer (slam/map_renderer.h) from viewpoints that frame the scene, and SVG overlays
// drawn over them in the page (the camera path, the instances' class names).
#pragma once

#include <string>
#include <vector>

#include "orpe/core/camera.h"
#include "orpe/core/image.h"
#include "orpe/core/se3.h"
#include "orpe/io/dataset.h"
#include "orpe/io/point_cloud_io.h"
#include "orpe/slam/surfel_map.h"

namespace orpe::report {

/// A viewpoint of a picture.
struct SceneView {
  SE3 T_world_cam;
  PinholeIntrinsics K;
};

/// A map PLY (map.ply / semantic_map.ply) as a SurfelMap. Missing attributes: radius 5 mm, normal
/// -z, grey, confidence 1; instance ids are kept only when `keep_instances` (else 0, so that
/// framing sees the whole map).
slam::SurfelMap surfel_map_from_cloud(const PointCloudData& cloud, bool keep_instances);

/// Recolours an instance-carrying map for the semantic picture: instance surfels take
/// label_color(instance id) (the colours of semantic_map_instances.ply and of the page's legend),
/// the others a pale grey of their own brightness.
void colour_by_instance(slam::SurfelMap& map);

/// A view of the map's focus box (slam::map_focus_box: the objects' surfels when there are any,
/// else the whole map), grown to hold `also_include` (e.g. the camera centres, so that the path is
/// in the picture), from the side of `first_camera`, `elevation_deg` above its viewing direction.
/// Falls back to a view from behind the first camera for a map too small to have a box.
SceneView framing_view(const slam::SurfelMap& map, const SE3& first_camera, double elevation_deg,
                       int width_px, int height_px, const std::vector<Vec3>& also_include = {});

/// The map as seen from `view` (surfel colours, headlight shading, white background).
ColorImage render_scene(const slam::SurfelMap& map, const SceneView& view);

/// An SVG drawn over a picture of `view`: the camera centres of `trajectory` as a polyline (start
/// green, end red); parts behind the viewer are left out.
std::string camera_path_svg(const std::vector<StampedPose>& trajectory, const SceneView& view);

/// A label drawn at a world point.
struct WorldLabel {
  Eigen::Vector3d position_world;
  std::string text;
  Rgb8 colour;
};
std::string labels_svg(const std::vector<WorldLabel>& labels, const SceneView& view);

/// The picture with an SVG on top of it (HTML: an <img> of `image_src` with the SVG over it).
std::string overlaid_image_html(const std::string& image_src, const std::string& svg,
                                const SceneView& view, const std::string& caption);

}  // namespace orpe::report
