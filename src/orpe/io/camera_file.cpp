#include "orpe/io/camera_file.h"

#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "orpe/core/error.h"

namespace orpe {
namespace {

/// Named access to a FileStorage with the checks every key needs.
class Keys {
 public:
  Keys(const cv::FileStorage& fs, std::string path) : fs_(fs), path_(std::move(path)) {}
  bool has(const std::string& key) const { return !fs_[key].empty() && !fs_[key].isNone(); }
  [[noreturn]] void fail(const std::string& key, const std::string& what) const {
    throw IoError(path_, key + ": " + what);
  }
  double number(const std::string& key) const {
    const cv::FileNode n = fs_[key];
    if (n.empty() || n.isNone()) fail(key, "missing");
    if (!n.isInt() && !n.isReal()) fail(key, "expected a number");
    const double v = n.real();
    if (!std::isfinite(v)) fail(key, "not a finite number");
    return v;
  }
  double number_or(const std::string& key, double fallback) const {
    return has(key) ? number(key) : fallback;
  }
  double positive(const std::string& key) const {
    const double v = number(key);
    if (!(v > 0)) fail(key, fmt::format("must be > 0 (got {})", v));
    return v;
  }
  int size_or(const std::string& key) const {
    if (!has(key)) return 0;
    const double v = positive(key);
    if (v != std::floor(v) || v > 100000)
      fail(key, fmt::format("must be a pixel count (got {})", v));
    return static_cast<int>(v);
  }
  /// An !!opencv-matrix of at most kMaxSide x kMaxSide values. Its rows, cols and data are checked
  /// before OpenCV reads it: OpenCV allocates rows x cols first (fuzz camera_yaml:
  /// crash-oom-matrix-rows.yaml, a mangled rows: line made it ask for 64 GB).
  cv::Mat matrix(const std::string& key) const {
    constexpr int kMaxSide = 16;
    const cv::FileNode n = fs_[key];
    if (n.empty() || n.isNone()) fail(key, "missing or not an !!opencv-matrix");
    if (!n.isMap()) fail(key, "expected an !!opencv-matrix (integer rows and cols, a data list)");
    const cv::FileNode rows = n["rows"], cols = n["cols"], data = n["data"];
    if (!rows.isInt() || !cols.isInt() || !data.isSeq())
      fail(key, "expected an !!opencv-matrix (integer rows and cols, a data list)");
    if (static_cast<int>(rows) < 1 || static_cast<int>(rows) > kMaxSide ||
        static_cast<int>(cols) < 1 || static_cast<int>(cols) > kMaxSide)
      fail(key, fmt::format("rows {} and cols {}: each must be 1 to {}", static_cast<int>(rows),
                            static_cast<int>(cols), kMaxSide));
    if (data.size() != static_cast<size_t>(static_cast<int>(rows) * static_cast<int>(cols)))
      fail(key, fmt::format("{} data values for {} x {}", data.size(), static_cast<int>(rows),
                            static_cast<int>(cols)));
    cv::Mat m;
    try {
      n >> m;
    } catch (const cv::Exception&) {
      fail(key, "expected an !!opencv-matrix");
    }
    if (m.empty()) fail(key, "missing or not an !!opencv-matrix");
    m.convertTo(m, CV_64F);
    for (int i = 0; i < static_cast<int>(m.total()); ++i)
      if (!std::isfinite(m.at<double>(i))) fail(key, "has a non-finite value");
    return m;
  }
  const std::string& path() const { return path_; }

