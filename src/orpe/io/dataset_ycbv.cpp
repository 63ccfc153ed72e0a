// YCB-Video layout: <root>/data/NNNN/NNNNNN-{color.png, depth.png, label.png, meta.mat}, with
// <root>/classes.txt and <root>/models/<class>/{points.xyz, textured_simple.obj}. meta.mat is read
// with libmatio (kept inside this file).
#include <algorithm>
#include <cctype>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <matio.h>
#include <spdlog/spdlog.h>
#include <zlib.h>

#include "orpe/core/error.h"
#include "orpe/core/parse_number.h"
#include "orpe/io/dataset_common.h"
#include "orpe/io/image_io.h"

namespace orpe::detail {
namespace fs = std::filesystem;
namespace {

constexpr double kFrameRateHz = 30.0;  // nominal; the layout has no timestamps
const char* const kSymmetricClassNames[] = {"024_bowl", "036_wood_block", "051_large_clamp",
                                            "052_extra_large_clamp", "061_foam_brick"};

// ---- matio ----

void route_matio_log(int level, char* message) {
  // matio reports problems here and then returns NULL; the caller turns that into an IoError.
  spdlog::debug("matio ({}): {}", level, message ? message : "");
}

void init_matio_logging() {
  static std::once_flag once;
  std::call_once(once, [] { Mat_LogInitFunc("orpe", route_matio_log); });
}

struct MatFileCloser {
  void operator()(mat_t* m) const { Mat_Close(m); }
};
struct MatVarFreer {
  void operator()(matvar_t* v) const { Mat_VarFree(v); }
};
using MatFilePtr = std::unique_ptr<mat_t, MatFileCloser>;
using MatVarPtr = std::unique_ptr<matvar_t, MatVarFreer>;

/// A numeric MATLAB array converted to double, column-major, with its dimensions.
struct MatArray {
  std::vector<size_t> dims;
  std::vector<double> values;
};

template <class T>
void convert(const void* data, size_t n, std::vector<double>& out) {
  const T* p = static_cast<const T*>(data);
  out.assign(p, p + n);
}

/// Bytes per element of a numeric MATLAB class; 0 for any other class.
size_t numeric_element_bytes(matio_classes c) {
  switch (c) {
    case MAT_C_DOUBLE:
    case MAT_C_INT64:
    case MAT_C_UINT64:
      return 8;
    case MAT_C_SINGLE:
    case MAT_C_INT32:
    case MAT_C_UINT32:
      return 4;
    case MAT_C_INT16:
    case MAT_C_UINT16:
      return 2;
    case MAT_C_INT8:
    case MAT_C_UINT8:
      return 1;
    default:
      return 0;
  }
}

/// Reads variable `name` as doubles; nullopt when absent. Throws IoError for a non-numeric, complex
/// or unreadable variable.
std::optional<MatArray> read_mat_array(mat_t* mat, const char* name, const std::string& path) {
  MatVarPtr var(Mat_VarRead(mat, name));
  if (!var) return std::nullopt;
  if (var->isComplex) throw IoError(path, fmt::format("variable '{}' is complex", name));
  MatArray a;
  size_t n = 1;
  for (int i = 0; i < var->rank; ++i) {
    a.dims.push_back(var->dims[i]);
    n *= var->dims[i];
  }
  if (n == 0) {
    a.values.clear();
    return a;
  }
  if (!var->data)
    throw IoError(path, fmt::format("variable '{}' has no data (truncated file?)", name));
  const size_t elem = numeric_element_bytes(var->class_type);
  if (elem == 0) throw IoError(path, fmt::format("variable '{}' is not a numeric array", name));
  if (var->nbytes < n * elem)
    throw IoError(path, fmt::format("variable '{}' is truncated ({} of {} bytes)", name,
                                    var->nbytes, n * elem));
  switch (var->class_type) {
    case MAT_C_DOUBLE:
      convert<double>(var->data, n, a.values);
      break;
    case MAT_C_SINGLE:
      convert<float>(var->data, n, a.values);
      break;
    case MAT_C_INT8:
      convert<int8_t>(var->data, n, a.values);
      break;
    case MAT_C_UINT8:
      convert<uint8_t>(var->data, n, a.values);
      break;
    case MAT_C_INT16:
      convert<int16_t>(var->data, n, a.values);
      break;
    case MAT_C_UINT16:
      convert<uint16_t>(var->data, n, a.values);
      break;
    case MAT_C_INT32:
      convert<int32_t>(var->data, n, a.values);
      break;
    case MAT_C_UINT32:
      convert<uint32_t>(var->data, n, a.values);
      break;
    case MAT_C_INT64:
      convert<int64_t>(var->data, n, a.values);
      break;
    default:
      convert<uint64_t>(var->data, n, a.values);
      break;
  }
  return a;
}

/// The parts of a YCB-Video meta.mat the reader uses, already in library conventions.
struct YcbMeta {
  std::optional<double> factor_depth;  // raw depth units per metre
  std::optional<Mat3> K;
  std::optional<SE3> T_cam_world;
  std::vector<int> class_ids;
  std::vector<SE3> T_cam_obj;  // same order as class_ids
};

/// The most bytes deflate can expand one byte into (zlib: 1032:1).
constexpr double kMaxInflateRatio = 1032;

/// The first `max_out` bytes (at most) that the zlib stream `data` inflates to; fewer when the
/// stream ends there. `corrupt` is set when the stream is not valid zlib up to that point.
std::string inflate_head(const char* data, size_t size, size_t max_out, bool& corrupt) {
  z_stream z{};
  corrupt = inflateInit(&z) != Z_OK;
  if (corrupt) return {};
  std::string out(max_out, '\0');
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data));
  z.avail_in = static_cast<uInt>(size);
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = static_cast<uInt>(max_out);
  const int rc = inflate(&z, Z_SYNC_FLUSH);
  corrupt = rc != Z_OK && rc != Z_STREAM_END && rc != Z_BUF_ERROR;
  out.resize(z.total_out);
  inflateEnd(&z);
  return out;
}

