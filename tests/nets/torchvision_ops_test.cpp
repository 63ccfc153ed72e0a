// orpe's CPU kernels of torchvision::nms and torchvision::roi_align against torchvision 0.14's on
// random inputs (tests/nets/data/torchvision_ops.pt, scripts/nets/maskrcnn_export.py fixtures).
#include <gtest/gtest.h>

#include "nets/net_fixtures.h"
#include "orpe/nets/torchvision_kernels.h"

namespace orpe {
namespace {

using nets::HostTensor;

TEST(maskrcnn_ops, NmsKeepsTheBoxesTorchvisionKeeps) {
  ORPE_REQUIRE_TORCH();
  auto t = nets::read_tensor_file(test::nets_data("torchvision_ops.pt"));
  const HostTensor& boxes = t.at("nms_boxes");
  const HostTensor& scores = t.at("nms_scores");
  ASSERT_EQ(boxes.shape.at(0), 300);
  for (int tenths : {3, 5, 7}) {
    const HostTensor& expected = t.at("nms_keep_" + std::to_string(tenths));
    const auto keep = nets::nms_cpu(boxes.values.data(), scores.values.data(), 300, tenths / 10.0f);
    ASSERT_EQ(keep.size(), expected.values.size()) << "iou " << tenths / 10.0;
    EXPECT_LT(keep.size(), 300u);  // the fixture's clustered boxes do suppress
    for (size_t i = 0; i < keep.size(); ++i) EXPECT_EQ(keep[i], expected.values[i]) << i;
  }
}

TEST(maskrcnn_ops, RoiAlignMatchesTorchvision) {
  ORPE_REQUIRE_TORCH();
  auto t = nets::read_tensor_file(test::nets_data("torchvision_ops.pt"));
  const HostTensor& input = t.at("roi_input");
  const HostTensor& rois = t.at("roi_rois");
  for (int c = 0; c < 4; ++c) {
    const HostTensor& p = t.at("roi_params_" + std::to_string(c));
    nets::RoiAlignSpec spec;
    spec.batch = int(input.shape[0]);
    spec.channels = int(input.shape[1]);
    spec.height = int(input.shape[2]);
    spec.width = int(input.shape[3]);
    spec.spatial_scale = p.values[0];
    spec.pooled_height = int(p.values[1]);
    spec.pooled_width = int(p.values[2]);
    spec.sampling_ratio = int(p.values[3]);
    spec.aligned = p.values[4] != 0;
    const HostTensor& expected = t.at("roi_out_" + std::to_string(c));
    const int k = int(rois.shape[0]);
    std::vector<float> out(size_t(k) * spec.channels * spec.pooled_height * spec.pooled_width);
    ASSERT_EQ(out.size(), expected.values.size());
    nets::roi_align_cpu(input.values.data(), spec, rois.values.data(), k, out.data());
    const double error = test::max_relative_error(out, expected.values, out.size());
    EXPECT_LE(error, 1e-5) << "case " << c;
    std::printf("roi_align case %d: max error %.2g\n", c, error);
  }
}

TEST(maskrcnn_ops, RoiAlignRefusesABatchIndexOutsideTheInput) {
  const float input[4] = {1, 2, 3, 4};
  nets::RoiAlignSpec spec{1, 1, 2, 2, 1.0f, 1, 1, 1, false};
  const float roi[5] = {1, 0, 0, 1, 1};
  float out[1];
  EXPECT_THROW(nets::roi_align_cpu(input, spec, roi, 1, out), std::invalid_argument);
}

}  // namespace
}  // namespace orpe
