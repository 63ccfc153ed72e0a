// Writes the seed bags of the rosbag fuzz target into the folder given: tiny TUM-like ROS 1 bags
// (2x2 or 3x2 images on the default topics, with and without CameraInfo; made up here, no dataset
// file is copied). The connection headers carry no message_definition (rosbag would store the
// whole .msg text of each type, twice: 30 KB a seed instead of 6). C++17 with the ROS headers, like
// io/rosbag_messages.cpp. docs/FUZZING.md.
#include <rosbag/bag.h>
#include <ros/message_traits.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include <cstdio>
#include <exception>
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

void write_bag(const std::string& path, const std::string& colour, unsigned cb,
               const std::string& depth, unsigned db, bool info, int frames, unsigned w) {
  rosbag::Bag bag(path, rosbag::bagmode::Write);
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
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
  return 0;
}