// libmatio sizes its allocations from the file's tags and dimensions before checking them against
// the file (fuzz ycbv_meta: a 411-byte meta.mat with a name tag of 4 GB made it allocate and clear
// 4 GB). check_mat5_sizes refuses such a file first. Of a compressed variable, the head (the first
// 64 KiB inflated: array flags, dimensions) is checked the same way, its element count against the
// size it declares once inflated, itself at most kMaxInflateRatio x its compressed size. Cells and
// structs inside a compressed variable are not walked; v7.3 (HDF5) files are left to matio.
struct Mat5Reader {
  const std::string& path;
  const std::string& bytes;
  bool swap = false;
  std::string where;  // "in the compressed variable at byte N: " for an inflated head

  uint32_t u32(size_t at) const {
    uint32_t v;
    std::memcpy(&v, bytes.data() + at, 4);
    return swap ? __builtin_bswap32(v) : v;
  }
  [[noreturn]] void corrupt(size_t at, const std::string& what) const {
    throw IoError(path, fmt::format("corrupt MATLAB file: {}{} (byte {})", where, what, at));
  }
  /// Walks the data elements in [begin, end); a matrix's elements are walked too (depth-limited).
  void elements(size_t begin, size_t end, int depth) const {
    if (depth > 16) corrupt(begin, "arrays nested too deep");
    for (size_t at = begin, index = 0; at + 8 <= end; ++index) {
      const uint32_t tag = u32(at);
      if (tag >> 16) {  // small element: type and size in one word, data in the next
        at += 8;
        continue;
      }
      const size_t n = u32(at + 4);
      if (n > end - at - 8)
        corrupt(at, fmt::format("an element of {} bytes where {} remain", n, end - at - 8));
      if (tag == 14) matrix(at + 8, at + 8 + n, depth + 1);  // miMATRIX
      if (tag == 15 && depth == 0) compressed(at + 8, n);    // miCOMPRESSED
      // Elements inside a matrix are padded to 8 bytes; top-level ones (miCOMPRESSED) are not.
      at += 8 + (depth > 0 ? (n + 7) / 8 * 8 : n);
    }
  }
  /// A data element's type, data offset and size, in either format (small: type and size in one
  /// word, at most 4 bytes of data in the next).
  struct Element {
    uint32_t type;
    size_t data, size;
  };
  Element element_at(size_t at) const {
    const uint32_t tag = u32(at);
    if (tag >> 16) return {tag & 0xffff, at + 4, tag >> 16};
    return {tag, at + 8, u32(at + 4)};
  }
  /// A matrix: array flags (miUINT32), dimensions (miINT32), name, data. Each stored value takes at
  /// least one byte, so the element count (but for sparse arrays) cannot exceed the matrix's size.
  /// The types of the flags and dimensions are checked too: libmatio reads the dimensions whatever
  /// their declared type (fuzz/corpus/ycbv_meta/crash-oom-dims-type-0-1gb.mat: type 0, 1 GB).
  void matrix(size_t begin, size_t end, int depth) const {
    elements(begin, end, depth);
    matrix_header(begin, end);
  }
  /// A compressed variable of `size` bytes at `begin`: one miMATRIX element once inflated, of at
  /// most kMaxInflateRatio x `size` bytes, whose head (array flags, dimensions) is checked like an
  /// uncompressed matrix's. fuzz/corpus/ycbv_meta: crash-slow-compressed-dims-tag-100mb.mat (a
  /// dimensions tag of 100 MB: libmatio allocated 400 MB at each variable it looked up) and
  /// crash-oom-compressed-dims-3gb.mat (20000 x 20000 doubles in a variable of 72 bytes: matio
  /// allocated 3.2 GB for the data).
  void compressed(size_t begin, size_t size) const {
    constexpr size_t kHeadBytes = 64 * 1024;
    bool bad_stream = false;
    const std::string head = inflate_head(bytes.data() + begin, size, kHeadBytes, bad_stream);
    // libmatio reads what a corrupt stream gave before the error, and sized allocations from it
    // (fuzz/corpus/ycbv_meta/crash-slow-corrupt-zlib-stream.mat: 450 MB).
    if (bad_stream || head.size() < 8)
      corrupt(begin - 8, fmt::format("a compressed variable of {} bytes whose zlib data does not "
                                     "inflate",
                                     size));
    Mat5Reader inner{path, head, swap,
                     fmt::format("in the compressed variable at byte {}: ", begin - 8)};
    const Element e = inner.element_at(0);
    if (e.type != 14)
      inner.corrupt(0, fmt::format("an element of type {} (MAT v5: miMATRIX = 14)", e.type));
    if (static_cast<double>(e.size) > kMaxInflateRatio * static_cast<double>(size) + 64)
      inner.corrupt(0, fmt::format("a matrix of {} bytes from {} compressed bytes", e.size, size));
    inner.matrix_header(e.data, e.data + e.size);
  }
  /// The array name after the dimensions: miINT8, in the bytes present; a small element holds at
  /// most 4 (fuzz/corpus/ycbv_meta/crash-oom-compressed-name-tag.mat: a compressed variable's name
  /// tag of 1.6 GB made libmatio allocate it).
  void check_name(size_t at, size_t limit) const {
    if (at + 8 > limit) corrupt(at, "a matrix without a name");
    const uint32_t tag = u32(at);
    const Element name = element_at(at);
    if (name.type != 1 || ((tag >> 16) && name.size > 4) || name.data + name.size > limit)
      corrupt(at, fmt::format("an array name of type {} and {} bytes where {} remain (MAT v5: "
                              "miINT8, at most 4 bytes in the small format)",
                              name.type, name.size, limit - std::min(limit, name.data)));
  }
  /// The head of the matrix in [begin, end): flags, dimensions and the element count they give;
  /// only the bytes present are read (an inflated head can end before `end`).
  void matrix_header(size_t begin, size_t end) const {
    if (end == begin) return;  // an empty matrix
    const size_t limit = std::min(end, bytes.size());
    if (limit < begin + 16) corrupt(begin, "a matrix too short for its array flags and dimensions");
    const Element flags = element_at(begin);
    if (flags.type != 6 || flags.size < 8)
      corrupt(begin, fmt::format("array flags of type {} and {} bytes (MAT v5: miUINT32, 8 bytes)",
                                 flags.type, flags.size));
    const uint32_t array_class = u32(flags.data) & 0xff;
    const size_t dims_at = begin + 8 + (flags.size + 7) / 8 * 8;
    if (dims_at + 8 > limit) corrupt(begin, "a matrix without dimensions");
    const Element dims = element_at(dims_at);
    if (dims.type != 5)
      corrupt(dims_at, fmt::format("array dimensions of type {} (MAT v5: miINT32 = 5)", dims.type));
    if (dims.data + dims.size > limit)
      corrupt(dims_at, fmt::format("array dimensions of {} bytes where {} remain", dims.size,
                                   limit - std::min(limit, dims.data)));
    check_name(dims.data + (dims.size + 7) / 8 * 8, limit);
    if (array_class == 5) return;  // sparse: the count is not bounded by the size
    double elements_count = 1;
    for (size_t k = 0; k + 4 <= dims.size; k += 4) elements_count *= u32(dims.data + k);
    if (elements_count > static_cast<double>(end - begin))
      corrupt(begin,
              fmt::format("an array of {:.0f} elements in {} bytes", elements_count, end - begin));
  }
};

