// The maskrcnn segmentation back-end: a tiny seeded torchvision Mask R-CNN (scripted, committed in
// tests/nets/data by scripts/nets/maskrcnn_export.py fixtures) run in LibTorch with orpe's
// torchvision operators gives eager torchvision's boxes, scores, labels and soft masks; the
// segmenter maps labels through the class map; bad files and inputs are clear errors.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "nets/net_fixtures.h"
#include "orpe/core/error.h"
#include "support/test_data.h"

namespace orpe {
namespace {

using nets::HostTensor;

const std::map<int, std::string> kClasses = {{1, "cup"}, {2, "box"}, {3, "can"}, {4, "bowl"}};

ColorImage fixture_image(const HostTensor& chw) {
  const int h = int(chw.shape[1]), w = int(chw.shape[2]);
  ColorImage img(w, h);
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      auto px = [&](int c) { return std::uint8_t(chw.values[(size_t(c) * h + v) * w + u]); };
      img.at(u, v) = {px(0), px(1), px(2)};
    }
  return img;
}

SegmentationParams tiny_params() {
  SegmentationParams p;
  p.backend = "maskrcnn";
  p.maskrcnn_model = test::nets_data("maskrcnn_tiny.pt");
  p.min_score = 0;
  p.min_mask_area_px = 0;
  return p;
}

std::string write_file(const std::string& name, const std::string& text) {
  const std::string path = test::scratch_dir("maskrcnn_" + name) + "/" + name;
  std::ofstream(path) << text;
  return path;
}

template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(maskrcnn, TinyModelMatchesTorchvisionOnBoxesScoresLabelsAndSoftMasks) {
  ORPE_REQUIRE_TORCH();
  auto ref = nets::read_tensor_file(test::nets_data("maskrcnn_tiny_expected.pt"));
  const nets::MaskRcnnNetwork net(test::nets_data("maskrcnn_tiny.pt"), {});
  EXPECT_EQ(net.num_classes(), 4);
  const nets::MaskRcnnOutput out = net.run(fixture_image(ref.at("image")));
  const size_t n = ref.at("scores").values.size();
  ASSERT_GE(n, 3u);
  ASSERT_EQ(out.scores.size(), n);
  const double score_error = test::max_relative_error(out.scores, ref.at("scores").values, n);
  EXPECT_LE(score_error, 1e-4);
  std::vector<float> boxes;
  for (const auto& b : out.boxes) boxes.insert(boxes.end(), b.begin(), b.end());
  const double box_error = test::max_relative_error(boxes, ref.at("boxes").values, 4 * n);
  EXPECT_LE(box_error, 1e-4);
  const HostTensor& masks = ref.at("masks");
  ASSERT_EQ(masks.shape.size(), 3u);
  double mask_error = 0;
  int mask_px = 0;
  for (size_t i = 0; i < n; ++i) {
    EXPECT_EQ(out.labels[i], int(ref.at("labels").values[i])) << i;
    ASSERT_EQ(out.masks[i].width(), masks.shape[2]);
    ASSERT_EQ(out.masks[i].height(), masks.shape[1]);
    const size_t plane = out.masks[i].size();
    mask_error = std::max(
        mask_error,
        test::max_relative_error(out.masks[i].data(), masks.values.data() + i * plane, plane));
    mask_px += mask_area(out.masks[i], 0.5f);
  }
  EXPECT_LE(mask_error, 1e-4);
  EXPECT_GT(mask_px, 0);  // the masks are not all background
  std::printf("maskrcnn equivalence: %zu detections, max error scores %.2g boxes %.2g masks %.2g\n",
              n, score_error, box_error, mask_error);
}

TEST(maskrcnn, SegmenterMapsLabelsToDatasetClassesAndFilters) {
  ORPE_REQUIRE_TORCH();
  auto ref = nets::read_tensor_file(test::nets_data("maskrcnn_tiny_expected.pt"));
  SegmentationParams p = tiny_params();
  p.maskrcnn_class_map = write_file("map.txt", "# shuffled\n1 can\n2 4\n3 cup\n");
  p.min_score = 0.3;
  const nets::MaskRcnnSegmenter seg(p, kClasses);
  RgbdFrame frame;
  frame.color = fixture_image(ref.at("image"));
  const auto dets = seg.detect(frame);
  const std::map<int, int> mapped = {{1, 3}, {2, 4}, {3, 1}};
  size_t expected = 0;
  for (size_t i = 0; i < ref.at("scores").values.size(); ++i) {
    if (ref.at("scores").values[i] < 0.3f) continue;
    ASSERT_LT(expected, dets.size());
    EXPECT_EQ(dets[expected].class_id, mapped.at(int(ref.at("labels").values[i])));
    EXPECT_NEAR(dets[expected].score, ref.at("scores").values[i], 1e-5);
    ++expected;
  }
  EXPECT_EQ(dets.size(), expected);
  EXPECT_GT(expected, 0u);
  EXPECT_LT(expected, ref.at("scores").values.size());  // the score filter removed some
}

/// The error of constructing the segmenter with `p` (a failure when there is none).
std::string segmenter_error(const SegmentationParams& p) {
  return error_of([&] { nets::MaskRcnnSegmenter(p, kClasses); });
}

TEST(maskrcnn, ClearErrorsForBadModelFilesAndClassMaps) {
  ORPE_REQUIRE_TORCH();
  SegmentationParams p = tiny_params();
  std::vector<std::pair<SegmentationParams, std::string>> cases;
  p.maskrcnn_model = "/nonexistent/model.pt";
  cases.push_back({p, "/nonexistent/model.pt: cannot open the model file"});
  p.maskrcnn_model = write_file("garbage.pt", "not a zip archive");
  cases.push_back({p, "garbage.pt: not a TorchScript file"});
  p.maskrcnn_model = test::nets_data("torchvision_ops.pt");  // TorchScript, but no Mask R-CNN
  cases.push_back({p, "not a scripted torchvision Mask R-CNN"});
  p = tiny_params();
  p.maskrcnn_class_map = write_file("short.txt", "1 1\n2 2\n");
  cases.push_back({p, "short.txt: maps 2 labels, the network has 3 classes"});
  p.maskrcnn_class_map = write_file("unknown.txt", "1 1\n2 plate\n3 3\n");
  cases.push_back({p, "unknown.txt: line 2: 'plate' is not a class of the dataset"});
  p.maskrcnn_class_map = write_file("range.txt", "1 1\n4 2\n3 3\n");
  cases.push_back({p, "range.txt: line 2, label"});
  p.maskrcnn_class_map = write_file("twice.txt", "1 1\n2 2\n2 3\n");
  cases.push_back({p, "twice.txt: line 3: label 2 appears twice"});
  for (const auto& [params, expected] : cases) {
    const std::string error = segmenter_error(params);
    EXPECT_NE(error.find(expected), std::string::npos) << error;
  }
}

TEST(maskrcnn, ClearErrorsForFramesOfTheWrongSize) {
  ORPE_REQUIRE_TORCH();
  SegmentationParams p = tiny_params();
  p.maskrcnn_input_width_px = 640;
  p.maskrcnn_input_height_px = 480;
  const nets::MaskRcnnSegmenter seg(p, kClasses);
  RgbdFrame frame;
  frame.name = "f7";
  frame.color = ColorImage(64, 48);
  EXPECT_NE(error_of([&] { seg.detect(frame); }).find("frame f7 is 64x48"), std::string::npos);
  frame.depth = DepthImage(32, 48);
  EXPECT_NE(error_of([&] { seg.detect(frame); }).find("colour image is 64x48, depth image 32x48"),
            std::string::npos);
  const nets::MaskRcnnNetwork net(p.maskrcnn_model, {});
  EXPECT_NE(error_of([&] { net.run(ColorImage(20, 48)); }).find("needs >= 32x32"),
            std::string::npos);
}

TEST(maskrcnn, InputSizeOptionChangesTheNetworkResolution) {
  ORPE_REQUIRE_TORCH();
  auto ref = nets::read_tensor_file(test::nets_data("maskrcnn_tiny_expected.pt"));
  nets::MaskRcnnOptions o;
  o.min_size_px = 96;
  o.max_size_px = 128;
  const nets::MaskRcnnNetwork net(test::nets_data("maskrcnn_tiny.pt"), o);
  const auto out = net.run(fixture_image(ref.at("image")));
  ASSERT_FALSE(out.scores.empty());
  EXPECT_EQ(out.masks[0].width(), 64);  // still pasted into the full frame
  EXPECT_GT(test::max_relative_error(out.scores, ref.at("scores").values,
                                     std::min(out.scores.size(), ref.at("scores").values.size())),
            1e-3);  // another resolution, other outputs
}

TEST(maskrcnn, BackendSaysWhenItIsNotBuilt) {
  if (nets::torch_built()) GTEST_SKIP() << "built with LibTorch";
  EXPECT_NE(error_of([&] {
              nets::MaskRcnnSegmenter(tiny_params(), kClasses);
            }).find("built without LibTorch (ORPE_WITH_TORCH=OFF)"),
            std::string::npos);
}

}  // namespace
}  // namespace orpe
