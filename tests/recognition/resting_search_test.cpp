#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>

#include "orpe/recognition/model_recognizer.h"
#include "orpe/recognition/resting_search.h"
#include "orpe/recognition/scene_geometry.h"
#include "recognition/recognition_scene.h"

namespace orpe {
namespace {

using test::PlacedObject;
using test::TestShapes;

const TestShapes& shapes() {
  static const TestShapes s;
  return s;
}

/// Mean distance of the model's points at `T` to the nearest of its points at `T_true` (ADD-S).
double adds(const ObjectModel& m, const SE3& T, const SE3& T_true) {
  double sum = 0;
  for (const auto& p : m.points) {
    const Vec3 a = T * p.cast<double>();
    double best = 1e9;
    for (const auto& q : m.points) best = std::min(best, (a - T_true * q.cast<double>()).norm());
    sum += best;
  }
  return sum / static_cast<double>(m.points.size());
}

TEST(RestingSearch, FaceAxesOfABoxAreItsEdges) {
  const ModelFaceAxes ax = model_face_axes(shapes().models()[0]);  // 0.12 x 0.07 x 0.05
  std::vector<float> e(ax.extents.data(), ax.extents.data() + 3);
  std::sort(e.begin(), e.end());
  EXPECT_NEAR(e[0], 0.05, 0.006);
  EXPECT_NEAR(e[1], 0.07, 0.006);
  EXPECT_NEAR(e[2], 0.12, 0.006);
  EXPECT_GT(ax.face_fraction, 0.9);
  EXPECT_NEAR(ax.axes.determinant(), 1.0, 1e-4);
  // A can's surface runs along no three axes: no box.
  EXPECT_LT(model_face_axes(shapes().models()[1]).face_fraction, 0.6);
}

// A box on the table: its vertical faces reach the table, and one of the resting poses placed on
// them is the box's own within a few mm.
TEST(RestingSearch, PlacesABoxOnItsObservedFace) {
  const auto& s = shapes();
  const SE3 T_world_obj = TestShapes::on_table(0.01, 0.02, 0.35, 0.025);
  const RgbdFrame f = test::render_table_scene({{1, &s.box, T_world_obj}});
  const SceneGeometryParams gp;
  SceneGrid g = make_scene_grid(f.depth, f.intrinsics, gp);
  remove_support_planes(g, gp);
  const auto regions = split_regions(g, gp);
  ASSERT_EQ(regions.size(), 1u);
  GridNormals normals(g, 3);
  const RestingFaceParams fp;
  const auto faces = vertical_faces(g, normals, regions[0].cells, g.planes.front(), fp);
  ASSERT_FALSE(faces.empty());
  EXPECT_NEAR(faces[0].top, 0.05, 0.01);
  EXPECT_LT(faces[0].bottom, fp.max_bottom_m);
  const ObjectModel& model = s.models()[0];
  const SE3 T_true = f.T_world_cam_gt->inverse() * T_world_obj;
  double best = 1e9;
  for (const auto& face : faces) {
    std::printf("face %d cells, %.3f wide, %.3f-%.3f, ext %.3f %.3f %.3f\n", face.cells, face.s_max - face.s_min, face.bottom, face.top, model_face_axes(model).extents[0], model_face_axes(model).extents[1], model_face_axes(model).extents[2]);
    for (const SE3& T : resting_poses(model_face_axes(model), face, g.planes.front(), fp))
      best = std::min(best, adds(model, T, T_true));
  }
  EXPECT_LT(best, 0.006);
}

// The box and the cube side by side, touching (one region): the crops explain both by the box;
// the resting search places the box on its front face and the cube on its own, and each point is
// explained once (formerly ModelRecognizer.DISABLED_SplitsTouchingObjectsOfOneRegion).
TEST(RestingSearch, SplitsTouchingBoxesOfOneRegion) {
  const auto& s = shapes();
  const RgbdFrame f =
      test::render_table_scene({{1, &s.box, TestShapes::on_table(-0.03, 0, 0, 0.025)},
                                {3, &s.cube, TestShapes::on_table(0.0525, 0.0, 0, 0.0225)}});
  auto classes_with = [&](bool resting) {
    RecognitionParams p;
    p.resting_search = resting;
    std::map<int, int> out;
    for (const auto& d :
         ModelRecognizer(SegmentationParams{}, p, SceneGeometryParams{}, s.models()).detect(f))
      ++out[d.class_id];
    return out;
  };
  EXPECT_EQ(classes_with(true), (std::map<int, int>{{1, 1}, {3, 1}}));
  EXPECT_NE(classes_with(false), (std::map<int, int>{{1, 1}, {3, 1}}));  // the search off
}

}  // namespace
}  // namespace orpe