void check_mat5_sizes(const std::string& path) {
  std::ifstream is(path, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(is)), std::istreambuf_iterator<char>());
  // Shorter than the MAT v5 header: libmatio would try it as MAT v4 and allocate the name length
  // that its header claims (fuzz/corpus/ycbv_meta/crash-oom-short-v4-header.mat: 40 bytes, 1.6 GB).
  if (bytes.size() < 128)
    throw IoError(path, fmt::format("not a MATLAB 5 or 7.3 file ({} bytes: shorter than the "
                                    "128-byte header)",
                                    bytes.size()));
  Mat5Reader r{path, bytes, false, {}};
  if (bytes[126] == 'M' && bytes[127] == 'I')
    r.swap = true;
  else if (bytes[126] != 'I' || bytes[127] != 'M')
    throw IoError(path, "not a MATLAB 5 or 7.3 file (no 'MI'/'IM' endian mark at byte 126)");
  const uint32_t version = static_cast<uint8_t>(bytes[r.swap ? 125 : 124]) |
                           (static_cast<uint8_t>(bytes[r.swap ? 124 : 125]) << 8);
  if (version == 0x0200) return;  // v7.3: an HDF5 file, read by libhdf5
  if (version != 0x0100)
    throw IoError(path, fmt::format("unknown MATLAB file version 0x{:04x}", version));
  r.elements(128, bytes.size(), 0);
}

