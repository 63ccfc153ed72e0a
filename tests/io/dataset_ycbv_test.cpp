// YCB-Video reader on a tiny dataset whose meta.mat files are written here with libmatio.
#include <gtest/gtest.h>

#include <matio.h>

#include <functional>
#include <map>

#include "io/dataset_fixtures.h"
#include "orpe/core/error.h"
#include "orpe/io/dataset.h"
#include "support/test_data.h"

namespace orpe {
namespace {
using test::kH;
using test::kW;

/// One variable of a meta.mat: class, dims and data (column-major), stored as given.
struct MatVariable {
  std::string name;
  matio_classes cls = MAT_C_DOUBLE;
  std::vector<size_t> dims;
  std::vector<double> values;  // converted to `cls` when written
};

void write_mat(const std::string& path, const std::vector<MatVariable>& vars, bool compressed) {
  mat_t* mat = Mat_CreateVer(path.c_str(), nullptr, MAT_FT_MAT5);
  ASSERT_NE(mat, nullptr);
  for (const MatVariable& v : vars) {
    std::vector<double> d = v.values;
    std::vector<float> f(v.values.begin(), v.values.end());
    std::vector<uint16_t> u16(v.values.begin(), v.values.end());
    std::vector<int32_t> i32(v.values.begin(), v.values.end());
    void* data = d.data();
    matio_types type = MAT_T_DOUBLE;
    if (v.cls == MAT_C_SINGLE) data = f.data(), type = MAT_T_SINGLE;
    if (v.cls == MAT_C_UINT16) data = u16.data(), type = MAT_T_UINT16;
    if (v.cls == MAT_C_INT32) data = i32.data(), type = MAT_T_INT32;
    std::vector<size_t> dims = v.dims;
    matvar_t* var = Mat_VarCreate(v.name.c_str(), v.cls, type, static_cast<int>(dims.size()),
                                  dims.data(), data, 0);
    ASSERT_NE(var, nullptr);
    ASSERT_EQ(Mat_VarWrite(mat, var, compressed ? MAT_COMPRESSION_ZLIB : MAT_COMPRESSION_NONE), 0);
    Mat_VarFree(var);
  }
  Mat_Close(mat);
}

/// Column-major 3x4 [R|t] values of a pose.
std::vector<double> col_major_3x4(const SE3& T) {
  std::vector<double> v(12);
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 3; ++r) v[r + 3 * c] = c < 3 ? T.rotation()(r, c) : T.translation()(r);
  return v;
}

struct YcbFrameSpec {
  std::vector<int> classes = {2, 3};
  double factor_depth = 10000;
  matio_classes factor_class = MAT_C_DOUBLE;
  bool with_factor = true;
  bool compressed = false;
};

SE3 object_pose(int frame, int cls) {
  return test::test_pose(frame + 10 * cls);
}
SE3 camera_pose_T_cam_world(int frame) {
  return test::test_pose(100 + frame);
}

std::vector<MatVariable> meta_variables(int frame, const YcbFrameSpec& spec) {
  std::vector<MatVariable> vars;
  const size_t n = spec.classes.size();
  std::vector<double> cls(spec.classes.begin(), spec.classes.end()), poses;
  for (int c : spec.classes) {
    const auto p = col_major_3x4(object_pose(frame, c));
    poses.insert(poses.end(), p.begin(), p.end());
  }
  vars.push_back({"cls_indexes", MAT_C_DOUBLE, {n, 1}, cls});
  if (spec.with_factor)
    vars.push_back({"factor_depth", spec.factor_class, {1, 1}, {spec.factor_depth}});
  vars.push_back({"intrinsic_matrix", MAT_C_DOUBLE, {3, 3}, {1000, 0, 0, 0, 1001, 0, 4.5, 3.5, 1}});
  vars.push_back({"rotation_translation_matrix",
                  MAT_C_DOUBLE,
                  {3, 4},
                  col_major_3x4(camera_pose_T_cam_world(frame))});
  // A single object's poses is a plain 3x4 in MATLAB files.
  vars.push_back({"poses", MAT_C_DOUBLE,
                  n == 1 ? std::vector<size_t>{3, 4} : std::vector<size_t>{3, 4, n}, poses});
  return vars;
}

/// Label image: left half class classes[0], a right block classes[1], a pixel of class 5 (absent).
LabelImage frame_labels(const std::vector<int>& classes) {
  LabelImage l(kW, kH, 0);
  for (int v = 0; v < kH; ++v)
    for (int u = 0; u < kW; ++u) {
      if (u < 4 && v > 0) l.at(u, v) = classes[0];
      if (u >= 5 && v >= 2 && classes.size() > 1) l.at(u, v) = classes[1];
    }
  l.at(4, 0) = 5;
  return l;
}

void write_ycb_frame(const std::string& video_dir, int frame, const YcbFrameSpec& spec) {
  const std::string stem = fmt::format("{}/{:06d}", video_dir, frame);
  write_color_png(stem + "-color.png", test::tiny_color(frame));
  write_depth_png(stem + "-depth.png", test::tiny_depth(0.8 + 0.1 * frame), spec.factor_depth);
  write_label_png(stem + "-label.png", frame_labels(spec.classes), /*eight_bit=*/true);
  write_mat(stem + "-meta.mat", meta_variables(frame, spec), spec.compressed);
}

/// <root>/classes.txt (3 classes), models for two of them, data/0003 with frames 1..3 and data/0007
/// with frame 1.
std::string make_ycb(const std::string& root) {
  test::write_text(root + "/classes.txt", "002_master_chef_can\n024_bowl\n061_foam_brick\n");
  test::write_text(root + "/models/024_bowl/points.xyz", "0 0 0\n0.01 0 0\n");
  test::write_text(root + "/models/024_bowl/textured_simple.obj", "v 0 0 0\n");
  test::write_text(root + "/models/002_master_chef_can/points.xyz", "0 0 0\n");
  for (int i = 1; i <= 3; ++i) {
    YcbFrameSpec spec;
    spec.compressed = i == 2;
    write_ycb_frame(root + "/data/0003", i, spec);
  }
  write_ycb_frame(root + "/data/0007", 1, YcbFrameSpec{});
  return root;
}

TEST(YcbReader, ReadsFramesObjectsLabelsAndInfo) {
  const std::string root = make_ycb(test::scratch_dir("ycb"));
  EXPECT_EQ(detect_dataset_format(root), "ycbv");
  auto reader = open_dataset(root, DatasetParams{});
  ASSERT_EQ(reader->size(), 3u);
  const DatasetInfo& info = reader->info();
  EXPECT_EQ(info.format, "ycbv");
  EXPECT_EQ(info.scene_id, 3);
  EXPECT_DOUBLE_EQ(info.depth_units_per_m, 10000.0);
  EXPECT_DOUBLE_EQ(info.intrinsics.fx, 1000.0);
  EXPECT_DOUBLE_EQ(info.intrinsics.fy, 1001.0);
  EXPECT_DOUBLE_EQ(info.intrinsics.cx, 4.5);
  EXPECT_EQ(info.intrinsics.width, kW);
  ASSERT_EQ(info.class_names.size(), 3u);
  EXPECT_EQ(info.class_names.at(2), "024_bowl");
  EXPECT_EQ(info.symmetric_classes, (std::vector<int>{2, 3}));
  EXPECT_EQ(info.model_points_paths.size(), 2u);
  EXPECT_NE(info.model_points_paths.at(2).find("models/024_bowl/points.xyz"), std::string::npos);
  EXPECT_EQ(info.model_mesh_paths.count(2), 1u);
  EXPECT_EQ(info.model_mesh_paths.count(1), 0u);

  for (size_t i = 0; i < 3; ++i) {
    const int n = static_cast<int>(i) + 1;
    const RgbdFrame f = reader->read(i);
    EXPECT_EQ(f.index, n);
    EXPECT_NEAR(f.depth.at(3, 3), 0.8 + 0.1 * n + 0.003, 1e-6);
    ASSERT_TRUE(f.T_world_cam_gt);
    EXPECT_LT((f.T_world_cam_gt->matrix() - camera_pose_T_cam_world(n).inverse().matrix()).norm(),
              1e-9);
    ASSERT_EQ(f.objects_gt.size(), 2u);
    for (size_t k = 0; k < 2; ++k) {
      const int c = static_cast<int>(k) + 2;
      EXPECT_EQ(f.objects_gt[k].class_id, c);
      EXPECT_EQ(f.objects_gt[k].instance_id, c);
      EXPECT_LT((f.objects_gt[k].T_cam_obj.matrix() - object_pose(n, c).matrix()).norm(), 1e-9);
    }
    ASSERT_EQ(f.labels_gt.width(), kW);
    EXPECT_EQ(f.labels_gt.at(1, 1), 1);  // class 2 -> objects_gt[0]
    EXPECT_EQ(f.labels_gt.at(6, 4), 2);  // class 3 -> objects_gt[1]
    EXPECT_EQ(f.labels_gt.at(4, 0), 0);  // class 5 has no pose in meta.mat
    EXPECT_EQ(f.labels_gt.at(1, 0), 0);
  }
  EXPECT_EQ(reader->ground_truth_trajectory().size(), 3u);
  test::expect_annotations_match_frames(*reader);
}

TEST(YcbReader, SceneSelectionAndVideoFolder) {
  const std::string root = make_ycb(test::scratch_dir("ycb"));
  DatasetParams p;
  p.scene = "0007";
  auto reader = open_dataset(root, p);
  EXPECT_EQ(reader->size(), 1u);
  EXPECT_EQ(reader->info().scene_id, 7);
  p.scene = "0042";
  EXPECT_THROW(open_dataset(root, p), ConfigError);
  // The video folder itself: classes.txt found two levels up.
  auto video = open_dataset(root + "/data/0003", DatasetParams{});
  EXPECT_EQ(video->info().format, "ycbv");
  EXPECT_EQ(video->size(), 3u);
  EXPECT_EQ(video->info().class_names.size(), 3u);
  EXPECT_EQ(video->info().scene_id, 3);
}

TEST(YcbReader, FactorDepthOfOtherClassesSingleObjectAndOverride) {
  const std::string dir = test::scratch_dir("ycb") + "/data/0001";
  YcbFrameSpec spec;
  spec.classes = {3};  // rank-2 poses
  spec.factor_depth = 1000;
  spec.factor_class = MAT_C_UINT16;
  write_ycb_frame(dir, 1, spec);
  spec.factor_class = MAT_C_SINGLE;
  write_ycb_frame(dir, 2, spec);
  auto reader = open_dataset(dir, DatasetParams{});
  ASSERT_EQ(reader->size(), 2u);
  EXPECT_DOUBLE_EQ(reader->info().depth_units_per_m, 1000.0);
  for (size_t i = 0; i < 2; ++i) {
    const RgbdFrame f = reader->read(i);
    EXPECT_NEAR(f.depth.at(2, 2), 0.8 + 0.1 * (i + 1) + 0.002, 1e-6);
    ASSERT_EQ(f.objects_gt.size(), 1u);
    EXPECT_EQ(f.objects_gt[0].class_id, 3);
  }
  DatasetParams p;
  p.depth_units_per_m = 500;  // override: depth doubles
  EXPECT_NEAR(open_dataset(dir, p)->read(0).depth.at(2, 2), 2 * (0.9 + 0.002), 1e-6);
}

TEST(YcbReader, BadMetaFilesAreErrorsNamingTheFile) {
  const std::string dir = test::scratch_dir("ycb") + "/data/0001";
  for (int i = 1; i <= 6; ++i) write_ycb_frame(dir, i, YcbFrameSpec{});
  // 2: no depth scale; 3: truncated; 4: poses / cls_indexes disagree; 5: corrupt; 6: bad
  // factor_depth.
  YcbFrameSpec no_factor;
  no_factor.with_factor = false;
  write_mat(dir + "/000002-meta.mat", meta_variables(2, no_factor), false);
  test::truncate_file(dir + "/000003-meta.mat",
                      std::filesystem::file_size(dir + "/000003-meta.mat") / 2);
  auto vars = meta_variables(4, YcbFrameSpec{});
  vars[0].values.push_back(7);
  vars[0].dims[0] = 3;
  write_mat(dir + "/000004-meta.mat", vars, false);
  test::write_garbage(dir + "/000005-meta.mat");
  YcbFrameSpec negative;
  negative.factor_depth = -10;
  write_mat(dir + "/000006-meta.mat", meta_variables(6, negative), false);

  auto reader = open_dataset(dir, DatasetParams{});
  ASSERT_EQ(reader->size(), 6u);
  EXPECT_NO_THROW(reader->read(0));
  test::expect_io_error_naming([&] { reader->read(1); }, "000002-meta.mat");
  test::expect_io_error_naming([&] { reader->read(2); }, "000003-meta.mat");
  test::expect_io_error_naming([&] { reader->read(3); }, "000004-meta.mat");
  test::expect_io_error_naming([&] { reader->read(4); }, "000005-meta.mat");
  test::expect_io_error_naming([&] { reader->read(5); }, "000006-meta.mat");
  FrameStream stream(*reader);
  RgbdFrame f;
  int good = 0;
  while (stream.next(f)) ++good;
  EXPECT_EQ(good, 1);
  EXPECT_EQ(stream.skipped(), 5u);
  // With an explicit depth scale, the frame without factor_depth reads.
  DatasetParams p;
  p.depth_units_per_m = 10000;
  EXPECT_NO_THROW(open_dataset(dir, p)->read(1));
}

// cls_indexes past classes.txt named no class and was accepted (issue 12).
TEST(YcbReader, ClassIndexBeyondTheClassListIsAnError) {
  const std::string root = make_ycb(test::scratch_dir("ycb"));
  YcbFrameSpec spec;
  spec.classes = {2, 25};
  write_ycb_frame(root + "/data/0003", 2, spec);
  DatasetParams p;
  p.scene = "0003";
  auto reader = open_dataset(root, p);
  EXPECT_NO_THROW(reader->read_annotations(0));
  test::expect_io_error_naming([&] { reader->read_annotations(1); }, "000002-meta.mat");
  try {
    reader->read(1);
    ADD_FAILURE() << "no error";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("cls_indexes[1] = 25 is beyond the 3 classes"),
              std::string::npos)
        << e.what();
  }
}

