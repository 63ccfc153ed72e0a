// ROS 1 bags (rosbag_storage): colour and depth sensor_msgs/Image topics paired by header stamp
// (within 0.02 s, like TUM's associate.py), intrinsics from a sensor_msgs/CameraInfo topic (its
// plumb_bob distortion undone at load, as a camera file's). No ground truth is read from a bag.
// The bag itself is read through rosbag_messages.h (ORPE_WITH_ROSBAG: Debian's
// librosbag-storage-dev + libsensor-msgs-dev); without it, open_rosbag is a ConfigError saying so.
// See docs/DATASETS.md, "ROS bags".
#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <memory>
#include <mutex>
#include <set>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "orpe/core/error.h"
#include "orpe/io/camera_file.h"
#include "orpe/io/dataset_common.h"
#include "orpe/io/rosbag_messages.h"

namespace orpe::detail {

namespace {

using rosbag_io::BagReader;
using rosbag_io::CameraInfoMessage;
using rosbag_io::ImageMessage;


/// Stamps of the image messages of `topic` with their bag positions, sorted by stamp.
std::vector<std::pair<double, size_t>> image_messages(const BagReader& bag,
                                                      const std::string& topic,
                                                      const std::string& path,
                                                      const std::string& key) {
  std::vector<double> stamps;
  try {
    stamps = bag.image_stamps(topic);
  } catch (const std::runtime_error& e) {
    throw IoError(path, std::string(e.what()) + " (dataset." + key + ")");
  }
  if (stamps.empty())
    throw IoError(path, fmt::format("no sensor_msgs/Image on topic {} (set dataset.{}); the bag "
                                    "has: {}",
                                    topic, key, bag.topics()));
  std::vector<std::pair<double, size_t>> out;
  for (size_t k = 0; k < stamps.size(); ++k) out.emplace_back(stamps[k], k);
  std::stable_sort(out.begin(), out.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  return out;
}

/// Colour and depth messages (sorted by stamp) paired one-to-one like TUM's associate.py
/// (detail::associate_stamps), in colour order.
std::vector<std::pair<size_t, size_t>> pair_by_stamp(
    const std::vector<std::pair<double, size_t>>& colour,
    const std::vector<std::pair<double, size_t>>& depth) {
  std::vector<double> ta, tb;
  for (const auto& c : colour) ta.push_back(c.first);
  for (const auto& d : depth) tb.push_back(d.first);
  return associate_stamps(ta, tb);
}

/// A CameraInfo as a camera (intrinsics, plumb_bob distortion, undone at load like a camera
/// file's).
CameraFileInfo camera_from_info(const CameraInfoMessage& info, const std::string& topic,
                                const std::string& path) {
  CameraFileInfo cam;
  cam.path = path + ":" + topic;
  cam.style = "ros_camera_info";
  cam.colour.fx = info.K[0], cam.colour.cx = info.K[2];
  cam.colour.fy = info.K[4], cam.colour.cy = info.K[5];
  cam.colour.width = static_cast<int>(info.width);
  cam.colour.height = static_cast<int>(info.height);
  if (!(cam.colour.fx > 0 && cam.colour.fy > 0 && std::isfinite(cam.colour.fx) &&
        std::isfinite(cam.colour.fy) && std::isfinite(cam.colour.cx) &&
        std::isfinite(cam.colour.cy)))
    throw IoError(path, fmt::format("CameraInfo on {}: K has no positive finite focal length "
                                    "(fx {}, fy {}); set dataset.fx/fy/cx/cy or --camera FILE",
                                    topic, cam.colour.fx, cam.colour.fy));
  const bool radtan = info.distortion_model.empty() || info.distortion_model == "plumb_bob" ||
                      info.distortion_model == "rational_polynomial";
  bool distorted = false;
  for (size_t i = 0; i < info.D.size(); ++i) {
    if (!std::isfinite(info.D[i]))
      throw IoError(path,
                    fmt::format("CameraInfo on {}: distortion D[{}] is not finite", topic, i));
    distorted = distorted || info.D[i] != 0;
    if (i < 5 && radtan) cam.colour_distortion[i] = info.D[i];
  }
  if (distorted && !radtan)
    throw IoError(path, fmt::format("CameraInfo on {}: distortion model '{}' is not supported "
                                    "(plumb_bob); give the camera with --camera FILE",
                                    topic, info.distortion_model));
  if (info.D.size() > 5 &&
      std::any_of(info.D.begin() + 5, info.D.end(), [](double d) { return d != 0; }))
    spdlog::warn("{}: CameraInfo on {}: rational_polynomial k4-k6 are ignored", path, topic);
  return cam;
}

void check_layout(const ImageMessage& m, size_t pixel_bytes, const std::string& what,
                  const std::string& name) {
  if (m.width == 0 || m.height == 0 || m.step < m.width * pixel_bytes ||
      m.data.size() < static_cast<size_t>(m.step) * m.height)
    throw IoError(name, fmt::format("{} image {}x{} ({}) with {} bytes per row does not fit its {} "
                                    "data bytes",
                                    what, m.width, m.height, m.encoding, m.step, m.data.size()));
}

ColorImage decode_colour(const ImageMessage& m, const std::string& name) {
  const std::string& e = m.encoding;
  const int channels = e == "mono8"                     ? 1
                       : (e == "rgb8" || e == "bgr8")   ? 3
                       : (e == "rgba8" || e == "bgra8") ? 4
                                                        : 0;
  if (channels == 0)
    throw IoError(name,
                  "colour encoding '" + e + "' is not supported (rgb8, bgr8, rgba8, bgra8, mono8)");
  check_layout(m, channels, "colour", name);
  const bool bgr = e[0] == 'b';
  ColorImage out(static_cast<int>(m.width), static_cast<int>(m.height));
  for (int v = 0; v < out.height(); ++v) {
    const std::uint8_t* src = m.data.data() + static_cast<size_t>(v) * m.step;
    Rgb8* dst = out.row(v);
    for (int u = 0; u < out.width(); ++u, src += channels) {
      if (channels == 1)
        dst[u] = {src[0], src[0], src[0]};
      else
        dst[u] = bgr ? Rgb8{src[2], src[1], src[0]} : Rgb8{src[0], src[1], src[2]};
    }
  }
  return out;
}

/// Depth in metres: 16UC1 / mono16 raw / units_per_m, 32FC1 metres as they are (NaN, inf,
/// negative -> 0, counted).
DepthImage decode_depth(const ImageMessage& m, double units_per_m, const std::string& name,
                        DepthReadStats& stats) {
  const bool u16 = m.encoding == "16UC1" || m.encoding == "mono16";
  if (!u16 && m.encoding != "32FC1")
    throw IoError(name, "depth encoding '" + m.encoding + "' is not supported (16UC1, 32FC1)");
  const size_t bytes = u16 ? 2 : 4;
  check_layout(m, bytes, "depth", name);
  DepthImage out(static_cast<int>(m.width), static_cast<int>(m.height));
  for (int v = 0; v < out.height(); ++v) {
    const std::uint8_t* src = m.data.data() + static_cast<size_t>(v) * m.step;
    for (int u = 0; u < out.width(); ++u, src += bytes) {
      std::uint8_t b[4] = {};
      std::memcpy(b, src, bytes);
      if (m.big_endian) std::reverse(b, b + bytes);
      float z = 0;
      if (u16) {
        std::uint16_t raw;
        std::memcpy(&raw, b, 2);
        z = static_cast<float>(raw / units_per_m);
      } else {
        std::memcpy(&z, b, 4);
        if (!std::isfinite(z) || z < 0) ++stats.nonfinite_or_negative_pixels, z = 0;
      }
      if (z == 0) ++stats.invalid_pixels;
      out.at(u, v) = z;
    }
  }
  return out;
}

class RosbagReader final : public SelectedFramesReader {
 public:
  RosbagReader(const std::string& path, const DatasetParams& params)
      : path_(path), bag_(open(path)) {
    params_ = params;
    colour_ = image_messages(*bag_, params.bag_colour_topic, path, "bag_colour_topic");
    depth_ = image_messages(*bag_, params.bag_depth_topic, path, "bag_depth_topic");
    pairs_ = pair_by_stamp(colour_, depth_);
    if (pairs_.empty())
      throw IoError(path, fmt::format("no colour image on {} has a depth image on {} within 0.02 s",
                                      params.bag_colour_topic, params.bag_depth_topic));
    selected_ = select_frames(pairs_.size(), params, path);
    info_.format = "rosbag";
    info_.root = path;
    info_.depth_units_per_m = params.depth_units_per_m > 0 ? params.depth_units_per_m : 1000.0;
    read_camera_info();
    PinholeIntrinsics k = camera_ ? camera_->colour : PinholeIntrinsics{};
    const ImageMessage first =
        message(params.bag_colour_topic, colour_[pairs_[selected_.front()].first].second, path);
    k.width = static_cast<int>(first.width), k.height = static_cast<int>(first.height);
    if (camera_) camera_->colour.width = k.width, camera_->colour.height = k.height;
    info_.intrinsics = apply_intrinsics_overrides(k, params);
    spdlog::info("{}: {} colour + {} depth images, {} pairs; intrinsics from {}", path,
                 colour_.size(), depth_.size(), pairs_.size(),
                 camera_ ? params.bag_camera_info_topic : std::string("the settings"));
  }

  RgbdFrame read(size_t i) const override {
    RgbdFrame f = read_annotations(i);
    const auto [c, d] = pairs_[position(i)];
    const std::string cname = message_name(params_.bag_colour_topic, colour_[c].first);
    const std::string dname = message_name(params_.bag_depth_topic, depth_[d].first);
    DepthReadStats stats;
    {
      std::lock_guard<std::mutex> lock(mutex_);  // a bag is not safe to read from two threads
      f.color = decode_colour(message(params_.bag_colour_topic, colour_[c].second, cname), cname);
      f.depth = decode_depth(message(params_.bag_depth_topic, depth_[d].second, dname),
                             info_.depth_units_per_m, dname, stats);
    }
    finish_color_and_depth(cname, dname, stats, params_, f);
    if (camera_) apply_camera_file(*camera_, cname, f);
    f.intrinsics = apply_intrinsics_overrides(f.intrinsics, params_);
    return f;
  }

  RgbdFrame read_annotations(size_t i) const override {
    const size_t pos = position(i);
    RgbdFrame f;
    f.index = static_cast<int>(pos);
    f.timestamp_s = colour_[pairs_[pos].first].first;
    f.name = message_name(params_.bag_colour_topic, f.timestamp_s);
    f.intrinsics = info_.intrinsics;
    return f;
  }

 private:
  static std::unique_ptr<BagReader> open(const std::string& path) {
    try {
      return std::make_unique<BagReader>(path);
    } catch (const std::runtime_error& e) {
      throw IoError(path, e.what());
    }
  }
  void read_camera_info() {
    if (!params_.camera_file.empty()) return;  // the camera file's camera wins (open_dataset)
    std::optional<CameraInfoMessage> info;
    try {
      info = bag_->first_camera_info(params_.bag_camera_info_topic);
    } catch (const std::runtime_error& e) {
      throw IoError(path_, std::string(e.what()) + " (dataset.bag_camera_info_topic)");
    }
    if (info) camera_ = camera_from_info(*info, params_.bag_camera_info_topic, path_);
    if (!camera_ && !(params_.fx > 0 && params_.fy > 0))
      throw IoError(path_, fmt::format("no sensor_msgs/CameraInfo on {} (dataset.bag_camera_info_"
                                       "topic): give the intrinsics with --camera FILE or "
                                       "dataset.fx/fy/cx/cy; the bag has: {}",
                                       params_.bag_camera_info_topic, bag_->topics()));
  }
  ImageMessage message(const std::string& topic, size_t k, const std::string& name) const {
    try {
      return bag_->image(topic, k);
    } catch (const std::runtime_error& e) {
      throw IoError(name, e.what());
    }
  }
  std::string message_name(const std::string& topic, double stamp_s) const {
    return fmt::format("{}:{}@{:.6f}", path_, topic, stamp_s);
  }

  std::string path_;
  std::unique_ptr<BagReader> bag_;
  std::vector<std::pair<double, size_t>> colour_, depth_;  ///< (stamp, bag position), by stamp
  std::vector<std::pair<size_t, size_t>> pairs_;           ///< (colour, depth) indices into those
  std::optional<CameraFileInfo> camera_;  ///< from CameraInfo, when the bag has one
  mutable std::mutex mutex_;
};

}  // namespace

std::unique_ptr<DatasetReader> open_rosbag(const std::string& path, const DatasetParams& params) {
  if (!rosbag_io::available())
    throw ConfigError(path +
                      ": this orpe was built without ROS bag support (apt-get install "
                      "librosbag-storage-dev libsensor-msgs-dev, as scripts/install-deps.sh "
                      "does, then configure with -DORPE_WITH_ROSBAG=ON)");
  return std::make_unique<RosbagReader>(path, params);
}

}  // namespace orpe::detail
