// Built as C++17 (CMakeLists.txt): Debian's ROS 1 message headers do not compile as C++20. Only
// standard and ROS headers here; see rosbag_messages.h.
#include "orpe/io/rosbag_messages.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <stdexcept>

#if ORPE_HAVE_ROSBAG
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#endif

namespace orpe::detail::rosbag_io {

#if !ORPE_HAVE_ROSBAG

bool available() {
  return false;
}

namespace {
[[noreturn]] void unavailable() {
  throw std::runtime_error(
      "this orpe was built without ROS bag support (apt-get install librosbag-storage-dev "
      "libsensor-msgs-dev, as scripts/install-deps.sh does, then configure with "
      "-DORPE_WITH_ROSBAG=ON)");
}
}  // namespace

struct BagReader::Impl {};
BagReader::BagReader(const std::string&) {
  unavailable();
}
BagReader::~BagReader() = default;
std::string BagReader::topics() const {
  unavailable();
}
std::vector<double> BagReader::image_stamps(const std::string&) const {
  unavailable();
}
ImageMessage BagReader::image(const std::string&, size_t) const {
  unavailable();
}
std::optional<CameraInfoMessage> BagReader::first_camera_info(const std::string&) const {
  unavailable();
}
struct BagWriter::Impl {};
BagWriter::BagWriter(const std::string&) {
  unavailable();
}
BagWriter::~BagWriter() = default;
void BagWriter::write(const std::string&, double, const ImageMessage&) {
  unavailable();
}
void BagWriter::write(const std::string&, double, const CameraInfoMessage&) {
  unavailable();
}

#else

bool available() {
  return true;
}

struct BagReader::Impl {
  rosbag::Bag bag;
  /// Per image topic, its messages in bag order (filled by image_stamps).
  mutable std::vector<std::pair<std::string, std::vector<rosbag::MessageInstance> > > messages;

  const std::vector<rosbag::MessageInstance>* find(const std::string& topic) const {
    for (const auto& [t, v] : messages)
      if (t == topic) return &v;
    return nullptr;
  }
};

namespace {

/// The message's type must be Msg, of the definition orpe was built with (the same md5sum):
/// rosbag's instantiate() gives a null pointer for another definition.
template <class Msg>
void check_type(const rosbag::MessageInstance& m, const std::string& topic) {
  const std::string want = ros::message_traits::datatype<Msg>();
  if (m.getDataType() != want)
    throw std::runtime_error("topic " + topic + " holds " + m.getDataType() + ", not " + want);
  const std::string md5 = ros::message_traits::md5sum<Msg>();
  if (m.getMD5Sum() != md5 && m.getMD5Sum() != "*")
    throw std::runtime_error("topic " + topic + " holds " + want +
                             " of another definition (md5sum " + m.getMD5Sum() + "; orpe reads " +
                             md5 + ")");
}

/// Walks a message's serialized bytes: every length-prefixed field must fit in the bytes left.
/// roscpp resizes a vector to its stated length before it checks that the bytes are there, so a
/// corrupt length allocated up to 4 GB (32 GB for a double vector): a fuzz finding.
class FieldWalker {
 public:
  FieldWalker(const std::vector<std::uint8_t>& bytes, const std::string& what)
      : p_(bytes.data()), left_(bytes.size()), what_(what) {}
  void skip(size_t n, const char* field) {
    if (n > left_)
      throw std::runtime_error(what_ + ": field " + field + " needs " + std::to_string(n) +
                               " bytes, the message has " + std::to_string(left_) + " left");
    p_ += n, left_ -= n;
  }
  std::uint32_t u32(const char* field) {
    std::uint32_t v = 0;
    if (left_ >= 4) std::memcpy(&v, p_, 4);  // little-endian, as ROS serialises
    skip(4, field);
    return v;
  }
  void string(const char* field) { skip(u32(field), field); }
  void vector(size_t element_bytes, const char* field) {
    skip(static_cast<size_t>(u32(field)) * element_bytes, field);
  }