MatFilePtr open_mat(const std::string& path) {
  init_matio_logging();
  if (!fs::exists(path)) throw IoError(path, "file not found");
  check_mat5_sizes(path);
  MatFilePtr mat(Mat_Open(path.c_str(), MAT_ACC_RDONLY));
  if (!mat) throw IoError(path, "cannot open as a MATLAB file (truncated or corrupt?)");
  return mat;
}

bool all_finite(const std::vector<double>& v) {
  return std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
}

/// Column-major 3x4 [R | t] starting at `offset` in `v`.
SE3 pose_3x4(const std::vector<double>& v, size_t offset, const std::string& path,
             const std::string& what) {
  Mat3 R;
  Vec3 t;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) R(r, c) = v[offset + r + 3 * c];
    t(r) = v[offset + r + 9];
  }
  return checked_pose(R, t, path, what);
}

YcbMeta read_meta(const std::string& path, bool with_objects) {
  MatFilePtr mat = open_mat(path);
  YcbMeta meta;
  if (auto f = read_mat_array(mat.get(), "factor_depth", path)) {
    // A scalar, or an array of one repeated value in some exports.
    if (f->values.empty() || !std::isfinite(f->values[0]) || !(f->values[0] > 0))
      throw IoError(path, "factor_depth must be a positive number (raw depth units per metre)");
    meta.factor_depth = f->values[0];
  }
  if (auto k = read_mat_array(mat.get(), "intrinsic_matrix", path)) {
    if (k->values.size() != 9 || !all_finite(k->values))
      throw IoError(path, "intrinsic_matrix must be a finite 3x3 matrix");
    Mat3 K;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) K(r, c) = k->values[r + 3 * c];
    if (!(K(0, 0) > 0) || !(K(1, 1) > 0))
      throw IoError(path, "intrinsic_matrix has non-positive focal lengths");
    meta.K = K;
  }
  if (auto rt = read_mat_array(mat.get(), "rotation_translation_matrix", path)) {
    if (rt->values.size() != 12) throw IoError(path, "rotation_translation_matrix must be 3x4");
    meta.T_cam_world = pose_3x4(rt->values, 0, path, "rotation_translation_matrix");
  }
  if (!with_objects) return meta;

  auto cls = read_mat_array(mat.get(), "cls_indexes", path);
  auto poses = read_mat_array(mat.get(), "poses", path);
  if (!cls) throw IoError(path, "no 'cls_indexes' variable");
  if (!poses) throw IoError(path, "no 'poses' variable (truncated file?)");
  const size_t n = cls->values.size();
  // poses is 3x4xN; MATLAB stores a single object's pose as a plain 3x4.
  const bool shape_ok = poses->dims.size() >= 2 && poses->dims[0] == 3 && poses->dims[1] == 4 &&
                        poses->values.size() == 12 * n;
  if (!shape_ok)
    throw IoError(
        path, fmt::format("poses must be 3x4xN with N = {} (entries of cls_indexes), has {} values",
                          n, poses->values.size()));
  for (size_t k = 0; k < n; ++k) {
    const double c = cls->values[k];
    if (!(c >= 1) || c != std::floor(c) || c > 1e6)
      throw IoError(path, fmt::format("cls_indexes[{}] = {} is not a class index >= 1", k, c));
    meta.class_ids.push_back(static_cast<int>(c));
    meta.T_cam_obj.push_back(
        pose_3x4(poses->values, 12 * k, path, fmt::format("poses(:,:,{})", k + 1)));
  }
  return meta;
}