TEST(YcbReader, LabelSizeMismatchAndMissingMeta) {
  const std::string dir = test::scratch_dir("ycb") + "/data/0001";
  for (int i = 1; i <= 3; ++i) write_ycb_frame(dir, i, YcbFrameSpec{});
  write_label_png(dir + "/000002-label.png", LabelImage(kW, kH + 1, 0));
  std::filesystem::remove(dir + "/000003-meta.mat");
  auto reader = open_dataset(dir, DatasetParams{});
  ASSERT_EQ(reader->size(), 3u);
  test::expect_io_error_naming([&] { reader->read(1); }, "000002-label.png");
  test::expect_io_error_naming([&] { reader->read(2); }, "000003-meta.mat");
}

TEST(YcbReader, MetaMatWithATagBeyondTheFileIsRefusedBeforeMatioAllocatesIt) {
  // fuzz/corpus/ycbv_meta/crash-oom-name-tag-4gb.mat (found by the ycbv_meta fuzz target): 411
  // bytes whose variable-name tag claims 4 GB; libmatio allocated and cleared 4 GB for it.
  const std::string dir = test::scratch_dir("ycb_fuzz") + "/data/0000";
  write_ycb_frame(dir, 1, YcbFrameSpec{});
  std::filesystem::copy_file(
      std::string(ORPE_SOURCE_DIR) + "/fuzz/corpus/ycbv_meta/crash-oom-name-tag-4gb.mat",
      dir + "/000001-meta.mat", std::filesystem::copy_options::overwrite_existing);
  auto reader = open_dataset(dir, DatasetParams{});
  test::expect_io_error_naming([&] { reader->read_annotations(0); }, "000001-meta.mat");
  try {
    reader->read_annotations(0);
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("corrupt MATLAB file"), std::string::npos) << e.what();
  }
}

