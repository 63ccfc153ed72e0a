// Built as C++17 (CMakeLists.txt): Debian's ROS 1 message headers do not compile as C++20. Only
// standard and ROS headers here; see rosbag_messages.h.
#include "orpe/io/rosbag_messages.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>
#include <string_view>

#if ORPE_HAVE_ROSBAG
#include <bzlib.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <roslz4/lz4s.h>
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
BagWriter::BagWriter(const std::string&, BagCompression) {
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

std::uint32_t le32(const char* p) {
  const auto* b = reinterpret_cast<const unsigned char*>(p);
  return b[0] | b[1] << 8 | b[2] << 16 | static_cast<std::uint32_t>(b[3]) << 24;
}

[[noreturn]] void refuse(const std::string& what) {
  throw std::runtime_error("cannot read the ROS bag: " + what);
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
    refuse("its version line holds a NUL byte");
  return buf;
}

/// A record's header: "name=value" fields, each led by its length (roscpp's ros::Header::parse,
/// which reads a field's stated length before it checks that the bytes are there: here every
/// field must fit exactly). A repeated name keeps its last value, as in roscpp.
using Fields = std::map<std::string, std::string>;

Fields parse_fields(const char* p, std::uint32_t n, const std::string& where) {
  Fields fields;
  for (std::uint32_t i = 0; i < n;) {
    if (n - i < 4) refuse(where + ": its header ends inside the length of a field");
    const std::uint32_t len = le32(p + i);
    i += 4;
    if (len > n - i)
      refuse(where + ": a header field states " + std::to_string(len) + " bytes, the header has " +
             std::to_string(n - i) + " left");
    const std::string_view field(p + i, len);
    i += len;
    const size_t eq = field.find('=');
    if (eq == std::string_view::npos) refuse(where + ": a header field without '='");
    fields[std::string(field.substr(0, eq))] = std::string(field.substr(eq + 1));
  }
  return fields;
}

/// The field `name` as a little-endian unsigned integer of exactly `bytes` bytes (as rosbag's
/// readField requires); nullopt when missing or of another size (rosbag then refuses the bag).
std::optional<std::uint64_t> uint_field(const Fields& f, const std::string& name, size_t bytes) {
  const auto it = f.find(name);
  if (it == f.end() || it->second.size() != bytes) return std::nullopt;
  std::uint64_t v = 0;
  for (size_t i = 0; i < bytes; ++i)
    v |= static_cast<std::uint64_t>(static_cast<unsigned char>(it->second[i])) << (8 * i);
  return v;
}

/// One record: a header (fields) and a data part, each led by its 4-byte length.
struct Record {
  std::uint64_t pos = 0;       ///< of its header length (in the file, or in the chunk's data)
  std::uint64_t data_pos = 0;  ///< of its data part
  std::uint32_t data_len = 0;
  Fields fields;
  int op() const { return static_cast<int>(uint_field(fields, "op", 1).value_or(0x100)); }
};

/// Walks the records of bytes [begin, end), read with `read(pos, n, out)`: every header and data
/// length must fit in the bytes left, and every header must parse. `where(pos)` names a record in
/// the messages, `unit` the whole ("the file", "the chunk").
template <class Read, class Where>
std::vector<Record> walk_records(Read&& read, std::uint64_t begin, std::uint64_t end, Where&& where,
                                 const char* unit) {
  std::vector<Record> records;
  std::string header;
  for (std::uint64_t pos = begin; pos + 4 <= end;) {
    Record r;
    r.pos = pos;
    std::uint32_t len[2] = {};
    for (int part = 0; part < 2; ++part) {
      char b[4];
      read(pos, 4, b);
      len[part] = le32(b);
      if (len[part] > end - pos - 4)
        refuse(where(r.pos) + " states a " + (part == 0 ? "header" : "data part") + " of " +
               std::to_string(len[part]) + " bytes, " + unit + " has " +
               std::to_string(end - pos - 4) + " left");
      if (part == 0) {
        header.resize(len[0]);
        read(pos + 4, len[0], header.data());
        r.fields = parse_fields(header.data(), len[0], where(r.pos));
      }
      pos += 4 + len[part];
      if (part == 0 && pos + 4 > end) refuse(std::string(unit) + " ends inside a record");
    }
    r.data_pos = r.pos + 8 + len[0];
    r.data_len = len[1];
    records.push_back(std::move(r));
  }
  return records;
}

/// A compressed chunk may state at most this many uncompressed bytes (rosbag allocates them before
/// it decompresses; rosbag writes chunks of 768 KiB plus one message).
constexpr std::uint64_t kMaxChunkBytes = std::uint64_t{256} << 20;

/// The uncompressed bytes of the chunk record `c` (its data part: `data`), after checking the
/// size the chunk states against what its compression can give.
/// nullopt when the chunk's header lacks its compression or size (rosbag refuses the bag then).
std::optional<std::string> chunk_bytes(const Record& c, std::string data) {
  const auto it = c.fields.find("compression");
  const auto size = uint_field(c.fields, "size", 4);
  if (it == c.fields.end() || !size) return std::nullopt;
  const std::string at = "the chunk at byte " + std::to_string(c.pos);
  if (it->second == "none") return data;
  if (it->second != "bz2" && it->second != "lz4") refuse(at + " has an unknown compression");
  // lz4 expands at most 255 times (a match length byte stands for at most 255 bytes); bzip2 far
  // more, so the cap alone bounds it.
  const std::uint64_t limit = it->second == "lz4"
                                  ? std::min(kMaxChunkBytes, 256 * std::uint64_t{c.data_len} + 64)
                                  : kMaxChunkBytes;
  if (*size > limit)
    refuse(at + " states " + std::to_string(*size) + " uncompressed bytes from " +
           std::to_string(c.data_len) + " " + it->second + " bytes (at most " +
           std::to_string(limit) + ")");
  std::string out(static_cast<size_t>(*size), '\0');
  unsigned int out_len = static_cast<unsigned int>(out.size());
  bool ok = false;
  if (it->second == "bz2")
    ok = BZ2_bzBuffToBuffDecompress(out.data(), &out_len, data.data(),
                                    static_cast<unsigned int>(data.size()), 0, 0) == BZ_OK;
  else
    ok = roslz4_buffToBuffDecompress(data.data(), static_cast<unsigned int>(data.size()),
                                     out.data(), &out_len) == ROSLZ4_OK;
  if (!ok || out_len != out.size())
    refuse(at + ": its " + it->second + " data does not decompress to the " +
           std::to_string(*size) + " bytes it states");
  return out;
}

/// Names a top-level record in the messages.
std::string where_in_file(std::uint64_t pos) {
  return "the record at byte " + std::to_string(pos);
}

/// A bag's top-level records (walk_records over the file) and reads of its bytes.
struct BagFile {
  std::ifstream& in;
  std::vector<Record> records;

  void read(std::uint64_t pos, size_t n, char* out) const {
    in.seekg(static_cast<std::streamoff>(pos));
    in.read(out, static_cast<std::streamsize>(n));
  }
  /// The data part of `r`.
  std::string data(const Record& r) const {
    std::string bytes(r.data_len, '\0');
    read(r.data_pos, r.data_len, bytes.data());
    return bytes;
  }
  /// The record that starts at byte `pos`, or null.
  const Record* record_at(std::uint64_t pos) const {
    const auto it = std::lower_bound(records.begin(), records.end(), pos,
                                     [](const Record& r, std::uint64_t p) { return r.pos < p; });
    return it != records.end() && it->pos == pos ? &*it : nullptr;
  }
  size_t index_of(const Record& r) const { return static_cast<size_t>(&r - records.data()); }
};

/// The version line when it states version 2.0; nullopt when it states none (rosbag refuses the
/// bag then). Other versions, and a line rosbag would overflow on, are refused.
std::optional<std::string> checked_version_line(std::ifstream& in, std::uint64_t size) {
  std::string line = bag_version_line(in, size);
  int major = 0, minor = 0;
  if (std::sscanf(line.c_str(), "#ROS%*s V%d.%d", &major, &minor) != 2) return std::nullopt;
  // rosbag scans the word after "#ROS" into a char[100] with an unbounded %s.
  if (line.find_first_of(" \t\n") > 4 + 99) refuse("its version line is too long");
  if (major != 2 || minor != 0)
    refuse("format version " + std::to_string(major) + "." + std::to_string(minor) +
           " (orpe reads bags of version 2.0, ROS since 2010)");
  return line;
}

/// What rosbag reads of the file header record (the first record, op 3).
struct FileHeader {
  size_t index = 0;  ///< the first record of the index (BagFile::records)
  std::uint64_t conn_count = 0, chunk_count = 0;
};

/// The file header: not encrypted, its index position the start of a record. nullopt when rosbag
/// refuses the bag itself (no file header, a field missing).
std::optional<FileHeader> checked_file_header(const BagFile& bag) {
  if (bag.records.empty() || bag.records[0].op() != 3) return std::nullopt;
  const Fields& fields = bag.records[0].fields;
  if (const auto e = fields.find("encryptor");
      e != fields.end() && !e->second.empty() && e->second != "rosbag/NoEncryptor")
    refuse("it is encrypted (" + e->second + "), which orpe does not read");
  const auto index_pos = uint_field(fields, "index_pos", 8);
  const auto conn_count = uint_field(fields, "conn_count", 4);
  const auto chunk_count = uint_field(fields, "chunk_count", 4);
  if (!index_pos || *index_pos == 0 || !conn_count || !chunk_count) return std::nullopt;
  const Record* index = bag.record_at(*index_pos);
  if (!index)
    refuse("the file header gives the index at byte " + std::to_string(*index_pos) +
           ", where no record starts");
  return FileHeader{bag.index_of(*index), *conn_count, *chunk_count};
}

/// The ids of the `count` connection records from records[k] on (k is left after them), each
/// one's data part a connection header, which rosbag parses as a header. nullopt when one is not
/// a connection record (rosbag refuses the bag).
std::optional<std::set<std::uint32_t> > checked_connections(const BagFile& bag, size_t& k,
                                                            std::uint64_t count) {
  std::set<std::uint32_t> connections;
  for (std::uint64_t i = 0; i < count && k < bag.records.size(); ++i, ++k) {
    const Record& r = bag.records[k];
    const auto id = uint_field(r.fields, "conn", 4);
    if (r.op() != 7 || !id) return std::nullopt;
    const std::string header = bag.data(r);
    parse_fields(header.data(), r.data_len, where_in_file(r.pos));
    connections.insert(static_cast<std::uint32_t>(*id));
  }
  return connections;
}

/// A chunk info's or an index's list: `count` entries of `bytes`, exactly its data part (rosbag
/// reads count x bytes, then the next record from there).
std::string checked_entries(const BagFile& bag, const Record& r, const char* what,
                            std::uint64_t count, unsigned bytes, const char* entry) {
  if (r.data_len != bytes * count)
    refuse(where_in_file(r.pos) + " (" + what + ") lists " + std::to_string(count) + " " + entry +
           " (" + std::to_string(bytes) + " bytes each) in a data part of " +
           std::to_string(r.data_len) + " bytes");
  return bag.data(r);
}

/// The offsets of the message data records (op 2) in `chunk`: its data decompressed (chunk_bytes)
/// and its records walked as the top level's. nullopt when rosbag refuses the chunk (its header
/// lacks the compression or the size).
std::optional<std::set<std::uint64_t> > chunk_message_offsets(const BagFile& bag,
                                                              const Record& chunk) {
  const std::optional<std::string> decompressed = chunk_bytes(chunk, bag.data(chunk));
  if (!decompressed) return std::nullopt;
  const std::string& bytes = *decompressed;
  const auto read_chunk = [&](std::uint64_t pos, size_t n, char* out) {
    std::memcpy(out, bytes.data() + pos, n);
  };
  const auto inner = [&](std::uint64_t pos) {
    return "the record at byte " + std::to_string(pos) + " of the chunk at byte " +
           std::to_string(chunk.pos);
  };
  std::set<std::uint64_t> offsets;
  for (const Record& r : walk_records(read_chunk, 0, bytes.size(), inner, "the chunk"))
    if (r.op() == 2) offsets.insert(r.pos);
  return offsets;
}

/// The index records rosbag reads after `chunk`, one for each of its chunk info's `connections`
/// (up to the first record that is not one): each of a connection of the bag, listing 12 bytes a
/// message, each message at the start of a message record of the chunk (`offsets`).
void check_chunk_indexes(const BagFile& bag, const Record& chunk, size_t connections,
                         const std::set<std::uint32_t>& bag_connections,
                         const std::set<std::uint64_t>& offsets) {
  const size_t c = bag.index_of(chunk);
  for (size_t j = c + 1; j < c + 1 + connections && j < bag.records.size(); ++j) {
    const Record& ix = bag.records[j];
    const auto conn = uint_field(ix.fields, "conn", 4);
    const auto n = uint_field(ix.fields, "count", 4);
    if (ix.op() != 4 || uint_field(ix.fields, "ver", 4) != 1u || !conn || !n) return;
    if (!bag_connections.count(static_cast<std::uint32_t>(*conn)))
      refuse(where_in_file(ix.pos) + " (an index) is of connection " + std::to_string(*conn) +
             ", which the bag does not have");
    const std::string list = checked_entries(bag, ix, "an index", *n, 12, "messages");
    for (size_t e = 0; e < list.size(); e += 12) {
      const std::uint32_t offset = le32(list.data() + e + 8);
      if (!offsets.count(offset))
        refuse(where_in_file(ix.pos) + " (an index) gives a message at byte " +
               std::to_string(offset) + " of the chunk at byte " + std::to_string(chunk.pos) +
               ", where no message record starts");
    }
  }
}

/// A chunk info record (op 6): 8 bytes a listed connection, pointing at a chunk, whose messages
/// (`messages`: per chunk, kept for the next chunk info pointing at it) and index records are
/// checked. false when rosbag refuses the bag (a record that is not a chunk info, a chunk
/// without its compression or size).
bool check_chunk_info(const BagFile& bag, const Record& info,
                      const std::set<std::uint32_t>& bag_connections,
                      std::map<std::uint64_t, std::set<std::uint64_t> >& messages) {
  const auto count = uint_field(info.fields, "count", 4);
  const auto chunk_pos = uint_field(info.fields, "chunk_pos", 8);
  if (info.op() != 6 || uint_field(info.fields, "ver", 4) != 1u || !count || !chunk_pos)
    return false;
  const std::string data = checked_entries(bag, info, "a chunk info", *count, 8, "connections");
  std::set<std::uint32_t> connections;
  for (size_t j = 0; j < data.size(); j += 8) connections.insert(le32(data.data() + j));
  const Record* chunk = bag.record_at(*chunk_pos);
  if (!chunk || chunk->op() != 5)
    refuse(where_in_file(info.pos) + " (a chunk info) points at byte " +
           std::to_string(*chunk_pos) + ", where no chunk starts");
  if (!messages.count(chunk->pos)) {
    std::optional<std::set<std::uint64_t> > offsets = chunk_message_offsets(bag, *chunk);
    if (!offsets) return false;
    messages[chunk->pos] = std::move(*offsets);
  }
  check_chunk_indexes(bag, *chunk, connections.size(), bag_connections, messages[chunk->pos]);
  return true;
}

/// rosbag's reading of a version 2.0 bag (Bag::startReadingVersion200, and each message through
/// the index) trusts every length and position it reads: a length is allocated before it is read
/// (a header length of 1.6 GB in a 2.7 KB file: 1.6 GB, fuzz/corpus/rosbag/crash-oom-*), a
/// position is read as the start of a record, a chunk's stated size is allocated before it is
/// decompressed, a message is copied from its chunk at the length its record states. So before
/// rosbag opens the bag:
/// - every top-level record's header and data length fit in the bytes left, every header parses;
/// - the file header's index position is the start of a record, its encryptor (if any) is none;
/// - each chunk info record rosbag reads lists 8 bytes a connection and points at a chunk;
/// - each index record after such a chunk lists 12 bytes a message, of a known connection, each
///   at the start of a message data record inside the chunk;
/// - each such chunk: its compressed stated size bounded (kMaxChunkBytes; lz4: 256 x its data), its
///   data decompressing to exactly that size, and its inner records' lengths fitting in it.
/// Other versions than 2.0 (rosbag also reads 1.2, unchecked) are refused. Where rosbag itself
/// refuses the bag (a record missing or of another kind), the check stops and leaves it to rosbag.
void check_bag_records(const std::string& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) return;  // rosbag names the problem
  const std::uint64_t size = static_cast<std::uint64_t>(in.tellg());
  const std::optional<std::string> line = checked_version_line(in, size);
  if (!line) return;
  BagFile bag{in, {}};
  const auto read_file = [&](std::uint64_t pos, size_t n, char* out) { bag.read(pos, n, out); };
  bag.records = walk_records(read_file, line->size(), size, where_in_file, "the file");
  const std::optional<FileHeader> header = checked_file_header(bag);
  if (!header) return;
  // The records rosbag reads from the index on: conn_count connections, then chunk_count chunk
  // infos.
  size_t k = header->index;
  const auto connections = checked_connections(bag, k, header->conn_count);
  if (!connections) return;
  std::map<std::uint64_t, std::set<std::uint64_t> > messages;  // per chunk: its messages' offsets
  for (std::uint64_t i = 0; i < header->chunk_count && k < bag.records.size(); ++i, ++k)
    if (!check_chunk_info(bag, bag.records[k], *connections, messages)) return;
}

