// Models drawn over a camera image (report/pose_overlays.h) and the surfel-map pictures.
#include <gtest/gtest.h>

#include "orpe/render/primitives.h"
#include "orpe/report/pose_overlays.h"
#include "orpe/report/scene_views.h"

namespace orpe::report {
namespace {

PinholeIntrinsics camera() {
  PinholeIntrinsics K;
  K.width = 160, K.height = 120, K.fx = K.fy = 150, K.cx = 79.5, K.cy = 59.5;
  return K;
}

TEST(PoseOverlays, AnOutlineInTheClassColourAroundTheModelAndTheRestUntouched) {
  const TriangleMesh box = make_box(Eigen::Vector3f(0.1f, 0.1f, 0.1f), 0.1f);
  const ColorImage image(160, 120, Rgb8{100, 100, 100});
  const Rgb8 red{255, 0, 0};
  const SE3 T = SE3(Mat3::Identity(), Vec3(0, 0, 1.0));
  const ColorImage out = draw_model_overlays(image, camera(), {{&box, T, red}}, 2, 0.3);
  // The box spans +-0.05 m at 1 m: +-7.5 px around the principal point.
  EXPECT_EQ(out.at(5, 5), (Rgb8{100, 100, 100})) << "far from the model";
  const Rgb8 inside = out.at(80, 60);
  EXPECT_GT(inside.r, 100);
  EXPECT_LT(inside.g, 100) << "tinted towards red";
  EXPECT_NE(inside, red) << "the inside is tinted, not painted";
  int outline = 0;
  for (int u = 60; u < 100; ++u) outline += out.at(u, 60) == red;
  EXPECT_GE(outline, 2) << "both edges on the centre row";
  EXPECT_LE(outline, 8);
  // A model behind the camera draws nothing.
  const ColorImage none =
      draw_model_overlays(image, camera(), {{&box, SE3(Mat3::Identity(), Vec3(0, 0, -1)), red}});
  EXPECT_EQ(none.at(80, 60), (Rgb8{100, 100, 100}));
}

TEST(SceneViews, TheFramingViewSeesTheWholeMapAndThePathProjects) {
  PointCloudData cloud;
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 40; ++j) {
      cloud.positions_m.emplace_back(-0.5f + i * 0.025f, 0.3f,
                                     1.5f + j * 0.025f);  // a floor, y down
      cloud.normals.emplace_back(0, -1, 0);
      cloud.radii_m.push_back(0.02f);  // discs overlapping as in a fused map
    }
  const slam::SurfelMap map = surfel_map_from_cloud(cloud, false);
  const SceneView view = framing_view(map, SE3(), 25, 320, 240);
  const ColorImage img = render_scene(map, view);
  int covered = 0;
  for (size_t k = 0; k < img.size(); ++k) covered += img[k] != Rgb8{255, 255, 255};
  EXPECT_GT(covered, 0.15 * img.size()) << "the floor fills a good part of the picture";
  // A path above the floor (the first camera itself is behind this close view).
  std::vector<StampedPose> path = {{0, SE3(Mat3::Identity(), Vec3(0, 0.2, 1.8))},
                                   {1, SE3(Mat3::Identity(), Vec3(0.1, 0.2, 1.9))}};
  const std::string svg = camera_path_svg(path, view);
  EXPECT_NE(svg.find("<polyline"), std::string::npos);
  EXPECT_NE(svg.find("#20a020"), std::string::npos) << "start marker";
}

}  // namespace
}  // namespace orpe::report
