#include "orpe/render/rasterizer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "orpe/render/primitives.h"

namespace orpe {
namespace {

PinholeIntrinsics small_camera(int w = 160, int h = 120) {
  PinholeIntrinsics K;
  K.width = w;
  K.height = h;
  K.fx = K.fy = 150.0 * w / 160.0;
  K.cx = (w - 1) / 2.0;
  K.cy = (h - 1) / 2.0;
  return K;
}

/// Ray through pixel centre (u, v) hits the plane n . p = d at z = d / (n . ray), ray = (x, y, 1).
double plane_depth(const PinholeIntrinsics& K, int u, int v, const Eigen::Vector3d& n, double d) {
  const Eigen::Vector3d ray((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);
  return d / n.dot(ray);
}

TriangleMesh single_triangle(const Eigen::Vector3f& a, const Eigen::Vector3f& b,
                             const Eigen::Vector3f& c) {
  TriangleMesh m;
  m.vertices = {a, b, c};
  m.triangles = {{0, 1, 2}};
  m.compute_vertex_normals();
  return m;
}

TEST(Rasterizer, FrontoParallelSquareHasExactDepthAndCoverage) {
  const PinholeIntrinsics K = small_camera();
  // A 0.4 m square at z = 2 m, shifted so that no pixel centre lies on its border.
  TriangleMesh quad = make_quad(0.4f, 0.4f, 3, 3);
  const SE3 T(Mat3::Identity(), Vec3(0.0123, -0.0211, 2.0));
  Rasterizer r;
  const RenderItem item{&quad, T, 7};
  RenderBuffers out = r.render(K, {&item, 1}, kRenderAll);
  int covered = 0, expected = 0;
  for (int v = 0; v < K.height; ++v)
    for (int u = 0; u < K.width; ++u) {
      const Eigen::Vector3d ray((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);
      const Eigen::Vector3d hit = ray * 2.0;
      const bool inside = std::abs(hit.x() - 0.0123) < 0.2 && std::abs(hit.y() + 0.0211) < 0.2;
      expected += inside;
      const bool got = out.depth.at(u, v) > 0;
      covered += got;
      ASSERT_EQ(got, inside) << "pixel " << u << "," << v;
      if (got) {
        EXPECT_NEAR(out.depth.at(u, v), 2.0, 1e-6);
        EXPECT_EQ(out.ids.at(u, v), 7);
        EXPECT_NEAR(out.normals.at(u, v).z(), -1.0, 1e-5);  // facing the camera
        EXPECT_EQ(out.silhouettes[0].at(u, v), 1);
      } else {
        EXPECT_EQ(out.ids.at(u, v), 0);
        EXPECT_EQ(out.triangles.at(u, v), -1);
      }
    }
  EXPECT_GT(expected, 500);
  EXPECT_EQ(covered, expected);
  EXPECT_EQ(out.stats.pixels_covered, static_cast<size_t>(expected));
}

TEST(Rasterizer, TiltedPlaneDepthIsRayPlaneIntersection) {
  const PinholeIntrinsics K = small_camera();
  TriangleMesh quad = make_quad(3.0f, 3.0f, 4, 4);
  // Rotate 60 degrees about x: strongly slanted, depth varies a lot across the image.
  const Mat3 R = Eigen::AngleAxisd(1.0472, Vec3::UnitX()).toRotationMatrix();
  const SE3 T(R, Vec3(0.1, 0.05, 2.5));
  Rasterizer r;
  const RenderItem item{&quad, T, 1};
  RenderBuffers out = r.render(K, {&item, 1}, kRenderDepth);
  const Eigen::Vector3d n = R.col(2);
  const double d = n.dot(T.translation());
  int checked = 0;
  double zmin = 1e9, zmax = 0;
  for (int v = 0; v < K.height; ++v)
    for (int u = 0; u < K.width; ++u) {
      const float z = out.depth.at(u, v);
      if (z <= 0) continue;
      const double expect = plane_depth(K, u, v, n, d);
      ASSERT_NEAR(z, expect, 2e-6 * expect) << u << "," << v;
      zmin = std::min(zmin, expect), zmax = std::max(zmax, expect);
      ++checked;
    }
  EXPECT_GT(checked, 5000);
  EXPECT_GT(zmax - zmin, 0.5);  // the test really covers a wide depth range
}

TEST(Rasterizer, SharedEdgesAreCoveredExactlyOnce) {
  // A grid whose vertices sit exactly on pixel centres (the fill rule's hardest case), each
  // triangle a separate item so that the amodal silhouettes count coverage per triangle.
  const PinholeIntrinsics K = small_camera(64, 48);
  const double z = 1.0;
  auto to_metric = [&](double u, double v) {
    return Eigen::Vector3f(static_cast<float>((u - K.cx) * z / K.fx),
                           static_cast<float>((v - K.cy) * z / K.fy), static_cast<float>(z));
  };
  std::vector<TriangleMesh> meshes;
  const int cols = 6, rows = 4;
  const double u0 = 5.5 + 0.5, v0 = 4.0;  // = pixel centres (cx is 31.5: whole pixels)
  for (int j = 0; j < rows; ++j)
    for (int i = 0; i < cols; ++i) {
      const double ua = u0 + 8 * i, va = v0 + 9 * j;
      const auto a = to_metric(ua, va), b = to_metric(ua + 8, va), c = to_metric(ua + 8, va + 9),
                 d = to_metric(ua, va + 9);
      meshes.push_back(single_triangle(a, b, c));
      meshes.push_back(single_triangle(a, c, d));
    }
  std::vector<RenderItem> items;
  for (size_t k = 0; k < meshes.size(); ++k)
    items.push_back({&meshes[k], SE3(), static_cast<int>(k + 1)});
  Rasterizer r;
  RenderBuffers out = r.render(K, items, kRenderIds | kRenderSilhouettes);
  int inner = 0;
  for (int v = 0; v < K.height; ++v)
    for (int u = 0; u < K.width; ++u) {
      int count = 0;
      for (const auto& s : out.silhouettes) count += s.at(u, v);
      const bool strictly_inside = u > u0 && u < u0 + 8 * cols && v > v0 && v < v0 + 9 * rows;
      if (strictly_inside) {
        ASSERT_EQ(count, 1) << "pixel " << u << "," << v;
        ++inner;
      }
      ASSERT_LE(count, 1) << "pixel " << u << "," << v << " drawn twice";
      EXPECT_EQ(count > 0, out.ids.at(u, v) > 0);
    }
  EXPECT_GT(inner, 1500);
}

TEST(Rasterizer, TextureCoordinatesArePerspectiveCorrect) {
  const PinholeIntrinsics K = small_camera();
  // Texture whose red channel encodes u (0..255) along x: the rendered colour reveals the sampled
  // u.
  auto tex = std::make_shared<ColorImage>(256, 4);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 256; ++x) tex->at(x, y) = {static_cast<std::uint8_t>(x), 0, 0};
  TriangleMesh quad =
      make_quad(1.0f, 1.0f, 1, 1);  // two triangles only: affine interpolation would be far off
  // uv from the quad: u = x + 0.5 in [0, 1]. Map u to texel centres: u' = (u * 255 + 0.5) / 256.
  for (auto& uv : quad.uvs) uv.x() = (uv.x() * 255.0f + 0.5f) / 256.0f, uv.y() = 0.5f;
  quad.texture = tex;
  const Mat3 R = Eigen::AngleAxisd(-1.2, Vec3::UnitY()).toRotationMatrix();  // steep slant about y
  const SE3 T(R, Vec3(0.0, 0.0, 1.2));
  RasterizerParams p;
  p.ambient = 1.0;
  p.diffuse = 0.0;
  Rasterizer r(p);
  const RenderItem item{&quad, T, 1};
  RenderBuffers out = r.render(K, {&item, 1}, kRenderColor | kRenderDepth);
  const Eigen::Vector3d n = R.col(2), ex = R.col(0);
  const double d = n.dot(T.translation());
  int checked = 0;
  double worst = 0;
  for (int v = 0; v < K.height; ++v)
    for (int u = 0; u < K.width; ++u) {
      if (out.depth.at(u, v) <= 0) continue;
      const double z = plane_depth(K, u, v, n, d);
      const Eigen::Vector3d hit(z * (u - K.cx) / K.fx, z * (v - K.cy) / K.fy, z);
      const double x_local = ex.dot(hit - T.translation());  // in [-0.5, 0.5]
      const double expect = (x_local + 0.5) * 255.0;
      if (expect < 1 || expect > 254) continue;  // bilinear wrap at the texture border
      worst = std::max(worst, std::abs(out.color.at(u, v).r - expect));
      ++checked;
    }
  EXPECT_GT(checked, 1000);
  EXPECT_LE(worst, 1.0) << "rendered u deviates from the exact perspective-correct u";
}

TEST(Rasterizer, CubeFrontFaceCullingAndOcclusion) {
  const PinholeIntrinsics K = small_camera();
  TriangleMesh cube = make_box(Eigen::Vector3f(0.3f, 0.3f, 0.3f), 0.1f);
  TriangleMesh wall = make_quad(4.0f, 4.0f, 2, 2);
  const SE3 T_cube(Mat3::Identity(), Vec3(0, 0, 1.5));
  const SE3 T_wall(Eigen::AngleAxisd(M_PI, Vec3::UnitX()).toRotationMatrix(),
                   Vec3(0, 0, 3.0));  // facing the camera
  const std::vector<RenderItem> items{{&wall, T_wall, 2}, {&cube, T_cube, 1}};
  RenderBuffers a, b;
  RasterizerParams p;
  Rasterizer(p).render(K, items, a, kRenderAll);
  p.cull_back_faces = true;
  Rasterizer(p).render(K, items, b, kRenderAll);
  int cube_px = 0;
  for (int v = 0; v < K.height; ++v)
    for (int u = 0; u < K.width; ++u) {
      ASSERT_EQ(a.ids.at(u, v), b.ids.at(u, v));
      ASSERT_FLOAT_EQ(a.depth.at(u, v), b.depth.at(u, v));
      if (a.ids.at(u, v) == 1) {
        ++cube_px;
        EXPECT_NEAR(a.depth.at(u, v), 1.35, 1e-6);  // front face of the cube
        EXPECT_EQ(a.silhouettes[0].at(u, v), 1);    // the wall covers this pixel too (occluded)
      } else if (a.depth.at(u, v) > 0) {
        EXPECT_NEAR(a.depth.at(u, v), 3.0, 1e-6);
      }
    }
  // The cube's front face spans 0.3 m at 1.35 m: about (150 * 0.3 / 1.35)^2 pixels.
  const double expect = std::pow(150 * 0.3 / 1.35, 2);
  EXPECT_NEAR(cube_px, expect, 0.1 * expect);
  EXPECT_LT(b.stats.triangles_drawn, a.stats.triangles_drawn);
}

TEST(Rasterizer, NearPlaneClippingOfAFloorPassingUnderTheCamera) {
  const PinholeIntrinsics K = small_camera();
  // A 20 m floor 1 m below the camera (y down => floor at y = +1), extending behind the camera.
  TriangleMesh floor = make_quad(20.0f, 20.0f, 1, 1);
  const Mat3 R =
      Eigen::AngleAxisd(M_PI / 2, Vec3::UnitX()).toRotationMatrix();  // quad z -> camera -y
  const SE3 T(R, Vec3(0, 1.0, 0));
  RasterizerParams p;
  p.far_m = 1000;
  Rasterizer r(p);
  const RenderItem item{&floor, T, 1};
  RenderBuffers out = r.render(K, {&item, 1}, kRenderDepth | kRenderIds);
  EXPECT_GT(out.stats.triangles_clipped, 0u);
  const Eigen::Vector3d n(0, 1, 0);
  for (int v = 0; v < K.height; ++v)
    for (int u = 0; u < K.width; ++u) {
      const double ray_y = (v - K.cy) / K.fy;
      const double z = ray_y > 0 ? 1.0 / ray_y : -1;
      const double x = z * (u - K.cx) / K.fx;
      const bool hits = ray_y > 0 && z < 10.0 - 1e-3 && std::abs(x) < 10.0 - 1e-3 && z > 0;
      if (!hits) continue;  // beyond the floor's far edge
      ASSERT_GT(out.depth.at(u, v), 0) << u << "," << v;
      ASSERT_NEAR(out.depth.at(u, v), z, 1e-5 * z);
    }
  for (int u = 0; u < K.width; ++u) EXPECT_EQ(out.depth.at(u, 0), 0.0f);  // above the horizon
}

TEST(Rasterizer, ResultIndependentOfThreadCount) {
  const PinholeIntrinsics K = small_camera(200, 150);
  std::vector<TriangleMesh> meshes;
  std::vector<RenderItem> items;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> U(-0.6, 0.6);
  for (int i = 0; i < 30; ++i) meshes.push_back(make_sphere(0.15f, 24, 12));
  for (int i = 0; i < 30; ++i)
    items.push_back({&meshes[i], SE3(Mat3::Identity(), Vec3(U(rng), U(rng), 2.0 + U(rng))), i + 1});
  RasterizerParams p;
  p.threads = 1;
  RenderBuffers a = Rasterizer(p).render(K, items, kRenderAll);
  p.threads = 2;
  p.band_rows = 3;
  RenderBuffers b = Rasterizer(p).render(K, items, kRenderAll);
  ASSERT_EQ(a.depth.size(), b.depth.size());
  EXPECT_TRUE(std::equal(a.depth.begin(), a.depth.end(), b.depth.begin()));
  EXPECT_TRUE(std::equal(a.ids.begin(), a.ids.end(), b.ids.begin()));
  EXPECT_TRUE(std::equal(a.color.begin(), a.color.end(), b.color.begin()));
  EXPECT_GT(a.stats.pixels_covered, 5000u);
}

TEST(Rasterizer, LambertShadingFollowsTheLight) {
  const PinholeIntrinsics K = small_camera();
  TriangleMesh quad = make_quad(1.0f, 1.0f, 1, 1);
  quad.base_color = {200, 200, 200};
  const RenderItem item{&quad, SE3(Mat3::Identity(), Vec3(0, 0, 2)),
                        1};  // quad normal +z: faces away, flipped
  RasterizerParams p;
  p.ambient = 0.2;
  p.diffuse = 0.8;
  Rasterizer r(p);
  Light head{Eigen::Vector3f(0, 0, -1), 0.2f, 0.8f};  // light at the camera: full diffuse
  Light side{Eigen::Vector3f(1, 0, 0), 0.2f, 0.8f};   // grazing: ambient only
  const Rgb8 c_head = r.render(K, {&item, 1}, kRenderColor, &head).color.at(80, 60);
  const Rgb8 c_side = r.render(K, {&item, 1}, kRenderColor, &side).color.at(80, 60);
  EXPECT_NEAR(c_head.r, 200, 1);
  EXPECT_NEAR(c_side.r, 40, 1);
}

TEST(Rasterizer, InvalidInputThrows) {
  PinholeIntrinsics K = small_camera();
  Rasterizer r;
  RenderItem no_mesh{nullptr, SE3(), 1};
  EXPECT_THROW(r.render(K, {&no_mesh, 1}), std::invalid_argument);
  TriangleMesh bad = single_triangle({0, 0, 1}, {1, 0, 1}, {0, 1, 1});
  bad.triangles.push_back({0, 1, 5});
  RenderItem bad_item{&bad, SE3(), 1};
  EXPECT_THROW(r.render(K, {&bad_item, 1}), std::invalid_argument);
  RasterizerParams p;
  p.near_m = 0;
  EXPECT_THROW(Rasterizer{p}, std::invalid_argument);
}

}  // namespace
}  // namespace orpe

namespace orpe {
namespace {

TEST(Rasterizer, CropEqualsTheCropOfTheFullRender) {
  // Pose-hypothesis rendering in a region of interest: shifted principal point, smaller size.
  const PinholeIntrinsics K = small_camera(200, 150);
  TriangleMesh sphere = make_sphere(0.3f, 40, 20);
  TriangleMesh box = make_box(Eigen::Vector3f(0.4f, 0.3f, 0.2f), 0.05f);
  const std::vector<RenderItem> items{
      {&sphere, SE3(Mat3::Identity(), Vec3(0.1, 0.05, 2.0)), 1},
      {&box, SE3(Eigen::AngleAxisd(0.5, Vec3::UnitY()).toRotationMatrix(), Vec3(-0.2, 0.1, 1.6)),
       2}};
  Rasterizer r;
  const RenderBuffers full = r.render(K, items, kRenderDepth | kRenderIds);
  PinholeIntrinsics crop = K;
  const int u0 = 37, v0 = 21;
  crop.width = 90, crop.height = 70, crop.cx -= u0, crop.cy -= v0;
  const RenderBuffers part = r.render(crop, items, kRenderDepth | kRenderIds);
  int covered = 0;
  for (int v = 0; v < crop.height; ++v)
    for (int u = 0; u < crop.width; ++u) {
      ASSERT_EQ(part.ids.at(u, v), full.ids.at(u + u0, v + v0)) << u << "," << v;
      ASSERT_NEAR(part.depth.at(u, v), full.depth.at(u + u0, v + v0), 1e-6);
      covered += part.ids.at(u, v) > 0;
    }
  EXPECT_GT(covered, 1000);
}

}  // namespace
}  // namespace orpe