// ---- layout ----

bool is_digits(const std::string& s) {
  return !s.empty() &&
         std::all_of(s.begin(), s.end(), [](unsigned char c) { return std::isdigit(c); });
}

/// Frame number of "NNNNNN-<suffix>", or -1.
int frame_number(const std::string& name, const std::string& suffix) {
  if (name.size() <= suffix.size() + 1) return -1;
  if (name.compare(name.size() - suffix.size(), suffix.size(), suffix) != 0) return -1;
  const std::string digits = name.substr(0, name.size() - suffix.size() - 1);
  if (name[digits.size()] != '-' || !is_digits(digits)) return -1;
  return parse_int_field(digits, name, "frame number", 0);
}

bool has_ycb_frames(const fs::path& dir) {
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (frame_number(e.path().filename().string(), "meta.mat") >= 0) return true;
  return false;
}

std::vector<std::string> video_folders(const fs::path& data_dir) {
  std::vector<std::string> out;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(data_dir, ec))
    if (e.is_directory() && has_ycb_frames(e.path())) out.push_back(e.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}

struct YcbFrame {
  int number = 0;
  std::string color, depth, label, meta;
};

class YcbReader final : public SelectedFramesReader {
 public:
  YcbReader(const std::string& path, const DatasetParams& params) {
    params_ = params;
    fs::path video_dir, root;
    if (has_ycb_frames(path)) {
      video_dir = path;
      // data/NNNN -> the dataset root two levels up holds classes.txt and models/.
      for (fs::path up :
           {video_dir.parent_path().parent_path(), video_dir.parent_path(), video_dir})
        if (fs::exists(up / "classes.txt")) {
          root = up;
          break;
        }
      if (!params.scene.empty() && params.scene != video_dir.filename().string())
        throw ConfigError(fmt::format("dataset.scene = '{}' but {} is the video folder {}",
                                      params.scene, path, video_dir.filename().string()));
    } else {
      root = path;
      const auto videos = video_folders(root / "data");
      if (videos.empty())
        throw IoError((root / "data").string(), "no video folders with NNNNNN-meta.mat files");
      std::string video = params.scene.empty() ? videos.front() : params.scene;
      if (std::find(videos.begin(), videos.end(), video) == videos.end())
        throw ConfigError(fmt::format("dataset.scene = '{}' is not a video of {} (has: {})",
                                      params.scene, (root / "data").string(),
                                      fmt::join(videos, ", ")));
      video_dir = root / "data" / video;
    }
    scan_frames(video_dir);
    selected_ = select_frames(frames_.size(), params, video_dir.string());

    info_.format = "ycbv";
    info_.root = path;
    const std::string video_name = video_dir.filename().string();
    info_.scene_id = is_digits(video_name) ? parse_int_field(video_name, video_dir.string(),
                                                             "video folder name (the scene id)", 0)
                                           : 0;
    if (!root.empty()) load_classes_and_models(root);

    // Intrinsics / depth scale of the first selected frame whose meta.mat reads.
    PinholeIntrinsics k = preset_intrinsics();
    info_.depth_units_per_m = params.depth_units_per_m;
    for (size_t i = 0; i < selected_.size() && i < 3; ++i) {
      try {
        const YcbMeta meta = read_meta(frames_[selected_[i]].meta, false);
        if (meta.K) k = intrinsics_from(*meta.K);
        if (info_.depth_units_per_m <= 0 && meta.factor_depth)
          info_.depth_units_per_m = *meta.factor_depth;
        break;
      } catch (const IoError& e) {
        spdlog::debug("{}", e.what());
      }
    }
    info_.intrinsics =
        with_image_size(apply_intrinsics_overrides(k, params), {frames_[selected_[0]].color});
  }

