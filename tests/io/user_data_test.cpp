// Issue #17: camera files (ORB-SLAM2/3, OpenCV style), undistortion and depth registration on
// synthetic images with known values, plain rgb/ + depth/ folders, models folders.
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "io/dataset_fixtures.h"
#include "orpe/io/camera_file.h"
#include "orpe/io/models_folder.h"
#include "orpe/render/mesh_io.h"
#include "orpe/render/primitives.h"
#include "support/test_data.h"

namespace orpe {
namespace {

const char* kOrbSlam2 = R"(%YAML:1.0
# ORB-SLAM2 TUM1.yaml shape
Camera.fx: 517.306408
Camera.fy: 516.469215
Camera.cx: 318.643040
Camera.cy: 255.313989
Camera.k1: 0.262383
Camera.k2: -0.953104
Camera.p1: -0.005358
Camera.p2: 0.002628
Camera.k3: 1.163314
Camera.width: 640
Camera.height: 480
Camera.fps: 30.0
Camera.bf: 40.0
Camera.RGB: 1
ThDepth: 40.0
DepthMapFactor: 5000.0
ORBextractor.nFeatures: 1000
Viewer.KeyFrameSize: 0.05
)";

const char* kOrbSlam3 = R"(%YAML:1.0
File.version: "1.0"
Camera.type: "PinHole"
Camera1.fx: 535.4
Camera1.fy: 539.2
Camera1.cx: 320.1
Camera1.cy: 247.6
Camera1.k1: 0.0
Camera1.k2: 0.0
Camera1.p1: 0.0
Camera1.p2: 0.0
Camera.width: 640
Camera.height: 480
Camera.fps: 30
Camera.RGB: 1
Stereo.ThDepth: 40.0
Stereo.b: 0.07732
RGBD.DepthMapFactor: 5000.0
)";

std::string opencv_style(const std::string& extra = "") {
  return "%YAML:1.0\nimage_width: 64\nimage_height: 48\n"
         "camera_matrix: !!opencv-matrix\n  rows: 3\n  cols: 3\n  dt: d\n"
         "  data: [ 60., 0., 31.5, 0., 61., 23.5, 0., 0., 1. ]\n"
         "distortion_coefficients: !!opencv-matrix\n  rows: 1\n  cols: 5\n  dt: d\n"
         "  data: [ -0.2, 0.05, 0.001, -0.002, 0. ]\n"
         "depth_units_per_m: 1000\nmax_depth_m: 4.5\n" +
         extra;
}

TEST(CameraFile, ReadsOrbSlam2And3SettingsAsTheyAre) {
  const std::string dir = test::scratch_dir("cam");
  test::write_text(dir + "/tum1.yaml", kOrbSlam2);
  const CameraFileInfo a = read_camera_file(dir + "/tum1.yaml");
  EXPECT_EQ(a.style, "orbslam2");
  EXPECT_DOUBLE_EQ(a.colour.fx, 517.306408);
  EXPECT_DOUBLE_EQ(a.colour.cy, 255.313989);
  EXPECT_DOUBLE_EQ(a.colour_distortion[0], 0.262383);
  EXPECT_DOUBLE_EQ(a.colour_distortion[4], 1.163314);
  EXPECT_EQ(a.colour.width, 640);
  EXPECT_DOUBLE_EQ(a.depth_units_per_m, 5000.0);
  EXPECT_FALSE(a.has_depth_camera);
  test::write_text(dir + "/tum3.yaml", kOrbSlam3);
  const CameraFileInfo b = read_camera_file(dir + "/tum3.yaml");
  EXPECT_EQ(b.style, "orbslam3");
  EXPECT_DOUBLE_EQ(b.colour.fy, 539.2);
  EXPECT_DOUBLE_EQ(b.depth_units_per_m, 5000.0);
  test::write_text(dir + "/cv.yaml", opencv_style());
  const CameraFileInfo c = read_camera_file(dir + "/cv.yaml");
  EXPECT_EQ(c.style, "opencv");
  EXPECT_DOUBLE_EQ(c.colour.cx, 31.5);
  EXPECT_DOUBLE_EQ(c.colour_distortion[3], -0.002);
  EXPECT_DOUBLE_EQ(c.max_depth_m, 4.5);
}