 private:
  const std::uint8_t* p_;
  size_t left_;
  std::string what_;
};

void check_fields(const std::vector<std::uint8_t>& b, const sensor_msgs::Image*,
                  const std::string& what) {
  FieldWalker w(b, what);
  w.skip(12, "header.seq/stamp");
  w.string("header.frame_id");
  w.skip(8, "height/width");
  w.string("encoding");
  w.skip(5, "is_bigendian/step");
  w.vector(1, "data");
}

void check_fields(const std::vector<std::uint8_t>& b, const sensor_msgs::CameraInfo*,
                  const std::string& what) {
  FieldWalker w(b, what);
  w.skip(12, "header.seq/stamp");
  w.string("header.frame_id");
  w.skip(8, "height/width");
  w.string("distortion_model");
  w.vector(8, "D");
  w.skip(8 * (9 + 9 + 12) + 8 + 17, "K/R/P/binning/roi");
}

/// The message, deserialised from its bytes once check_type and check_fields have passed.
template <class Msg>
Msg read_message(const rosbag::MessageInstance& m, const std::string& topic, size_t k) {
  check_type<Msg>(m, topic);
  std::vector<std::uint8_t> bytes(m.size());
  ros::serialization::OStream out(bytes.data(), static_cast<std::uint32_t>(bytes.size()));
  m.write(out);
  check_fields(bytes, static_cast<const Msg*>(nullptr),
               "message " + std::to_string(k) + " on " + topic);
  Msg msg;
  ros::serialization::IStream in(bytes.data(), static_cast<std::uint32_t>(bytes.size()));
  ros::serialization::deserialize(in, msg);
  return msg;
}

template <class Fn>
auto translate(Fn&& fn) -> decltype(fn()) {
  try {
    return fn();
  } catch (const rosbag::BagException& e) {
    throw std::runtime_error(std::string("cannot read the ROS bag: ") + e.what());
  } catch (const ros::Exception& e) {
    throw std::runtime_error(std::string("cannot read the ROS bag: ") + e.what());
  }
}

std::uint64_t read_u32_at(std::ifstream& in, std::uint64_t pos) {
  unsigned char b[4] = {};
  in.seekg(static_cast<std::streamoff>(pos));
  in.read(reinterpret_cast<char*>(b), 4);
  return b[0] | b[1] << 8 | b[2] << 16 | static_cast<std::uint64_t>(b[3]) << 24;
}

/// The version line as rosbag reads it (ChunkedFile::getline: fgets of at most 1023 bytes, then a
/// std::string of the buffer, cut at a NUL): the first record starts right after it. Any
/// "#ROS<word> V2.0" is version 2.0 to rosbag ("#ROSBG V2.0" too).
std::string bag_version_line(std::ifstream& in, std::uint64_t size) {
  std::string buf(static_cast<size_t>(std::min<std::uint64_t>(size, 1023)), '\0');
  in.seekg(0);
  in.read(buf.data(), static_cast<std::streamsize>(buf.size()));
  const size_t newline = buf.find('\n');
  if (newline != std::string::npos) buf.resize(newline + 1);
  // rosbag's offsets disagree for such a line (a valid bag has none): refused.
  if (buf.find('\0') != std::string::npos && buf.rfind("#ROS", 0) == 0)
    throw std::runtime_error("cannot read the ROS bag: its version line holds a NUL byte");
  return buf;
}

/// A bag (format 2.0) is a sequence of records, each a header and a data part, each led by its
/// length; rosbag allocates the stated length before it reads (a header length of 1.6 GB in a
/// 2.7 KB file: 1.6 GB, fuzz/corpus/rosbag/crash-oom-file-header-length.bag). Every top-level
/// length must fit in the bytes left. Other versions are left to rosbag.
void check_bag_records(const std::string& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) return;  // rosbag names the problem
  const std::uint64_t size = static_cast<std::uint64_t>(in.tellg());
  const std::string line = bag_version_line(in, size);
  int major = 0, minor = 0;
  if (std::sscanf(line.c_str(), "#ROS%*s V%d.%d", &major, &minor) != 2 || major != 2 || minor != 0)
    return;
  // rosbag scans the word after "#ROS" into a char[100] with an unbounded %s.
  if (line.find_first_of(" \t\n") > 4 + 99)
    throw std::runtime_error("cannot read the ROS bag: its version line is too long");
  for (std::uint64_t pos = line.size(); pos + 4 <= size;) {
    for (const char* part : {"header", "data"}) {
      const std::uint64_t len = read_u32_at(in, pos);
      if (len > size - pos - 4)
        throw std::runtime_error("cannot read the ROS bag: the record at byte " +
                                 std::to_string(pos) + " states a " + part + " of " +
                                 std::to_string(len) + " bytes, the file has " +
                                 std::to_string(size - pos - 4) + " left");
      pos += 4 + len;
      if (pos + 4 > size && std::string(part) == "header")
        throw std::runtime_error("cannot read the ROS bag: the file ends inside a record");
    }
  }
}

}  // namespace