  RgbdFrame read(size_t i) const override {
    const YcbFrame& fr = frames_[position(i)];
    const YcbMeta meta = read_meta(fr.meta, true);
    double units = params_.depth_units_per_m;
    if (units <= 0) {
      if (!meta.factor_depth)
        throw IoError(
            fr.meta,
            "no 'factor_depth' (depth scale); set dataset.depth_units_per_m to read this frame");
      units = *meta.factor_depth;
    }
    RgbdFrame f = annotations(fr, meta);
    load_color_and_depth(fr.color, fr.depth, units, params_, f);
    std::map<int, int> label_of_class;  // class id -> objects_gt index + 1
    for (size_t k = 0; k < f.objects_gt.size(); ++k)
      label_of_class.emplace(f.objects_gt[k].class_id, static_cast<int>(k) + 1);
    if (fs::exists(fr.label)) {
      f.labels_gt = load_labels_matching(fr.label, f);
      size_t unmatched = 0;
      for (int32_t& l : f.labels_gt) {
        if (l == 0) continue;
        const auto it = label_of_class.find(l);
        if (it == label_of_class.end()) {
          ++unmatched;
          l = 0;
        } else {
          l = it->second;
        }
      }
      if (unmatched > 0)
        spdlog::debug("{}: {} labelled pixels of classes absent from meta.mat set to background",
                      fr.label, unmatched);
    }
    return f;
  }

  RgbdFrame read_annotations(size_t i) const override {
    const YcbFrame& fr = frames_[position(i)];
    return annotations(fr, read_meta(fr.meta, true));
  }

  std::vector<StampedPose> ground_truth_trajectory() const override {
    std::vector<StampedPose> out;
    for (size_t p : selected_) {
      try {
        const YcbMeta meta = read_meta(frames_[p].meta, false);
        if (meta.T_cam_world)
          out.push_back({frames_[p].number / kFrameRateHz, meta.T_cam_world->inverse()});
      } catch (const IoError& e) {
        spdlog::warn("ground truth: {}", e.what());
      }
    }
    return out;
  }