/// Every rosbag::Bag loads its encryption plugin (pluginlib: the plugin library is opened with
/// dlopen, its symbols bound) and unloads it when destroyed, when no other Bag holds it: 60 % of
/// the time of opening a small bag (the rosbag fuzz target, docs/FUZZING.md, session 12). One Bag
/// made once, never destroyed, keeps the library loaded for the process. It is held by a pointer
/// of external linkage (below), which the compiler must keep: LeakSanitizer then sees the Bag as
/// reachable (a function-local `static const` pointer that nothing reads was optimised away, and
/// the Bag reported as a leak in every process that opened a bag).
void keep_the_encryptor_plugins_loaded();

}  // namespace

extern rosbag::Bag* g_encryptor_plugin_keeper;
rosbag::Bag* g_encryptor_plugin_keeper = nullptr;

namespace {

void keep_the_encryptor_plugins_loaded() {
  static const bool made = [] {
    g_encryptor_plugin_keeper = new rosbag::Bag();
    return true;
  }();
  (void)made;
}

}  // namespace

BagReader::BagReader(const std::string& path)
    : impl_((keep_the_encryptor_plugins_loaded(), std::make_unique<Impl>())) {
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

BagWriter::BagWriter(const std::string& path, BagCompression compression)
    : impl_(std::make_unique<Impl>()) {
  translate([&] {
    impl_->bag.open(path, rosbag::bagmode::Write);
    impl_->bag.setCompression(compression == BagCompression::bz2 ? rosbag::compression::BZ2
                              : compression == BagCompression::lz4
                                  ? rosbag::compression::LZ4
                                  : rosbag::compression::Uncompressed);
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