/// Reads fuzz/corpus/ycbv_meta/`corpus_file` as the meta.mat of a one-frame video: an IoError
/// naming the file and containing `needle` (a refusal before libmatio reads the variable).
void expect_corpus_meta_refused(const std::string& corpus_file, const std::string& needle) {
  const std::string dir = test::scratch_dir("ycb_fuzz_corpus") + "/data/0000";
  write_ycb_frame(dir, 1, YcbFrameSpec{});
  std::filesystem::copy_file(std::string(ORPE_SOURCE_DIR) + "/fuzz/corpus/ycbv_meta/" + corpus_file,
                             dir + "/000001-meta.mat",
                             std::filesystem::copy_options::overwrite_existing);
  auto reader = open_dataset(dir, DatasetParams{});
  try {
    reader->read_annotations(0);
    ADD_FAILURE() << corpus_file << ": no error";
  } catch (const IoError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("000001-meta.mat"), std::string::npos) << what;
    EXPECT_NE(what.find(needle), std::string::npos) << what;
  }
}

TEST(YcbReader, MetaMatWithDimensionsOfTheWrongTypeIsRefusedBeforeMatioAllocatesIt) {
  // Found by the ycbv_meta fuzz target: 365 bytes; a matrix's dimensions have type 0 instead of
  // miINT32, and libmatio, which reads them anyway, allocated 1 GB for [1 x 1095565313] doubles.
  expect_corpus_meta_refused("crash-oom-dims-type-0-1gb.mat", "array dimensions of type 0");
}