 private:
  /// The frame's fields from meta.mat (no pixels; image size from the dataset's first frame).
  RgbdFrame annotations(const YcbFrame& fr, const YcbMeta& meta) const {
    RgbdFrame f;
    f.index = fr.number;
    f.timestamp_s = fr.number / kFrameRateHz;
    f.name = fmt::format("{:04d}/{}", info_.scene_id, fs::path(fr.color).filename().string());
    f.intrinsics = apply_intrinsics_overrides(
        meta.K ? intrinsics_from(*meta.K) : preset_intrinsics(), params_);
    f.intrinsics.width = info_.intrinsics.width;
    f.intrinsics.height = info_.intrinsics.height;
    if (meta.T_cam_world) f.T_world_cam_gt = meta.T_cam_world->inverse();
    for (size_t k = 0; k < meta.class_ids.size(); ++k) {
      // With a class list, an index past it names no class (and no model): refused, not skipped.
      if (!info_.class_names.empty() && !info_.class_names.count(meta.class_ids[k]))
        throw IoError(fr.meta,
                      fmt::format("cls_indexes[{}] = {} is beyond the {} classes of classes.txt", k,
                                  meta.class_ids[k], info_.class_names.size()));
      ObjectGroundTruth o;
      o.class_id = meta.class_ids[k];
      o.instance_id = o.class_id;  // one instance per class in YCB-Video
      o.T_cam_obj = meta.T_cam_obj[k];
      f.objects_gt.push_back(o);
    }
    return f;
  }

  void scan_frames(const fs::path& video_dir) {
    std::map<int, YcbFrame> frames;
    for (const auto& e : fs::directory_iterator(video_dir)) {
      const std::string name = e.path().filename().string();
      for (const char* suffix : {"color.png", "depth.png", "meta.mat"}) {
        const int n = frame_number(name, suffix);
        if (n < 0) continue;
        const std::string stem = (video_dir / fmt::format("{:06d}", n)).string();
        frames[n] = {n, stem + "-color.png", stem + "-depth.png", stem + "-label.png",
                     stem + "-meta.mat"};
      }
    }
    for (auto& [n, f] : frames) frames_.push_back(f);
  }

  void load_classes_and_models(const fs::path& root) {
    const fs::path classes = root / "classes.txt";
    std::ifstream is(classes);
    if (!is) return;
    std::string line;
    int id = 0;
    while (std::getline(is, line)) {
      while (!line.empty() && std::isspace(static_cast<unsigned char>(line.back())))
        line.pop_back();
      if (line.empty()) continue;
      ++id;
      info_.class_names[id] = line;
      const fs::path dir = root / "models" / line;
      if (fs::exists(dir / "points.xyz"))
        info_.model_points_paths[id] = (dir / "points.xyz").string();
      if (fs::exists(dir / "textured_simple.obj"))
        info_.model_mesh_paths[id] = (dir / "textured_simple.obj").string();
      for (const char* sym : kSymmetricClassNames)
        if (line == sym) info_.symmetric_classes.push_back(id);
    }
    info_.model_units_per_m = 1.0;
  }

  /// REFERENCE.md: the camera of videos 0-59 and the one of videos >= 60 (used when meta.mat has no
  /// K).
  PinholeIntrinsics preset_intrinsics() const {
    PinholeIntrinsics k;
    if (info_.scene_id >= 60) {
      k.fx = 1077.836, k.fy = 1078.189, k.cx = 323.7872, k.cy = 279.6921;
    } else {
      k.fx = 1066.778, k.fy = 1067.487, k.cx = 312.9869, k.cy = 241.3109;
    }
    return k;
  }

  static PinholeIntrinsics intrinsics_from(const Mat3& K) {
    PinholeIntrinsics k;
    k.fx = K(0, 0);
    k.fy = K(1, 1);
    k.cx = K(0, 2);
    k.cy = K(1, 2);
    return k;
  }

  std::vector<YcbFrame> frames_;
};

}  // namespace

bool looks_like_ycbv(const std::string& path) {
  if (has_ycb_frames(path)) return true;
  return !video_folders(fs::path(path) / "data").empty();
}

std::unique_ptr<DatasetReader> open_ycbv(const std::string& path, const DatasetParams& params) {
  if (!looks_like_ycbv(path))
    throw IoError(
        path,
        "not a YCB-Video folder: expected data/NNNN/NNNNNN-meta.mat, or NNNNNN-meta.mat here");
  return std::make_unique<YcbReader>(path, params);
}

}  // namespace orpe::detail
