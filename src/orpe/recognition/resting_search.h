// Resting search of the `model` back-end (docs/SEMANTIC.md, "model", step 3): boxes resting on the
// support plane on one of their faces, placed at an observed vertical face. A box lying on the
// table shows one or two vertical faces whose lower edge meets the table; its pose is then fixed
// up to where along that face it sits: the box's face normal along the observed face's normal, one
// of its axes along the support normal, its bottom on the plane. This finds a box that the crop
// search misses because no crop holds it alone (the wood block of YCB-Video clip 0002, touched by
// three other objects), and gives the ranking a hypothesis whose height is the box's own.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "orpe/core/plane_fit.h"
#include "orpe/core/se3.h"
#include "orpe/pose/object_model.h"
#include "orpe/recognition/scene_geometry.h"

namespace orpe {

/// A model's face axes: the three orthogonal directions most of its surface normals run along
/// (a box's faces), object frame, with the extents along them and the centre of its bounding box.
struct ModelFaceAxes {
  Eigen::Matrix3f axes = Eigen::Matrix3f::Identity();  ///< columns, unit, right-handed
  Eigen::Vector3f extents = Eigen::Vector3f::Zero();   ///< m, along each column
  Eigen::Vector3f centre = Eigen::Vector3f::Zero();    ///< object frame
  double face_fraction = 0;  ///< of the model's normals within 10 degrees of +-an axis
};

/// The face axes of a model with normals (all-zero extents without normals).
ModelFaceAxes model_face_axes(const ObjectModel& model);

/// A vertical planar patch of observed surface that reaches down to the support plane.
struct VerticalFace {
  Eigen::Vector3f normal;      ///< horizontal, towards the camera (camera frame)
  Eigen::Vector3f along;       ///< horizontal, in the face (up x normal)
  float offset = 0;            ///< normal . p of the face's points, relative to the plane origin
  float s_min = 0, s_max = 0;  ///< extent along `along` (2nd / 98th percentiles)
  bool s_min_cut = false, s_max_cut = false;  ///< that end lies on the image border
  float bottom = 0, top = 0;                  ///< heights over the support (2nd / 98th percentiles)
  int cells = 0;
};

struct RestingFaceParams {
  int min_cells = 60;                ///< grid cells of a face
  double max_tilt_deg = 15;          ///< normal this close to horizontal
  double max_bottom_m = 0.03;        ///< the face's lowest points this close to the plane
  double height_tolerance_m = 0.02;  ///< model extent along the support normal vs the face's top
  double width_slack_m = 0.02;       ///< the face may be this much wider than the model's side
  int max_faces = 3;                 ///< per region, largest first
};

/// A horizontal planar patch of observed surface over the support: the top of a box resting on it.
struct TopFace {
  Eigen::Vector3f e1 = Eigen::Vector3f::UnitX();  ///< horizontal, camera frame
  Eigen::Vector3f e2 = Eigen::Vector3f::UnitY();  ///< horizontal, support normal x e1
  float height = 0;                               ///< over the support (median), m
  /// convex hull of its points in (e1, e2) coordinates from the plane's point nearest the camera
  std::vector<Eigen::Vector2f> hull;
  int cells = 0;
  bool at_border = false;  ///< some of its cells lie on the image border (it leaves the view)
  std::vector<Eigen::Vector2f> border;  ///< its cells on the image border, as `hull`
};

/// The top faces of `cells`, largest first: cells whose normal lies within max_tilt_deg of the
/// support normal, at least 2 cm over the support, grouped by height (1 cm bins, +-1.5 cm around
/// the most common height); at most max_faces, each with at least min_cells cells.
std::vector<TopFace> top_faces(const SceneGrid& g, GridNormals& normals,
                               const std::vector<int>& cells, const Plane& support,
                               const RestingFaceParams& p);

/// Poses (T_cam_obj) of a model resting on `support` with its top face on `face`: every axis
/// whose extent is the face's height (height_tolerance_m) stands up; the other two run along the
/// face's dominant outline directions (the two longest directions of its hull edges, modulo 90
/// degrees), each way round, when the face fits in the model's top (+ width_slack_m); centred on
/// the face along a side the face spans, else aligned with either end of it (the rest hidden, or
/// outside the image) -- but not with an end the image border cuts while the other is in view.
std::vector<SE3> resting_poses_on_top(const ModelFaceAxes& axes, const TopFace& face,
                                      const Plane& support, const RestingFaceParams& p);

/// The vertical faces of `cells` (the normals of `normals`), largest first: cells whose normal
/// lies within max_tilt_deg of the support plane, grouped by direction (10-degree bins) and by
/// offset along it (1 cm bins).
std::vector<VerticalFace> vertical_faces(const SceneGrid& g, GridNormals& normals,
                                         const std::vector<int>& cells, const Plane& support,
                                         const RestingFaceParams& p);

/// Poses (T_cam_obj) of a model resting on `support` on one of its faces with another face on
/// `face`: every choice of the axis along the support normal whose extent fits the face's top
/// (height_tolerance_m) and of the axis along the face normal whose remaining side is at least the
/// face's width (- width_slack_m), one sign of each (the others are the box turned by 180
/// degrees); centred on the face when the face is about
/// as wide as the model's side, else aligned with either end of it (the rest hidden) -- but not
/// with an end the image border cuts while the other is in view (the rest would be in view).
std::vector<SE3> resting_poses(const ModelFaceAxes& axes, const VerticalFace& face,
                               const Plane& support, const RestingFaceParams& p);

}  // namespace orpe
