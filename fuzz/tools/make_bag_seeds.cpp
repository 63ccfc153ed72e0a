// Writes the seed bags of the rosbag fuzz target into the folder given: tiny TUM-like ROS 1 bags
// (2x2 or 3x2 images on the default topics, with and without CameraInfo; made up here, no dataset
// file is copied). The connection headers carry no message_definition (rosbag would store the
// whole .msg text of each type, twice: 30 KB a seed instead of 6), and the 4 KB of padding rosbag
// writes after the file header are taken out (the index and chunk positions moved to
// match): 1.5-2.5 KB a seed, under the 4 KB -max_len of scripts/fuzz.sh. Uncompressed, bz2 and lz4
// chunks. C++17 with the ROS headers, like io/rosbag_messages.cpp. docs/FUZZING.md.
#include <ros/message_traits.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>

namespace {

template <class Msg>
boost::shared_ptr<ros::M_string> header_without_definition() {
  auto h = boost::make_shared<ros::M_string>();
  (*h)["type"] = ros::message_traits::datatype<Msg>();
  (*h)["md5sum"] = ros::message_traits::md5sum<Msg>();
  return h;
}

sensor_msgs::Image image(double t, const std::string& encoding, unsigned bytes_per_pixel,
                         unsigned w) {
  sensor_msgs::Image m;
  m.header.stamp = ros::Time(t);
  m.encoding = encoding, m.width = w, m.height = 2, m.step = w * bytes_per_pixel;
  m.data.resize(static_cast<size_t>(m.step) * m.height);
  for (size_t i = 0; i < m.data.size(); ++i) m.data[i] = static_cast<unsigned char>(17 * i + 3);
  return m;
}

/// Subtracts `delta` from the little-endian u64 value of every header field `name` in `b`.
void move_positions(std::string& b, const std::string& name, std::uint64_t delta) {
  std::string key(4, '\0');
  key[0] = static_cast<char>(name.size() + 1 + 8);
  key += name + "=";
  for (size_t at = b.find(key); at != std::string::npos; at = b.find(key, at + 1)) {
    std::uint64_t v = 0;
    std::memcpy(&v, &b[at + key.size()], 8);  // little-endian, as the bag
    v -= delta;
    std::memcpy(&b[at + key.size()], &v, 8);
  }
}

/// The bag at `path` without the padding after its file header record (rosbag writes 4 KB there,
/// to rewrite the header in place when it closes; a reader skips whatever the data length says).
void drop_file_header_padding(const std::string& path) {
  std::string b;
  {
    std::ifstream in(path, std::ios::binary);
    b.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  const size_t first = b.find('\n') + 1;  // after the version line
  std::uint32_t header_len = 0, padding = 0;
  std::memcpy(&header_len, &b[first], 4);
  const size_t data_len_at = first + 4 + header_len;
  std::memcpy(&padding, &b[data_len_at], 4);
  b.erase(data_len_at + 4, padding);
  std::memset(&b[data_len_at], 0, 4);
  move_positions(b, "index_pos", padding);
  move_positions(b, "chunk_pos", padding);
  std::ofstream(path, std::ios::binary) << b;
}

void write_bag(
    const std::string& path, const std::string& colour, unsigned cb, const std::string& depth,
    unsigned db, bool info, int frames, unsigned w,
    rosbag::compression::CompressionType compression = rosbag::compression::Uncompressed) {
  {
    rosbag::Bag bag(path, rosbag::bagmode::Write);
    bag.setCompression(compression);
    const auto image_header = header_without_definition<sensor_msgs::Image>();
    const auto info_header = header_without_definition<sensor_msgs::CameraInfo>();
    for (int i = 0; i < frames; ++i) {
      const ros::Time t(10.0 + 0.1 * i);
      bag.write("/camera/rgb/image_color", t, image(t.toSec(), colour, cb, w), image_header);
      bag.write("/camera/depth/image", t, image(t.toSec() + 0.005, depth, db, w), image_header);
      if (info) {
        sensor_msgs::CameraInfo ci;
        ci.header.stamp = t;
        ci.width = w, ci.height = 2;
        ci.K = {2.5, 0, 1, 0, 2.5, 0.5, 0, 0, 1};
        ci.distortion_model = "plumb_bob";
        ci.D = {0.01, 0, 0, 0, 0};
        bag.write("/camera/rgb/camera_info", t, ci, info_header);
      }
    }
  }
  drop_file_header_padding(path);
  // Read back: every message of the shrunk bag.
  rosbag::Bag back(path, rosbag::bagmode::Read);
  size_t n = 0;
  for (const rosbag::MessageInstance& m : rosbag::View(back)) n += m.size() > 0;
  if (n != static_cast<size_t>(frames) * (info ? 3 : 2))
    throw std::runtime_error(path + ": " + std::to_string(n) + " messages read back");
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s OUT_DIR\n", argv[0]);
    return 2;
  }
  const std::string dir = argv[1];
  try {
    write_bag(dir + "/seed-rgb8-16uc1-info.bag", "rgb8", 3, "16UC1", 2, true, 2, 2);
    write_bag(dir + "/seed-bgra8-32fc1-info.bag", "bgra8", 4, "32FC1", 4, true, 1, 3);
    write_bag(dir + "/seed-mono8-mono16-noinfo.bag", "mono8", 1, "mono16", 2, false, 1, 2);
    write_bag(dir + "/seed-rgb8-16uc1-info-bz2.bag", "rgb8", 3, "16UC1", 2, true, 2, 2,
              rosbag::compression::BZ2);
    write_bag(dir + "/seed-rgb8-16uc1-info-lz4.bag", "rgb8", 3, "16UC1", 2, true, 2, 2,
              rosbag::compression::LZ4);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
  return 0;
}