BagReader::BagReader(const std::string& path) : impl_(std::make_unique<Impl>()) {
  check_bag_records(path);
  translate([&] {
    impl_->bag.open(path, rosbag::bagmode::Read);
    return 0;
  });
}

BagReader::~BagReader() = default;

std::string BagReader::topics() const {
  return translate([&] {
    rosbag::View all(impl_->bag);
    std::string out;
    for (const rosbag::ConnectionInfo* c : all.getConnections())
      out += (out.empty() ? "" : ", ") + c->topic + " (" + c->datatype + ")";
    return out.empty() ? std::string("none") : out;
  });
}

std::vector<double> BagReader::image_stamps(const std::string& topic) const {
  return translate([&] {
    rosbag::View view(impl_->bag, rosbag::TopicQuery(topic));
    std::vector<rosbag::MessageInstance> kept;
    std::vector<double> stamps;
    for (const rosbag::MessageInstance& m : view) {
      stamps.push_back(
          read_message<sensor_msgs::Image>(m, topic, kept.size()).header.stamp.toSec());
      kept.push_back(m);
    }
    impl_->messages.emplace_back(topic, std::move(kept));
    return stamps;
  });
}

ImageMessage BagReader::image(const std::string& topic, size_t k) const {
  return translate([&] {
    const auto* v = impl_->find(topic);
    if (!v || k >= v->size())
      throw std::runtime_error("no image " + std::to_string(k) + " on topic " + topic);
    sensor_msgs::Image msg = read_message<sensor_msgs::Image>((*v)[k], topic, k);
    ImageMessage out;
    out.stamp_s = msg.header.stamp.toSec();
    out.encoding = msg.encoding;
    out.width = msg.width, out.height = msg.height, out.step = msg.step;
    out.big_endian = msg.is_bigendian != 0;
    out.data = std::move(msg.data);
    return out;
  });
}

std::optional<CameraInfoMessage> BagReader::first_camera_info(const std::string& topic) const {
  return translate([&]() -> std::optional<CameraInfoMessage> {
    rosbag::View view(impl_->bag, rosbag::TopicQuery(topic));
    for (const rosbag::MessageInstance& m : view) {
      const auto info = read_message<sensor_msgs::CameraInfo>(m, topic, 0);
      CameraInfoMessage out;
      out.stamp_s = info.header.stamp.toSec();
      out.width = info.width, out.height = info.height;
      for (int i = 0; i < 9; ++i) out.K[i] = info.K[i];
      out.distortion_model = info.distortion_model;
      out.D = info.D;
      return out;
    }
    return std::nullopt;
  });
}

struct BagWriter::Impl {
  rosbag::Bag bag;
};

BagWriter::BagWriter(const std::string& path) : impl_(std::make_unique<Impl>()) {
  translate([&] {
    impl_->bag.open(path, rosbag::bagmode::Write);
    return 0;
  });
}

BagWriter::~BagWriter() = default;

void BagWriter::write(const std::string& topic, double record_time_s, const ImageMessage& m) {
  sensor_msgs::Image msg;
  msg.header.stamp = ros::Time(m.stamp_s);
  msg.encoding = m.encoding;
  msg.width = m.width, msg.height = m.height, msg.step = m.step;
  msg.is_bigendian = m.big_endian ? 1 : 0;
  msg.data = m.data;
  translate([&] {
    impl_->bag.write(topic, ros::Time(record_time_s), msg);
    return 0;
  });
}

void BagWriter::write(const std::string& topic, double record_time_s, const CameraInfoMessage& m) {
  sensor_msgs::CameraInfo msg;
  msg.header.stamp = ros::Time(m.stamp_s);
  msg.width = m.width, msg.height = m.height;
  for (int i = 0; i < 9; ++i) msg.K[i] = m.K[i];
  msg.distortion_model = m.distortion_model;
  msg.D = m.D;
  translate([&] {
    impl_->bag.write(topic, ros::Time(record_time_s), msg);
    return 0;
  });
}

#endif

}  // namespace orpe::detail::rosbag_io