TEST(YcbReader, CompressedMetaVariableOfMoreElementsThanBytesIsRefusedBeforeMatioReadsIt) {
  // 227 bytes: a compressed variable 'factor_depth' declaring 20000 x 20000 doubles in 72 bytes.
  // libmatio allocated 3.2 GB for its data before inflating it, and the conversion to doubles
  // would have copied all of it.
  expect_corpus_meta_refused(
      "crash-oom-compressed-dims-3gb.mat",
      "in the compressed variable at byte 128: an array of 400000000 elements in 72 bytes");
}

TEST(YcbReader, CompressedMetaDimensionsTagBeyondTheVariableIsRefusedBeforeMatioReadsIt) {
  // crash-slow-compressed-dims-tag-100mb.mat (found by the ycbv_meta fuzz target, a timeout under
  // ASan): a compressed variable with a dimensions tag of 100663304 bytes; libmatio allocated 400
  // MB for the dimensions at each variable it looked up. Its zlib checksum is wrong too (refused
  // for that first, by the next test's check); the -valid-zlib copy has the same bytes
  // recompressed.
  expect_corpus_meta_refused(
      "crash-slow-compressed-dims-tag-100mb-valid-zlib.mat",
      "in the compressed variable at byte 128: array dimensions of 100663304 bytes");
}