 private:
  const cv::FileStorage& fs_;
  std::string path_;
};

PinholeIntrinsics intrinsics_from_matrix(const Keys& k, const std::string& key) {
  const cv::Mat K = k.matrix(key);
  if (K.rows != 3 || K.cols != 3) k.fail(key, "expected a 3x3 camera matrix");
  PinholeIntrinsics in;
  in.fx = K.at<double>(0, 0), in.fy = K.at<double>(1, 1);
  in.cx = K.at<double>(0, 2), in.cy = K.at<double>(1, 2);
  if (!(in.fx > 0) || !(in.fy > 0)) k.fail(key, "focal lengths must be > 0");
  return in;
}

std::array<double, 5> distortion_from_matrix(const Keys& k, const std::string& key) {
  std::array<double, 5> d{};
  if (!k.has(key)) return d;
  const cv::Mat D = k.matrix(key);
  if (D.total() != 4 && D.total() != 5 && D.total() != 8)
    k.fail(key, "expected 4 or 5 coefficients k1 k2 p1 p2 [k3]");
  if (D.total() == 8)
    for (int i = 5; i < 8; ++i)
      if (D.at<double>(i) != 0) k.fail(key, "rational coefficients k4..k6 are not supported");
  for (size_t i = 0; i < std::min<size_t>(5, D.total()); ++i)
    d[i] = D.at<double>(static_cast<int>(i));
  return d;
}

/// ORB-SLAM2 (prefix "Camera.") or ORB-SLAM3 (prefix "Camera1.") pinhole + radial-tangential.
void read_orbslam(const Keys& k, const std::string& prefix, CameraFileInfo& c) {
  c.colour.fx = k.positive(prefix + "fx");
  c.colour.fy = k.positive(prefix + "fy");
  c.colour.cx = k.number(prefix + "cx");
  c.colour.cy = k.number(prefix + "cy");
  const char* names[5] = {"k1", "k2", "p1", "p2", "k3"};
  for (int i = 0; i < 5; ++i) c.colour_distortion[i] = k.number_or(prefix + names[i], 0.0);
  c.colour.width = k.size_or("Camera.width");
  c.colour.height = k.size_or("Camera.height");
  for (const char* key : {"DepthMapFactor", "RGBD.DepthMapFactor"})
    if (k.has(key)) c.depth_units_per_m = k.positive(key);
}

void read_opencv_style(const Keys& k, CameraFileInfo& c) {
  const PinholeIntrinsics K = intrinsics_from_matrix(k, "camera_matrix");
  c.colour.fx = K.fx, c.colour.fy = K.fy, c.colour.cx = K.cx, c.colour.cy = K.cy;
  c.colour_distortion = distortion_from_matrix(k, "distortion_coefficients");
  c.colour.width = k.size_or("image_width");
  c.colour.height = k.size_or("image_height");
  if (k.has("depth_units_per_m")) c.depth_units_per_m = k.positive("depth_units_per_m");
}

/// The optional extras of every shape: a separate depth camera and the depth range.
void read_depth_camera(const Keys& k, CameraFileInfo& c) {
  const bool has_K = k.has("depth_camera_matrix"), has_T = k.has("T_colour_depth");
  if (has_K != has_T)
    k.fail(
        has_K ? "T_colour_depth" : "depth_camera_matrix",
        "missing: an unregistered depth camera needs both depth_camera_matrix and T_colour_depth");
  if (has_K) {
    c.has_depth_camera = true;
    c.depth = intrinsics_from_matrix(k, "depth_camera_matrix");
    c.depth.width = k.size_or("depth_image_width");
    c.depth.height = k.size_or("depth_image_height");
    c.depth_distortion = distortion_from_matrix(k, "depth_distortion_coefficients");
    const cv::Mat T = k.matrix("T_colour_depth");
    if (T.rows != 4 || T.cols != 4) k.fail("T_colour_depth", "expected a 4x4 matrix");
    Mat3 R;
    Vec3 t;
    for (int r = 0; r < 3; ++r) {
      for (int col = 0; col < 3; ++col) R(r, col) = T.at<double>(r, col);
      t[r] = T.at<double>(r, 3);
    }
    if ((R * R.transpose() - Mat3::Identity()).norm() > 1e-3 || R.determinant() < 0 ||
        std::abs(T.at<double>(3, 3) - 1) > 1e-9)
      k.fail("T_colour_depth",
             "the rotation part is not a rotation (or the last row is not 0 0 0 1)");
    if (t.norm() > 1.0) k.fail("T_colour_depth", "translation over 1 m: metres expected");
    c.T_colour_depth = SE3(orthonormalize(R), t);
  }
  c.min_depth_m = k.number_or("min_depth_m", 0.0);
  c.max_depth_m = k.number_or("max_depth_m", 0.0);
  if (c.min_depth_m < 0 || c.max_depth_m < 0) k.fail("min_depth_m", "depth limits must be >= 0");
  if (c.max_depth_m > 0 && c.min_depth_m >= c.max_depth_m)
    k.fail("max_depth_m", "must be greater than min_depth_m");
}

cv::Mat K_of(const PinholeIntrinsics& k) {
  return (cv::Mat_<double>(3, 3) << k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
}
cv::Mat D_of(const std::array<double, 5>& d) {
  return cv::Mat(1, 5, CV_64F, const_cast<double*>(d.data())).clone();
}
bool distorted(const std::array<double, 5>& d) {
  return std::any_of(d.begin(), d.end(), [](double x) { return x != 0; });
}

/// Undistorts an image into the same K (remap with `interp`).
template <class T>
void undistort_in_place(Image<T>& img, const PinholeIntrinsics& K, const std::array<double, 5>& d,
                        int cv_type, int interp) {
  if (img.empty() || !distorted(d)) return;
  cv::Mat map1, map2;
  cv::initUndistortRectifyMap(K_of(K), D_of(d), cv::Mat(), K_of(K), {img.width(), img.height()},
                              CV_32FC1, map1, map2);
  const cv::Mat src(img.height(), img.width(), cv_type, img.data());
  cv::Mat dst;
  cv::remap(src, dst, map1, map2, interp, cv::BORDER_CONSTANT, cv::Scalar::all(0));
  std::memcpy(img.data(), dst.data, img.size() * sizeof(T));
}

void check_size(const PinholeIntrinsics& k, int w, int h, const std::string& what,
                const CameraFileInfo& c, const std::string& frame) {
  if ((k.width > 0 && k.width != w) || (k.height > 0 && k.height != h))
    throw IoError(frame, fmt::format("{} image is {}x{} but the camera file {} says {}x{}", what, w,
                                     h, c.path, k.width, k.height));
}

}  // namespace

namespace {

/// Built-in cameras (docs/DATASETS.md "Sensor presets"): nominal values, not a calibration. Each
/// depth is registered to colour (the driver's registered / aligned stream), in millimetres.
struct CameraPreset {
  const char* name;
  const char* yaml;
};

const CameraPreset kPresets[] = {
    // PrimeSense family (Kinect v1, Asus Xtion Pro Live) through OpenNI: the ROS openni_camera
    // defaults, as TUM RGB-D's "ROS default" intrinsics; registered depth in mm.
    {"primesense",
     "%YAML:1.0\nCamera.fx: 525.0\nCamera.fy: 525.0\nCamera.cx: 319.5\nCamera.cy: 239.5\n"
     "Camera.width: 640\nCamera.height: 480\nDepthMapFactor: 1000.0\n"},
    // Intel RealSense D435 colour at 640x480, depth aligned to colour (Z16, 1 mm units): the
    // factory values of one unit (librealsense issue #7300, rs-enumerate-devices -c).
    {"realsense_d435",
     "%YAML:1.0\nCamera.fx: 612.405\nCamera.fy: 610.649\nCamera.cx: 314.251\nCamera.cy: "
     "237.778\nCamera.width: 640\nCamera.height: 480\nDepthMapFactor: 1000.0\n"},
    // Microsoft Azure Kinect colour at 1280x720, depth transformed to colour (k4a
    // depth_to_color, mm): one unit's 1920x1080 factory values (pyk4a issue #35) scaled by 2/3.
    {"azure_kinect_720p",
     "%YAML:1.0\nCamera.fx: 612.953\nCamera.fy: 612.920\nCamera.cx: 635.382\nCamera.cy: "
     "367.842\nCamera.width: 1280\nCamera.height: 720\nDepthMapFactor: 1000.0\n"},
};

const CameraPreset* find_preset(const std::string& name) {
  std::string n = name;
  if (n == "kinect_v1" || n == "xtion") n = "primesense";
  for (const CameraPreset& p : kPresets)
    if (n == p.name) return &p;
  return nullptr;
}

}  // namespace

std::vector<std::string> camera_preset_names() {
  std::vector<std::string> out = {"kinect_v1", "xtion"};
  for (const CameraPreset& p : kPresets) out.push_back(p.name);
  return out;
}

namespace {
CameraFileInfo read_camera_keys(const cv::FileStorage& fs, const std::string& path, bool preset);

/// OpenCV's YAML parser can loop for ever on flow lists or maps ("[" / "{") left open at the end of
/// the file (fuzz camera_yaml, session 12: crash-timeout-unclosed-flow-lists.yaml, 296 bytes, more
/// than 2 minutes). A camera file nests them at most 2 deep (a matrix's data list), so lists or
/// maps left open, or nested deeper than 8, are refused before OpenCV parses the file (brackets in
/// comments and quoted strings do not count).
void check_flow_nesting(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  constexpr int kMaxDepth = 8;
  int depth = 0, line = 1, open_line = 0;
  char quote = 0;
  for (size_t i = 0; i < text.size(); ++i) {
    const char ch = text[i];
    if (ch == '\n') {
      ++line, quote = 0;
    } else if (quote) {
      if (ch == quote) quote = 0;
    } else if (ch == '\'' || ch == '"') {
      quote = ch;
    } else if (ch == '#' && (i == 0 || text[i - 1] == ' ' || text[i - 1] == '\t')) {
      while (i + 1 < text.size() && text[i + 1] != '\n') ++i;
    } else if (ch == '[' || ch == '{') {
      if (depth++ == 0) open_line = line;
      if (depth > kMaxDepth)
        throw IoError(
            path, fmt::format("line {}: lists or maps nested more than {} deep", line, kMaxDepth));
    } else if ((ch == ']' || ch == '}') && depth > 0) {
      --depth;
    }
  }
  if (depth > 0)
    throw IoError(path, fmt::format("line {}: a list or map ('[' or '{{') is not closed by the end "
                                    "of the file",
                                    open_line));
}
}  // namespace

CameraFileInfo read_camera_file(const std::string& path) {
  const CameraPreset* preset = std::filesystem::exists(path) ? nullptr : find_preset(path);
  if (!preset && !std::filesystem::is_regular_file(path)) {
    std::string names;
    for (const std::string& n : camera_preset_names()) names += (names.empty() ? "" : ", ") + n;
    throw IoError(path, "camera file not found (nor a sensor preset: " + names + ")");
  }
  if (!preset) check_flow_nesting(path);
  cv::FileStorage fs;
  try {
    if (preset)
      fs.open(preset->yaml,
              cv::FileStorage::READ | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML);
    else
      fs.open(path, cv::FileStorage::READ | cv::FileStorage::FORMAT_YAML);
  } catch (const cv::Exception& e) {
    throw IoError(path, std::string("not a readable YAML camera file: ") + e.what());
  } catch (const std::exception& e) {  // std::length_error from OpenCV's YAML parser (fuzz
                                       // camera_yaml: crash-length-error-yaml.yaml)
    throw IoError(path, std::string("not a readable YAML camera file: ") + e.what());
  }
  if (!fs.isOpened()) throw IoError(path, "not a readable YAML camera file");
  // Keys are looked up in the top-level map: OpenCV's FileNode::operator[] asserts on a list or a
  // value there (fuzz camera_yaml, session 12: crash-cv-assert-top-level-list.yaml).
  if (!fs.root().isMap() && !fs.root().isNone())
    throw IoError(path,
                  "not a camera file: its top level is a list or a value, not keys (name: value)");
  try {
    return read_camera_keys(fs, path, preset != nullptr);
  } catch (const cv::Exception& e) {  // any other OpenCV assertion while reading the keys
    throw IoError(path, std::string("not a readable camera file: ") + e.what());
  }
}

namespace {

CameraFileInfo read_camera_keys(const cv::FileStorage& fs, const std::string& path, bool preset) {
  const Keys k(fs, path);
  CameraFileInfo c;
  c.path = preset ? "preset:" + path : path;
  if (k.has("Camera1.fx")) {
    c.style = "orbslam3";
    read_orbslam(k, "Camera1.", c);
  } else if (k.has("Camera.fx")) {
    c.style = "orbslam2";
    read_orbslam(k, "Camera.", c);
  } else if (k.has("camera_matrix")) {
    c.style = "opencv";
    read_opencv_style(k, c);
  } else {
    throw IoError(path,
                  "unknown camera file: expected Camera.fx (ORB-SLAM2), Camera1.fx "
                  "(ORB-SLAM3) or camera_matrix (OpenCV calibration style)");
  }
  if (k.has("Camera.type") && fs["Camera.type"].isString() &&
      std::string(fs["Camera.type"]) != "PinHole")
    k.fail("Camera.type",
           "only PinHole cameras are supported (got " + std::string(fs["Camera.type"]) + ")");
  read_depth_camera(k, c);
  return c;
}

}  // namespace

DepthImage register_depth_to_colour(const DepthImage& depth, const CameraFileInfo& c) {
  const int w = c.colour.width > 0 ? c.colour.width : depth.width();
  const int h = c.colour.height > 0 ? c.colour.height : depth.height();
  // Undistorted normalised coordinates of every depth pixel centre.
  std::vector<cv::Point2f> px;
  px.reserve(depth.size());
  for (int v = 0; v < depth.height(); ++v)
    for (int u = 0; u < depth.width(); ++u)
      px.emplace_back(static_cast<float>(u), static_cast<float>(v));
  std::vector<cv::Point2f> xn;
  cv::undistortPoints(px, xn, K_of(c.depth), D_of(c.depth_distortion));
  DepthImage out(w, h, 0.0f);
  const Mat3 R = c.T_colour_depth.rotation();
  const Vec3 t = c.T_colour_depth.translation();
  // A depth pixel covers (colour focal / depth focal) x (z_depth / z_colour) colour pixels per
  // side: when depth is coarser than colour (an Azure Kinect's 640x576 depth into 1280x720
  // colour), each point fills its whole footprint, or 3 of 4 colour pixels would stay holes.
  const double sx = c.colour.fx / c.depth.fx, sy = c.colour.fy / c.depth.fy;
  for (int v = 0; v < depth.height(); ++v)
    for (int u = 0; u < depth.width(); ++u) {
      const float z = depth.at(u, v);
      if (!(z > 0)) continue;
      const cv::Point2f& n = xn[static_cast<size_t>(v) * depth.width() + u];
      const Vec3 p = R * Vec3(n.x * z, n.y * z, z) + t;
      if (!(p.z() > 0)) continue;
      const double x = c.colour.fx * p.x() / p.z() + c.colour.cx;
      const double y = c.colour.fy * p.y() / p.z() + c.colour.cy;
      const double hx = 0.5 * sx * z / p.z(), hy = 0.5 * sy * z / p.z();
      // Colour pixels whose centres lie in [x - hx, x + hx) x [y - hy, y + hy); at least the
      // nearest one.
      int u0 = static_cast<int>(std::ceil(x - hx)), u1 = static_cast<int>(std::ceil(x + hx)) - 1;
      int v0 = static_cast<int>(std::ceil(y - hy)), v1 = static_cast<int>(std::ceil(y + hy)) - 1;
      if (hx <= 0.5) u0 = u1 = static_cast<int>(std::lround(x));
      if (hy <= 0.5) v0 = v1 = static_cast<int>(std::lround(y));
      for (int vc = std::max(v0, 0); vc <= std::min(v1, h - 1); ++vc)
        for (int uc = std::max(u0, 0); uc <= std::min(u1, w - 1); ++uc) {
          float& d = out.at(uc, vc);
          if (d == 0 || p.z() < d) d = static_cast<float>(p.z());
        }
    }
  return out;
}

void apply_camera_file(const CameraFileInfo& c, const std::string& frame_name, RgbdFrame& f) {
  check_size(c.colour, f.color.width(), f.color.height(), "colour", c, frame_name);
  PinholeIntrinsics K = c.colour;
  K.width = f.color.width(), K.height = f.color.height();
  undistort_in_place(f.color, K, c.colour_distortion, CV_8UC3, cv::INTER_LINEAR);
  undistort_in_place(f.labels_gt, K, c.colour_distortion, CV_32SC1, cv::INTER_NEAREST);
  if (c.has_depth_camera) {
    check_size(c.depth, f.depth.width(), f.depth.height(), "depth", c, frame_name);
    CameraFileInfo sized = c;
    sized.colour = K;
    f.depth = register_depth_to_colour(f.depth, sized);
  } else {
    undistort_in_place(f.depth, K, c.colour_distortion, CV_32FC1, cv::INTER_NEAREST);
  }
  for (float& d : f.depth)
    if ((c.min_depth_m > 0 && d < c.min_depth_m) || (c.max_depth_m > 0 && d > c.max_depth_m)) d = 0;
  f.intrinsics = K;
}

}  // namespace orpe
