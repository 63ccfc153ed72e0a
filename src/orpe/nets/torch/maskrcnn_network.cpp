// The LibTorch plugin (liborpe_nets_torch.so, orpe/nets/plugin.h): torchvision operator
// registration, Mask R-CNN loading and inference, fixture reading. One translation unit on purpose
// (LibTorch headers cost ~1 GB of compiler memory per file).
#include <ATen/Parallel.h>
#include <torch/script.h>

#include <spdlog/spdlog.h>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>

#include "orpe/core/error.h"
#include "orpe/nets/maskrcnn.h"
#include "orpe/nets/plugin.h"
#include "orpe/nets/torchvision_kernels.h"

namespace orpe::nets {

namespace {

at::Tensor nms_op(const at::Tensor& dets, const at::Tensor& scores, double iou_threshold) {
  TORCH_CHECK(dets.dim() == 2 && dets.size(1) == 4, "nms: boxes must be N x 4");
  TORCH_CHECK(scores.dim() == 1 && scores.size(0) == dets.size(0), "nms: one score per box");
  const at::Tensor b = dets.to(at::kFloat).contiguous(), s = scores.to(at::kFloat).contiguous();
  const std::vector<std::int64_t> keep =
      nms_cpu(b.data_ptr<float>(), s.data_ptr<float>(), static_cast<int>(b.size(0)),
              static_cast<float>(iou_threshold));
  return torch::tensor(keep, at::kLong);
}

at::Tensor roi_align_op(const at::Tensor& input, const at::Tensor& rois, double spatial_scale,
                        std::int64_t pooled_height, std::int64_t pooled_width,
                        std::int64_t sampling_ratio, bool aligned) {
  TORCH_CHECK(input.dim() == 4, "roi_align: input must be N x C x H x W");
  TORCH_CHECK(rois.dim() == 2 && rois.size(1) == 5, "roi_align: rois must be K x 5");
  TORCH_CHECK(input.scalar_type() == at::kFloat, "roi_align: float input only");
  const at::Tensor x = input.contiguous(), r = rois.to(at::kFloat).contiguous();
  RoiAlignSpec spec;
  spec.batch = static_cast<int>(x.size(0));
  spec.channels = static_cast<int>(x.size(1));
  spec.height = static_cast<int>(x.size(2));
  spec.width = static_cast<int>(x.size(3));
  spec.spatial_scale = static_cast<float>(spatial_scale);
  spec.pooled_height = static_cast<int>(pooled_height);
  spec.pooled_width = static_cast<int>(pooled_width);
  spec.sampling_ratio = static_cast<int>(sampling_ratio);
  spec.aligned = aligned;
  at::Tensor out = at::zeros({r.size(0), x.size(1), pooled_height, pooled_width}, x.options());
  if (r.size(0) == 0 || x.numel() == 0) return out;
  try {
    roi_align_cpu(x.data_ptr<float>(), spec, r.data_ptr<float>(), static_cast<int>(r.size(0)),
                  out.data_ptr<float>());
  } catch (const std::invalid_argument& e) {
    TORCH_CHECK(false, e.what());
  }
  return out;
}

/// torchvision::nms / torchvision::roi_align with torchvision 0.14's schemas, CPU kernels ours.
void register_torchvision_ops() {
  static std::once_flag once;
  std::call_once(once, [] {
    static torch::Library def(torch::Library::DEF, "torchvision", c10::nullopt, __FILE__, __LINE__);
    def.def("nms(Tensor dets, Tensor scores, float iou_threshold) -> Tensor");
    def.def(
        "roi_align(Tensor input, Tensor rois, float spatial_scale, int pooled_height, "
        "int pooled_width, int sampling_ratio, bool aligned) -> Tensor");
    static torch::Library impl(torch::Library::IMPL, "torchvision", c10::DispatchKey::CPU, __FILE__,
                               __LINE__);
    impl.impl("nms", TORCH_FN(nms_op));
    impl.impl("roi_align", TORCH_FN(roi_align_op));
  });
}

/// LibTorch warnings go to orpe's log; the one every scripted torchvision detector gives on each
/// call ("RCNN always returns a (Losses, Detections) tuple in scripting") is dropped.
class WarningToLog : public c10::WarningHandler {
 public:
  void process(const c10::SourceLocation& where, const std::string& msg, bool verbatim) override {
    (void)where;
    (void)verbatim;
    if (msg.find("always returns a (Losses, Detections) tuple") == std::string::npos)
      spdlog::warn("LibTorch: {}", msg);
  }
};

std::string first_line(const std::string& text) {
  const size_t nl = text.find('\n');
  return nl == std::string::npos ? text : text.substr(0, nl);
}

void require_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError(path, "cannot open the model file");
}

torch::jit::Module load_module(const std::string& path, torch::jit::ExtraFilesMap* extra) {
  require_file(path);
  register_torchvision_ops();
  try {
    return torch::jit::load(path, c10::nullopt, *extra);
  } catch (const c10::Error& e) {
    throw IoError(path, "not a TorchScript file LibTorch 1.13 can load: " +
                            first_line(e.what_without_backtrace()));
  }
}

}  // namespace

std::map<std::string, HostTensor> read_tensors(const std::string& path) {
  torch::jit::ExtraFilesMap extra;
  torch::jit::Module m = load_module(path, &extra);
  std::map<std::string, HostTensor> out;
  for (const auto& b : m.named_buffers()) {
    const at::Tensor t = b.value.to(at::kFloat).contiguous();
    HostTensor h;
    h.shape.assign(t.sizes().begin(), t.sizes().end());
    h.values.assign(t.data_ptr<float>(), t.data_ptr<float>() + t.numel());
    out[b.name] = std::move(h);
  }
  return out;
}