TEST(YcbReader, CompressedMetaVariableWithCorruptZlibDataIsRefusedBeforeMatioReadsIt) {
  // Found by the ycbv_meta fuzz target (timeouts under ASan): libmatio sized allocations from what
  // a corrupt zlib stream inflated to before its error (450 MB in the first file).
  expect_corpus_meta_refused("crash-slow-corrupt-zlib-stream.mat",
                             "a compressed variable of 84 bytes whose zlib data does not inflate "
                             "(byte 333)");
  expect_corpus_meta_refused("crash-slow-compressed-dims-tag-100mb.mat",
                             "a compressed variable of 91 bytes whose zlib data does not inflate");
}

TEST(YcbReader, CompressedMetaVariableWithANameTagBeyondItsBytesIsRefusedBeforeMatioReadsIt) {
  // Found by the ycbv_meta fuzz target: a compressed variable whose name tag claims 1,638,145,809
  // bytes; libmatio allocated 1.6 GB for the name.
  expect_corpus_meta_refused("crash-oom-compressed-name-tag.mat",
                             "in the compressed variable at byte 249: an array name of type 1 and "
                             "1638145809 bytes");
}

TEST(YcbReader, MetaMatShorterThanTheHeaderIsRefusedBeforeMatioReadsItAsMatV4) {
  // Found by the ycbv_meta fuzz target: 40 bytes; libmatio read them as a MAT v4 header and
  // allocated the 1.6 GB name length it claims.
  expect_corpus_meta_refused(
      "crash-oom-short-v4-header.mat",
      "not a MATLAB 5 or 7.3 file (40 bytes: shorter than the 128-byte header)");
}

}  // namespace
}  // namespace orpe
