#include "orpe/io/image_io.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <vector>

#include "orpe/core/atomic_file.h"
#include "orpe/core/error.h"

namespace orpe {
namespace {

cv::Mat imread_checked(const std::string& path, int flags) {
  // Without an error code, status() throws a bare filesystem_error for a name it cannot look up
  // (fuzz tum_index: a file name of 300 characters in rgb.txt, "File name too long").
  std::error_code ec;
  const std::filesystem::file_status st = std::filesystem::status(path, ec);
  if (!std::filesystem::exists(st))
    throw IoError(path, ec && ec != std::errc::no_such_file_or_directory
                            ? "cannot access the file: " + ec.message()
                            : std::string("file not found"));
  // A FIFO or device would block the reader for ever; a folder is a mistake.
  if (!std::filesystem::is_regular_file(st)) throw IoError(path, "not a regular file");
  cv::Mat m;
  try {
    m = cv::imread(path, flags);
  } catch (const cv::Exception& e) {
    throw IoError(path, std::string("cannot decode image: ") + e.what());
  }
  if (m.empty()) throw IoError(path, "cannot decode image (truncated or corrupt?)");
  return m;
}

void imwrite_atomic(const std::string& path, const cv::Mat& m) {
  std::filesystem::path p(path);
  if (p.has_parent_path()) std::filesystem::create_directories(p.parent_path());
  const std::string tmp = temp_path_for(path);
  bool ok = false;
  try {
    ok = cv::imwrite(tmp, m);
  } catch (const cv::Exception& e) {
    std::filesystem::remove(tmp);
    throw IoError(path, std::string("cannot encode image: ") + e.what());
  }
  if (!ok) {
    std::filesystem::remove(tmp);
    throw IoError(path, "cannot write image");
  }
  commit_temp_file(tmp, path);
}

bool is_jpeg_file(const std::string& path) {
  std::ifstream is(path, std::ios::binary);
  unsigned char magic[2] = {0, 0};
  is.read(reinterpret_cast<char*>(magic), 2);
  return is && magic[0] == 0xFF && magic[1] == 0xD8;
}

// libjpeg decodes a truncated file with a warning and grey fill; a complete JPEG ends with FF D9
// (some writers pad a few bytes after it, so look at the tail).
bool jpeg_has_end_marker(const std::string& path) {
  std::ifstream is(path, std::ios::binary | std::ios::ate);
  const std::streamoff size = is.tellg();
  const std::streamoff tail = std::min<std::streamoff>(size, 64);
  std::vector<char> buf(static_cast<size_t>(tail));
  is.seekg(size - tail);
  is.read(buf.data(), tail);
  if (!is) return false;
  for (std::streamoff i = tail - 2; i >= 0; --i)
    if (static_cast<unsigned char>(buf[i]) == 0xFF &&
        static_cast<unsigned char>(buf[i + 1]) == 0xD9)
      return true;
  return false;
}

}  // namespace

ColorImage read_color_image(const std::string& path) {
  cv::Mat m = imread_checked(path, cv::IMREAD_UNCHANGED);
  if (is_jpeg_file(path) && !jpeg_has_end_marker(path))
    throw IoError(path, "truncated JPEG (no end-of-image marker)");
  if (m.depth() != CV_8U) throw IoError(path, "expected an 8-bit colour image");
  ColorImage out(m.cols, m.rows);
  const int ch = m.channels();
  for (int v = 0; v < m.rows; ++v) {
    const uint8_t* row = m.ptr<uint8_t>(v);
    for (int u = 0; u < m.cols; ++u) {
      const uint8_t* px = row + u * ch;
      if (ch >= 3)
        out.at(u, v) = {px[2], px[1], px[0]};  // OpenCV stores BGR(A)
      else
        out.at(u, v) = {px[0], px[0], px[0]};
    }
  }
  return out;
}

DepthImage read_depth_image(const std::string& path, double depth_units_per_m,
                            DepthReadStats* stats) {
  if (!(depth_units_per_m > 0) || !std::isfinite(depth_units_per_m))
    throw IoError(path, "depth scale must be positive (units per metre), got " +
                            std::to_string(depth_units_per_m));
  cv::Mat m = imread_checked(path, cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR);
  if (m.channels() != 1)
    throw IoError(path, "depth image must have one channel, has " + std::to_string(m.channels()));
  DepthImage out(m.cols, m.rows, 0.0f);
  size_t invalid = 0, nonfinite_or_negative = 0;
  if (m.depth() == CV_16U) {
    const float s = static_cast<float>(1.0 / depth_units_per_m);
    for (int v = 0; v < m.rows; ++v) {
      const uint16_t* row = m.ptr<uint16_t>(v);
      for (int u = 0; u < m.cols; ++u) {
        if (row[u] == 0)
          ++invalid;
        else
          out.at(u, v) = row[u] * s;
      }
    }
  } else if (m.depth() == CV_32F) {
    for (int v = 0; v < m.rows; ++v) {
      const float* row = m.ptr<float>(v);
      for (int u = 0; u < m.cols; ++u) {
        const float z = row[u];
        if (!std::isfinite(z) || z < 0.0f) ++nonfinite_or_negative;
        if (!std::isfinite(z) || z <= 0.0f)
          ++invalid;
        else
          out.at(u, v) = z;
      }
    }
  } else {
    throw IoError(path, "depth image must be 16-bit unsigned (or 32-bit float metres)");
  }
  if (stats) {
    stats->invalid_pixels = invalid;
    stats->nonfinite_or_negative_pixels = nonfinite_or_negative;
  }
  return out;
}

LabelImage read_label_image(const std::string& path) {
  cv::Mat m = imread_checked(path, cv::IMREAD_ANYDEPTH | cv::IMREAD_GRAYSCALE);
  if (m.channels() != 1) throw IoError(path, "label image must have one channel");
  cv::Mat m32;
  if (m.depth() == CV_8U || m.depth() == CV_16U)
    m.convertTo(m32, CV_32S);
  else
    throw IoError(path, "label image must be 8- or 16-bit");
  LabelImage out(m.cols, m.rows);
  for (int v = 0; v < m.rows; ++v) std::copy_n(m32.ptr<int32_t>(v), m.cols, out.row(v));
  return out;
}

void write_color_png(const std::string& path, const ColorImage& image) {
  cv::Mat m(image.height(), image.width(), CV_8UC3);
  for (int v = 0; v < image.height(); ++v)
    for (int u = 0; u < image.width(); ++u) {
      const Rgb8 c = image.at(u, v);
      m.at<cv::Vec3b>(v, u) = {c.b, c.g, c.r};
    }
  imwrite_atomic(path, m);
}

void write_depth_png(const std::string& path, const DepthImage& depth, double depth_units_per_m) {
  if (!(depth_units_per_m > 0)) throw IoError(path, "depth scale must be positive");
  cv::Mat m(depth.height(), depth.width(), CV_16UC1);
  for (int v = 0; v < depth.height(); ++v)
    for (int u = 0; u < depth.width(); ++u) {
      const double z = depth.at(u, v);
      const double q = std::isfinite(z) && z > 0 ? std::round(z * depth_units_per_m) : 0.0;
      m.at<uint16_t>(v, u) = static_cast<uint16_t>(std::min(q, 65535.0));
    }
  imwrite_atomic(path, m);
}

void write_label_png(const std::string& path, const LabelImage& labels, bool eight_bit) {
  int maxv = 0;
  for (int32_t l : labels) maxv = std::max(maxv, l);
  const bool use8 = eight_bit && maxv < 256;
  cv::Mat m(labels.height(), labels.width(), use8 ? CV_8UC1 : CV_16UC1);
  for (int v = 0; v < labels.height(); ++v)
    for (int u = 0; u < labels.width(); ++u) {
      const int32_t l = std::clamp(labels.at(u, v), 0, 65535);
      if (use8)
        m.at<uint8_t>(v, u) = static_cast<uint8_t>(l);
      else
        m.at<uint16_t>(v, u) = static_cast<uint16_t>(l);
    }
  imwrite_atomic(path, m);
}

void write_mask_png(const std::string& path, const MaskImage& mask) {
  cv::Mat m(mask.height(), mask.width(), CV_8UC1);
  for (int v = 0; v < mask.height(); ++v)
    for (int u = 0; u < mask.width(); ++u) m.at<uint8_t>(v, u) = mask.at(u, v) ? 255 : 0;
  imwrite_atomic(path, m);
}

void write_gray_png(const std::string& path, const Image<float>& image, float lo, float hi) {
  cv::Mat m(image.height(), image.width(), CV_8UC1);
  const float span = hi > lo ? hi - lo : 1.0f;
  for (int v = 0; v < image.height(); ++v)
    for (int u = 0; u < image.width(); ++u) {
      const float x = std::isfinite(image.at(u, v)) ? (image.at(u, v) - lo) / span : 0.0f;
      m.at<uint8_t>(v, u) = static_cast<uint8_t>(std::clamp(x, 0.0f, 1.0f) * 255.0f + 0.5f);
    }
  imwrite_atomic(path, m);
}

}  // namespace orpe