const std::string kIdentityColourDepth =
    "T_colour_depth: !!opencv-matrix\n  rows: 4\n  cols: 4\n  dt: d\n"
    "  data: [ 1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1. ]\n";

TEST(CameraFile, WrongOrMissingValuesAreErrorsNamingTheKey) {
  const std::string dir = test::scratch_dir("badcam");
  struct Case {
    std::string text, needle;
  };
  const std::string orb = kOrbSlam2;
  auto replace = [&](const std::string& from, const std::string& to) {
    std::string s = orb;
    s.replace(s.find(from), from.size(), to);
    return s;
  };
  const std::vector<Case> cases = {
      {replace("Camera.fy: 516.469215", "Camera.fz: 1"), "Camera.fy: missing"},
      {replace("Camera.fx: 517.306408", "Camera.fx: -517"), "Camera.fx: must be > 0"},
      {replace("Camera.cx: 318.643040", "Camera.cx: left"), "Camera.cx: expected a number"},
      {replace("DepthMapFactor: 5000.0", "DepthMapFactor: 0"), "DepthMapFactor: must be > 0"},
      {replace("Camera.width: 640", "Camera.width: 640.5"), "Camera.width: must be a pixel count"},
      {"%YAML:1.0\nfocal: 500\n", "unknown camera file"},
      {opencv_style("depth_camera_matrix: !!opencv-matrix\n  rows: 3\n  cols: 3\n  dt: d\n"
                    "  data: [ 60., 0., 31.5, 0., 61., 23.5, 0., 0., 1. ]\n"),
       "T_colour_depth: missing"},
      {opencv_style("depth_camera_matrix: !!opencv-matrix\n  rows: 3\n  cols: 3\n  dt: d\n"
                    "  data: [ 60., 0., 31.5, 0., 61., 23.5, 0., 0., 1. ]\n"
                    "T_colour_depth: !!opencv-matrix\n  rows: 4\n  cols: 4\n  dt: d\n"
                    "  data: [ 2., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1. ]\n"),
       "not a rotation"},
      {opencv_style("min_depth_m: 5\n"), "greater than min_depth_m"},
      // not a map: OpenCV's FileNode::operator[] asserted (fuzz camera_yaml)
      {"%YAML:1.0\nimage_width: 64\nimage_height: 48\ncamera_matrix: 5\n",
       "camera_matrix: expected an !!opencv-matrix"},
      // a list at the top level: OpenCV's FileNode::operator[] asserted (fuzz camera_yaml,
      // session 12: crash-cv-assert-top-level-list.yaml)
      {"%YAML:1.0\n- Camera.fx: 500\n", "its top level is a list or a value, not keys"},
      // lists left open at the end: OpenCV's YAML parser looped for ever (fuzz camera_yaml,
      // session 12: crash-timeout-unclosed-flow-lists.yaml)
      {"%YAML:1.0\nCamera.fx: 500\nCamera.k1: [[[4, 6., [[\n", "line 3: a list or map"},
      {"%YAML:1.0\nCamera.fx: [[[[[[[[[1]]]]]]]]]\n", "nested more than 8 deep"},
      // OpenCV allocates rows x cols before it reads the data (fuzz camera_yaml: 64 GB)
      {opencv_style("depth_camera_matrix: !!opencv-matrix\n  rows: 100000\n  cols: 100000\n"
                    "  dt: d\n  data: [ 1. ]\n" +
                    kIdentityColourDepth),
       "depth_camera_matrix: rows 100000 and cols 100000: each must be 1 to 16"},
      {opencv_style("depth_camera_matrix: !!opencv-matrix\n  rows: 3\n  cols: 3\n  dt: d\n"
                    "  data: [ 1., 2. ]\n" +
                    kIdentityColourDepth),
       "depth_camera_matrix: 2 data values for 3 x 3"},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    const std::string path = dir + "/c" + std::to_string(i) + ".yaml";
    test::write_text(path, cases[i].text);
    test::expect_io_error_naming([&] { read_camera_file(path); }, cases[i].needle);
    test::expect_io_error_naming([&] { read_camera_file(path); }, path);
  }
  test::expect_io_error_naming([&] { read_camera_file(dir + "/none.yaml"); }, "not found");
}

