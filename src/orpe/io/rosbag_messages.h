// The ROS 1 bag access orpe needs, behind a small interface with no ROS headers: Debian's ROS 1
// message headers do not compile as C++20 (std::allocator<void>::rebind), so rosbag_messages.cpp is
// the one file built as C++17 against them. Used by the bag dataset reader (dataset_rosbag.cpp)
// and by tests that write bags. Not a public API. Errors are std::runtime_error with the reason;
// callers add the file name.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace orpe::detail::rosbag_io {

/// True when orpe was built with ROS bag support (ORPE_WITH_ROSBAG).
bool available();

/// A sensor_msgs/Image, as stored.
struct ImageMessage {
  double stamp_s = 0;  ///< header.stamp, seconds
  std::string encoding;
  std::uint32_t width = 0, height = 0, step = 0;  ///< step: bytes per row
  bool big_endian = false;
  std::vector<std::uint8_t> data;
};

/// The part of a sensor_msgs/CameraInfo orpe uses.
struct CameraInfoMessage {
  double stamp_s = 0;
  std::uint32_t width = 0, height = 0;
  std::array<double, 9> K{};  ///< row-major 3x3
  std::string distortion_model;
  std::vector<double> D;
};

/// A bag opened for reading. Not safe to use from two threads at once.
class BagReader {
 public:
  explicit BagReader(const std::string& path);  ///< throws std::runtime_error
  ~BagReader();
  BagReader(const BagReader&) = delete;
  BagReader& operator=(const BagReader&) = delete;

  /// "topic (type), ..." of every connection, or "none".
  std::string topics() const;
  /// Header stamps of the messages of `topic`, in bag order. Throws std::runtime_error when the
  /// topic holds another type than sensor_msgs/Image. Empty when the bag has no such topic.
  std::vector<double> image_stamps(const std::string& topic) const;
  /// The k-th message (bag order) of `topic`.
  ImageMessage image(const std::string& topic, size_t k) const;
  /// The first sensor_msgs/CameraInfo of `topic`; nullopt when there is none. Throws when the
  /// topic holds another type.
  std::optional<CameraInfoMessage> first_camera_info(const std::string& topic) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// How a written bag's chunks are compressed (rosbag::compression).
enum class BagCompression { none, bz2, lz4 };

/// A bag opened for writing (tests, conversions); closed by the destructor.
class BagWriter {
 public:
  /// Throws std::runtime_error.
  explicit BagWriter(const std::string& path, BagCompression compression = BagCompression::none);
  ~BagWriter();
  BagWriter(const BagWriter&) = delete;
  BagWriter& operator=(const BagWriter&) = delete;

  /// Writes `m` on `topic`, recorded at `record_time_s` (the bag's time, not the header stamp).
  void write(const std::string& topic, double record_time_s, const ImageMessage& m);
  void write(const std::string& topic, double record_time_s, const CameraInfoMessage& m);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace orpe::detail::rosbag_io