class TorchMaskRcnn : public MaskRcnnImpl {
 public:
  TorchMaskRcnn(const std::string& model_path, const MaskRcnnOptions& options);
  int num_classes() const override { return num_classes_; }
  MaskRcnnOutput run(const ColorImage& image) const override;

 private:
  std::string path_;
  mutable torch::jit::Module module_;
  int num_classes_ = 0;
};

TorchMaskRcnn::TorchMaskRcnn(const std::string& model_path, const MaskRcnnOptions& options)
    : path_(model_path) {
  torch::jit::ExtraFilesMap extra{{"orpe_maskrcnn.json", ""}};
  module_ = load_module(model_path, &extra);
  torch::jit::Module& m = module_;
  if (!m.hasattr("transform") || !m.hasattr("roi_heads") || !m.find_method("forward"))
    throw IoError(model_path, "not a scripted torchvision Mask R-CNN (no transform / roi_heads)");
  if (!extra["orpe_maskrcnn.json"].empty()) {
    const auto meta = nlohmann::json::parse(extra["orpe_maskrcnn.json"], nullptr, false);
    if (meta.is_discarded() || !meta.contains("num_classes") ||
        !meta["num_classes"].is_number_integer())
      throw IoError(model_path, "orpe_maskrcnn.json inside the model has no integer num_classes");
    num_classes_ = meta["num_classes"].get<int>();
  }
  torch::jit::Module transform = m.attr("transform").toModule();
  try {
    if (options.min_size_px > 0)
      transform.setattr("min_size", c10::ivalue::Tuple::create({c10::IValue(
                                        static_cast<std::int64_t>(options.min_size_px))}));
    if (options.max_size_px > 0)
      transform.setattr("max_size", static_cast<std::int64_t>(options.max_size_px));
  } catch (const c10::Error& e) {
    throw IoError(model_path,
                  "cannot set the input size: " + first_line(e.what_without_backtrace()));
  }
  if (options.threads > 0) at::set_num_threads(options.threads);
}

namespace {

ProbabilityImage to_image(const at::Tensor& plane) {
  ProbabilityImage img(static_cast<int>(plane.size(1)), static_cast<int>(plane.size(0)));
  const at::Tensor p = plane.contiguous();
  std::copy(p.data_ptr<float>(), p.data_ptr<float>() + p.numel(), img.data());
  return img;
}

MaskRcnnOutput to_output(const c10::Dict<c10::IValue, c10::IValue>& dets, int width, int height) {
  const at::Tensor boxes = dets.at("boxes").toTensor().to(at::kFloat).contiguous();
  const at::Tensor scores = dets.at("scores").toTensor().to(at::kFloat).contiguous();
  const at::Tensor labels = dets.at("labels").toTensor().to(at::kLong).contiguous();
  const at::Tensor masks = dets.at("masks").toTensor().to(at::kFloat);
  const std::int64_t n = scores.size(0);
  TORCH_CHECK(boxes.size(0) == n && labels.size(0) == n && masks.size(0) == n,
              "boxes / scores / labels / masks differ in length");
  TORCH_CHECK(n == 0 || (masks.dim() == 4 && masks.size(2) == height && masks.size(3) == width),
              "masks are not N x 1 x H x W of the image");
  MaskRcnnOutput out;
  for (std::int64_t i = 0; i < n; ++i) {
    const float* b = boxes.data_ptr<float>() + 4 * i;
    out.boxes.push_back({b[0], b[1], b[2], b[3]});
    out.scores.push_back(scores.data_ptr<float>()[i]);
    out.labels.push_back(static_cast<int>(labels.data_ptr<std::int64_t>()[i]));
    out.masks.push_back(to_image(masks[i][0]));
  }
  return out;
}

}  // namespace

MaskRcnnOutput TorchMaskRcnn::run(const ColorImage& image) const {
  if (image.width() < 32 || image.height() < 32)
    throw std::invalid_argument("maskrcnn: the image is " + std::to_string(image.width()) + "x" +
                                std::to_string(image.height()) + ", the network needs >= 32x32");
  c10::InferenceMode guard;
  WarningToLog to_log;
  const c10::Warning::WarningHandlerGuard warnings(&to_log);
  static_assert(sizeof(Rgb8) == 3);
  const at::Tensor hwc = torch::from_blob(const_cast<Rgb8*>(image.data()),
                                          {image.height(), image.width(), 3}, at::kByte);
  const at::Tensor chw = hwc.permute({2, 0, 1}).to(at::kFloat).div(255).contiguous();
  try {
    c10::List<at::Tensor> images({chw});
    const c10::IValue result = module_.forward({images});
    const auto dets = result.toTupleRef().elements().at(1).toList().get(0).toGenericDict();
    return to_output(dets, image.width(), image.height());
  } catch (const c10::Error& e) {
    throw IoError(path_, "the network failed: " + first_line(e.what_without_backtrace()));
  }
}

std::unique_ptr<DenseFusionImpl> open_densefusion(
    const DenseFusionSpec& spec);  // densefusion_network.cpp

std::unique_ptr<MaskRcnnImpl> open_maskrcnn(const std::string& path,
                                            const MaskRcnnOptions& options) {
  return std::make_unique<TorchMaskRcnn>(path, options);
}

}  // namespace orpe::nets

extern "C" __attribute__((visibility("default"))) const orpe::nets::PluginApi* orpe_nets_plugin() {
  static const orpe::nets::PluginApi api{orpe::nets::kPluginApiVersion, &orpe::nets::open_maskrcnn,
                                         &orpe::nets::read_tensors, &orpe::nets::open_densefusion};
  return &api;
}