/// Smooth colour pattern with detail everywhere (period ~10 pixels), so resampling is exact enough.
ColorImage pattern(int w, int h) {
  ColorImage c(w, h);
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u)
      c.at(u, v) = {static_cast<uint8_t>(128 + 100 * std::sin(u * 0.6) * std::cos(v * 0.6)),
                    static_cast<uint8_t>(4 * u % 256), static_cast<uint8_t>(5 * v % 256)};
  return c;
}

/// The image a lens with distortion `D` would see of the ideal image `ideal` (same K).
ColorImage distort(const ColorImage& ideal, const cv::Mat& K, const cv::Mat& D) {
  std::vector<cv::Point2f> px;
  for (int v = 0; v < ideal.height(); ++v)
    for (int u = 0; u < ideal.width(); ++u) px.emplace_back(u, v);
  std::vector<cv::Point2f> undist;
  cv::undistortPoints(px, undist, K, D, cv::noArray(),
                      K);  // ideal pixel seen at each distorted one
  cv::Mat mapx(ideal.height(), ideal.width(), CV_32F), mapy(ideal.height(), ideal.width(), CV_32F);
  for (size_t i = 0; i < px.size(); ++i) {
    mapx.at<float>(static_cast<int>(px[i].y), static_cast<int>(px[i].x)) = undist[i].x;
    mapy.at<float>(static_cast<int>(px[i].y), static_cast<int>(px[i].x)) = undist[i].y;
  }
  const cv::Mat src(ideal.height(), ideal.width(), CV_8UC3, const_cast<Rgb8*>(ideal.data()));
  cv::Mat dst;
  cv::remap(src, dst, mapx, mapy, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
  ColorImage out(ideal.width(), ideal.height());
  std::memcpy(out.data(), dst.data, out.size() * 3);
  return out;
}

double mean_abs_diff(const ColorImage& a, const ColorImage& b, int border) {
  double sum = 0;
  long n = 0;
  for (int v = border; v < a.height() - border; ++v)
    for (int u = border; u < a.width() - border; ++u) {
      sum += std::abs(a.at(u, v).r - b.at(u, v).r);
      ++n;
    }
  return sum / n;
}

TEST(CameraFile, UndistortionRecoversTheIdealImage) {
  const std::string dir = test::scratch_dir("undist");
  test::write_text(dir + "/cv.yaml", opencv_style());
  const CameraFileInfo cam = read_camera_file(dir + "/cv.yaml");
  const cv::Mat K = (cv::Mat_<double>(3, 3) << 60, 0, 31.5, 0, 61, 23.5, 0, 0, 1);
  const cv::Mat D = (cv::Mat_<double>(1, 5) << -0.2, 0.05, 0.001, -0.002, 0);
  const ColorImage ideal = pattern(64, 48);
  RgbdFrame f;
  f.color = distort(ideal, K, D);
  f.depth = DepthImage(64, 48, 1.0f);
  const double before = mean_abs_diff(f.color, ideal, 6);
  apply_camera_file(cam, "synthetic", f);
  const double after = mean_abs_diff(f.color, ideal, 6);
  EXPECT_GT(before, 8.0);  // the lens moves the pattern by pixels near the border
  EXPECT_LT(after, 0.4 * before) << "before " << before << " after " << after;
  EXPECT_DOUBLE_EQ(f.intrinsics.fx, 60.0);
  // The depth range of the file applies: 4.5 m at most.
  f.depth = DepthImage(64, 48, 5.0f);
  f.color = ideal;
  apply_camera_file(cam, "synthetic", f);
  EXPECT_EQ(f.depth.at(30, 20), 0.0f);
  // Images of another size than the file's are an error naming the frame and the file.
  f.color = ColorImage(32, 24);
  test::expect_io_error_naming([&] { apply_camera_file(cam, "frame7.png", f); }, "frame7.png");
}

/// Depth of the analytic scene (a plane z = 2 + 0.3 x, a sphere of radius 0.25 at (0.1, 0, 1.2) in
/// the colour frame) along the ray of pixel (u, v) of a camera at T_colour_cam with intrinsics K:
/// z in that camera's frame, 0 when nothing is hit.
double ray_depth(double u, double v, const PinholeIntrinsics& K, const SE3& T_colour_cam) {
  const Vec3 d_cam((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);
  const Vec3 o = T_colour_cam.translation(), d = T_colour_cam.rotation() * d_cam;
  double best = INFINITY;
  const Vec3 c(0.1, 0.0, 1.2);
  const double r = 0.25, b = d.dot(o - c), q = (o - c).squaredNorm() - r * r;
  const double disc = b * b - d.squaredNorm() * q;
  if (disc >= 0) best = (-b - std::sqrt(disc)) / d.squaredNorm();
  // plane: z - 0.3 x = 2
  const double denom = d.z() - 0.3 * d.x();
  if (std::abs(denom) > 1e-9) {
    const double s = (2.0 + 0.3 * o.x() - o.z()) / denom;
    if (s > 0) best = std::min(best, s);
  }
  return std::isfinite(best) ? best : 0.0;  // d_cam has z = 1: s is the camera-frame z
}

TEST(CameraFile, DepthRegistrationIntoTheColourCameraMatchesGroundTruth) {
  CameraFileInfo cam;
  cam.colour = {160, 120, 150.0, 150.0, 79.5, 59.5};
  cam.has_depth_camera = true;
  cam.depth = {160, 120, 140.0, 141.0, 81.0, 58.0};
  cam.depth_distortion = {-0.1, 0.02, 0.0, 0.0, 0.0};
  // Depth camera 5 cm to the left of the colour camera, turned 2 degrees about y.
  cam.T_colour_depth =
      SE3(Eigen::AngleAxisd(0.035, Vec3::UnitY()).toRotationMatrix(), Vec3(-0.05, 0.002, 0.0));
  // The depth camera's (distorted) image: each distorted pixel sees along its undistorted ray.
  const cv::Mat Kd = (cv::Mat_<double>(3, 3) << 140, 0, 81, 0, 141, 58, 0, 0, 1);
  const cv::Mat Dd = (cv::Mat_<double>(1, 5) << -0.1, 0.02, 0, 0, 0);
  std::vector<cv::Point2f> px, und;
  for (int v = 0; v < 120; ++v)
    for (int u = 0; u < 160; ++u) px.emplace_back(u, v);
  cv::undistortPoints(px, und, Kd, Dd, cv::noArray(), Kd);
  DepthImage raw(160, 120);
  for (size_t i = 0; i < px.size(); ++i)
    raw.at(static_cast<int>(px[i].x), static_cast<int>(px[i].y)) =
        static_cast<float>(ray_depth(und[i].x, und[i].y, cam.depth, cam.T_colour_depth));
  const DepthImage reg = register_depth_to_colour(raw, cam);
  ASSERT_EQ(reg.width(), 160);
  int compared = 0, holes = 0;
  double err_reg = 0, err_raw = 0;
  for (int v = 10; v < 110; ++v)
    for (int u = 10; u < 150; ++u) {
      const double gt = ray_depth(u, v, cam.colour, SE3());
      if (reg.at(u, v) == 0) {
        ++holes;
        continue;
      }
      ++compared;
      err_reg += std::abs(reg.at(u, v) - gt);
      err_raw += std::abs(raw.at(u, v) - gt);
    }
  ASSERT_GT(compared, 0.8 * (compared + holes));  // forward splatting leaves a few holes
  err_reg /= compared, err_raw /= compared;
  EXPECT_LT(err_reg, 0.01) << "mean |registered - truth| m";
  EXPECT_GT(err_raw, 3 * err_reg) << "unregistered depth would be this far off";
}

/// A plain folder of three frames (names by sorted order or by timestamp) and its camera.yaml.
std::string make_plain(const std::string& dir, bool timestamps) {
  for (int i = 0; i < 3; ++i) {
    const std::string rgb =
        timestamps ? fmt::format("{:.6f}", 10 + i / 30.0) : fmt::format("c{:03d}", i);
    const std::string dep =
        timestamps ? fmt::format("{:.6f}", 10 + i / 30.0 + 0.004) : fmt::format("d{:03d}", i);
    write_color_png(dir + "/rgb/" + rgb + ".png", test::tiny_color(i));
    write_depth_png(dir + "/depth/" + dep + ".png", test::tiny_depth(1.0 + 0.1 * i), 1000);
  }
  test::write_text(dir + "/camera.yaml",
                   "%YAML:1.0\nCamera.fx: 7.5\nCamera.fy: 7.6\nCamera.cx: 3.5\nCamera.cy: 2.5\n"
                   "Camera.width: 8\nCamera.height: 6\nDepthMapFactor: 1000\n");
  return dir;
}

TEST(PlainFolder, RgbAndDepthFoldersWithCameraYaml) {
  for (bool stamps : {false, true}) {
    std::filesystem::create_directories(test::scratch_dir("plain") + (stamps ? "/t" : "/n"));
    const std::string dir = make_plain(test::scratch_dir("plain") + (stamps ? "/t" : "/n"), stamps);
    EXPECT_EQ(detect_dataset_format(dir), "plain");
    auto reader = open_dataset(dir, DatasetParams{});
    ASSERT_EQ(reader->size(), 3u);
    EXPECT_DOUBLE_EQ(reader->info().depth_units_per_m, 1000.0);
    EXPECT_DOUBLE_EQ(reader->info().intrinsics.fy, 7.6);
    ASSERT_TRUE(reader->info().camera);
    const RgbdFrame f = reader->read(2);
    EXPECT_NEAR(f.depth.at(3, 2), 1.2 + 0.003, 1e-6);
    EXPECT_EQ(f.color.at(1, 1), test::tiny_color(2).at(1, 1));
    EXPECT_DOUBLE_EQ(f.intrinsics.fx, 7.5);
    if (stamps) {
      EXPECT_NEAR(f.timestamp_s, 10 + 2 / 30.0, 1e-6);
    }
  }
  const std::string dir = make_plain(test::scratch_dir("plain") + "/x", false);
  std::filesystem::remove(dir + "/camera.yaml");
  test::expect_io_error_naming([&] { open_dataset(dir, DatasetParams{}); }, "camera file");
  std::filesystem::remove(dir + "/depth/d002.png");
  DatasetParams p;
  p.fx = p.fy = 7;
  p.depth_units_per_m = 1000;
  test::expect_io_error_naming([&] { open_dataset(dir, p); }, "counts must agree");
}

TEST(PlainFolder, DepthCameraOfHalfTheColourResolutionIsRegisteredWithoutHoles) {
  // Colour 64x48 (fx 60), depth 32x24 (fx 30) from the same centre: a depth pixel covers 2x2
  // colour pixels. A plane at 1.5 m.
  const std::string dir = test::scratch_dir("plain_depth_res");
  write_color_png(dir + "/rgb/000000.png", ColorImage(64, 48, Rgb8{90, 120, 150}));
  write_depth_png(dir + "/depth/000000.png", DepthImage(32, 24, 1.5f), 1000);
  test::write_text(dir + "/camera.yaml",
                   "%YAML:1.0\nimage_width: 64\nimage_height: 48\n"
                   "camera_matrix: !!opencv-matrix\n  rows: 3\n  cols: 3\n  dt: d\n"
                   "  data: [ 60., 0., 31.5, 0., 60., 23.5, 0., 0., 1. ]\n"
                   "depth_units_per_m: 1000\n"
                   "depth_camera_matrix: !!opencv-matrix\n  rows: 3\n  cols: 3\n  dt: d\n"
                   "  data: [ 30., 0., 15.5, 0., 30., 11.5, 0., 0., 1. ]\n"
                   "depth_image_width: 32\ndepth_image_height: 24\n"
                   "T_colour_depth: !!opencv-matrix\n  rows: 4\n  cols: 4\n  dt: d\n"
                   "  data: [ 1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1. ]\n");
  const RgbdFrame f = open_dataset(dir, DatasetParams{})->read(0);
  ASSERT_EQ(f.depth.width(), 64);
  ASSERT_EQ(f.depth.height(), 48);
  EXPECT_EQ(f.intrinsics.width, 64);
  int holes = 0;
  for (float z : f.depth) {
    holes += z == 0;
    if (z != 0) {
      EXPECT_NEAR(z, 1.5f, 1e-6);
    }
  }
  EXPECT_EQ(holes, 0) << "each coarse depth pixel fills its 2x2 colour footprint";
  // Without a depth camera in the camera file, differing sizes are an error naming both.
  test::write_text(dir + "/camera.yaml",
                   "%YAML:1.0\nimage_width: 64\nimage_height: 48\n"
                   "camera_matrix: !!opencv-matrix\n  rows: 3\n  cols: 3\n  dt: d\n"
                   "  data: [ 60., 0., 31.5, 0., 60., 23.5, 0., 0., 1. ]\n"
                   "depth_units_per_m: 1000\n");
  test::expect_io_error_naming([&] { open_dataset(dir, DatasetParams{})->read(0); },
                               "depth is 32x24 but colour image");
}

TEST(CameraFile, SensorPresetsByNameWhenNoSuchFileExists) {
  const CameraFileInfo d435 = read_camera_file("realsense_d435");
  EXPECT_EQ(d435.path, "preset:realsense_d435");
  EXPECT_NEAR(d435.colour.fx, 612.405, 1e-9);
  EXPECT_EQ(d435.colour.width, 640);
  EXPECT_DOUBLE_EQ(d435.depth_units_per_m, 1000.0);
  EXPECT_FALSE(d435.has_depth_camera);  // depth aligned to colour by the driver
  const CameraFileInfo kinect = read_camera_file("kinect_v1");
  EXPECT_DOUBLE_EQ(kinect.colour.fx, 525.0);
  EXPECT_DOUBLE_EQ(kinect.colour.cy, 239.5);
  EXPECT_EQ(read_camera_file("azure_kinect_720p").colour.width, 1280);
  for (const std::string& name : camera_preset_names())
    EXPECT_NO_THROW(read_camera_file(name)) << name;
  // A file of that name wins over the preset; an unknown name lists the presets.
  const std::string dir = test::scratch_dir("presets");
  test::write_text(dir + "/xtion", kOrbSlam2);
  EXPECT_NEAR(read_camera_file(dir + "/xtion").colour.fx, 517.306408, 1e-9);
  test::expect_io_error_naming([&] { read_camera_file("realsense_d999"); },
                               "nor a sensor preset: kinect_v1, xtion, primesense");
}

TEST(CameraFile, OverridesATumFoldersIntrinsicsAndDepthScale) {
  const std::string dir = make_plain(test::scratch_dir("tumcam"), false);
  std::string rgb, depth;
  for (int i = 0; i < 3; ++i) {
    rgb += fmt::format("{} rgb/c{:03d}.png\n", i, i);
    depth += fmt::format("{} depth/d{:03d}.png\n", i, i);
  }
  test::write_text(dir + "/rgb.txt", rgb);
  test::write_text(dir + "/depth.txt", depth);
  EXPECT_EQ(detect_dataset_format(dir), "tum");
  auto plain_tum = open_dataset(dir, DatasetParams{});  // TUM preset: 5000 per metre, fx 525
  EXPECT_NEAR(plain_tum->read(0).depth.at(3, 2), (1.0 + 0.003) / 5, 1e-6);
  DatasetParams p;
  p.camera_file = dir + "/camera.yaml";
  auto reader = open_dataset(dir, p);
  EXPECT_NEAR(reader->read(0).depth.at(3, 2), 1.0 + 0.003, 1e-6);
  EXPECT_DOUBLE_EQ(reader->read(0).intrinsics.fx, 7.5);
  EXPECT_DOUBLE_EQ(reader->read_annotations(0).intrinsics.cy, 2.5);
}

TEST(ModelsFolder, NamesUnitsIdsAndSymmetrySidecar) {
  const std::string dir = test::scratch_dir("models");
  PlyWriteOptions mm;  // millimetres
  std::filesystem::create_directories(dir + "/mm/mug");
  write_ply(dir + "/mm/box.ply", make_box(Eigen::Vector3f(0.1f, 0.05f, 0.04f), 0.02f), mm);
  write_ply(dir + "/mm/mug/mug.ply", make_box(Eigen::Vector3f(0.08f, 0.08f, 0.1f), 0.02f), mm);
  test::write_text(dir + "/mm/mug/notes.txt", "not a mesh");
  DatasetInfo info;
  info.class_names = {{4, "mug"}};  // the dataset's own id for the same name is kept
  apply_models_folder(info, dir + "/mm", "");
  EXPECT_DOUBLE_EQ(info.model_units_per_m, 1000.0);  // detected: diagonals ~ 100 file units
  ASSERT_EQ(info.model_mesh_paths.size(), 2u);
  EXPECT_EQ(info.class_names.at(4), "mug");
  EXPECT_EQ(info.class_names.at(1), "box");
  EXPECT_EQ(info.model_mesh_paths.at(4), dir + "/mm/mug/mug.ply");
  // Stated unit wins; a mix of sizes that fits neither is an error asking for it.
  DatasetInfo stated;
  apply_models_folder(stated, dir + "/mm", "m");
  EXPECT_DOUBLE_EQ(stated.model_units_per_m, 1.0);
  PlyWriteOptions metres;
  metres.units_per_metre = 1.0;
  write_ply(dir + "/mm/tiny.ply", make_box(Eigen::Vector3f(0.1f, 0.05f, 0.04f), 0.02f), metres);
  DatasetInfo mixed;
  test::expect_io_error_naming([&] { apply_models_folder(mixed, dir + "/mm", ""); },
                               "set dataset.models_unit=m or mm");
  std::filesystem::remove(dir + "/mm/tiny.ply");
  // symmetry.yaml: stated symmetries, checked names and values with line numbers.
  test::write_text(dir + "/mm/symmetry.yaml", "box: flip x y\nmug: continuous z\n");
  DatasetInfo sym;
  apply_models_folder(sym, dir + "/mm", "mm");
  ASSERT_EQ(sym.model_symmetry.size(), 2u);
  EXPECT_TRUE(sym.model_symmetry.at(2).continuous);
  EXPECT_EQ(sym.model_symmetry.at(1).flip_axes.size(), 2u);
  EXPECT_EQ(sym.symmetric_classes.size(), 2u);
  EXPECT_TRUE(parse_symmetry_spec("symmetric")->detected);
  EXPECT_FALSE(parse_symmetry_spec("auto").has_value());
  EXPECT_THROW(parse_symmetry_spec("flip w"), std::invalid_argument);
  test::write_text(dir + "/mm/symmetry.yaml", "box: none\nmug: spin z\n");
  test::expect_io_error_naming([&] { apply_models_folder(sym, dir + "/mm", "mm"); }, "line 2");
  test::write_text(dir + "/mm/symmetry.yaml", "bowl: none\n");
  test::expect_io_error_naming([&] { apply_models_folder(sym, dir + "/mm", "mm"); },
                               "no model named 'bowl'");
  // A key that is not a plain name (fuzz: the bare YAML::BadConversion it made escaped).
  test::write_text(dir + "/mm/symmetry.yaml", "box: none\n? [mug, box]\n: none\n");
  test::expect_io_error_naming([&] { apply_models_folder(sym, dir + "/mm", "mm"); },
                               "line 2: a model name must be a plain word");
  std::filesystem::remove(dir + "/mm/symmetry.yaml");
  // Two meshes in one object folder without a textured.obj: which one is meant is unclear.
  write_ply(dir + "/mm/mug/mug2.ply", make_box(Eigen::Vector3f(0.08f, 0.08f, 0.1f), 0.02f), mm);
  test::expect_io_error_naming([&] { apply_models_folder(sym, dir + "/mm", "mm"); },
                               "2 mesh files");
  test::expect_io_error_naming([&] { apply_models_folder(sym, dir + "/none", "mm"); }, "not found");
}

TEST(ModelsFolder, OverridesTheDatasetsModelsThroughOpenDataset) {
  const std::string dir = make_plain(test::scratch_dir("plainmodels"), false);
  write_ply(dir + "/../models/obj_000007.ply",
            make_box(Eigen::Vector3f(0.1f, 0.05f, 0.04f), 0.02f));
  DatasetParams p;
  p.models_dir = dir + "/../models";
  auto reader = open_dataset(dir, p);
  ASSERT_EQ(reader->info().model_points_paths.count(7), 1u);  // obj_NNNNNN keeps its number
  EXPECT_DOUBLE_EQ(reader->info().model_units_per_m, 1000.0);
  p.models_unit = "cm";
  EXPECT_THROW(open_dataset(dir, p), ConfigError);
}

}  // namespace
}  // namespace orpe
