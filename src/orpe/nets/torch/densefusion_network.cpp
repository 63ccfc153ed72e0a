// DenseFusion's PoseNet and PoseRefineNet, functional LibTorch code over a parameter map whose
// names and shapes are the reference implementation's (lib/network.py, lib/pspnet.py,
// lib/extractors.py of the DenseFusion repository; the structure is re-derived here, no code
// copied), and the reference evaluation's pose selection and refinement loop (tools/eval_ycb.py).
// Part of the plugin.
#include <torch/torch.h>

#include <Eigen/Core>
#include <cmath>
#include <map>
#include <stdexcept>

#include "orpe/core/error.h"
#include "orpe/nets/plugin.h"

namespace orpe::nets {

std::map<std::string, HostTensor> read_tensors(const std::string& path);  // maskrcnn_network.cpp

namespace {

namespace F = torch::nn::functional;
using Shape = std::vector<std::int64_t>;
using ParamList = std::vector<std::pair<std::string, Shape>>;

/// The PointNet / fusion branch "feat.*" of both networks; conv5 takes 256 (PoseNet) or 384
/// channels.
void add_point_feature_parameters(ParamList* p, std::int64_t conv5_in) {
  const std::pair<const char*, Shape> feat[] = {
      {"conv1", {64, 3, 1}},     {"conv2", {128, 64, 1}},       {"e_conv1", {64, 32, 1}},
      {"e_conv2", {128, 64, 1}}, {"conv5", {512, conv5_in, 1}}, {"conv6", {1024, 512, 1}}};
  for (const auto& [name, shape] : feat) {
    p->push_back({std::string("feat.") + name + ".weight", shape});
    p->push_back({std::string("feat.") + name + ".bias", {shape[0]}});
  }
}

ParamList posenet_parameters(int num_obj) {
  ParamList p;
  const std::string cnn = "cnn.model.module.";
  p.push_back({cnn + "feats.conv1.weight", {64, 3, 7, 7}});
  int in = 64;
  const int planes[4] = {64, 128, 256, 512};
  for (int l = 0; l < 4; ++l) {
    for (int b = 0; b < 2; ++b) {
      const std::string pre = cnn + "feats.layer" + std::to_string(l + 1) + "." + std::to_string(b);
      p.push_back({pre + ".conv1.weight", {planes[l], b == 0 ? in : planes[l], 3, 3}});
      p.push_back({pre + ".conv2.weight", {planes[l], planes[l], 3, 3}});
      if (b == 0 && in != planes[l])
        p.push_back({pre + ".downsample.0.weight", {planes[l], in, 1, 1}});
    }
    in = planes[l];
  }
  for (int s = 0; s < 4; ++s)
    p.push_back({cnn + "psp.stages." + std::to_string(s) + ".1.weight", {512, 512, 1, 1}});
  p.push_back({cnn + "psp.bottleneck.weight", {1024, 2560, 1, 1}});
  p.push_back({cnn + "psp.bottleneck.bias", {1024}});
  const int up_in[3] = {1024, 256, 64}, up_out[3] = {256, 64, 64};
  for (int u = 0; u < 3; ++u) {
    const std::string pre = cnn + "up_" + std::to_string(u + 1) + ".conv.";
    p.push_back({pre + "1.weight", {up_out[u], up_in[u], 3, 3}});
    p.push_back({pre + "1.bias", {up_out[u]}});
    p.push_back({pre + "2.weight", {1}});
  }
  p.push_back({cnn + "final.0.weight", {32, 64, 1, 1}});
  p.push_back({cnn + "final.0.bias", {32}});
  p.push_back({cnn + "classifier.0.weight", {256, 256}});
  p.push_back({cnn + "classifier.0.bias", {256}});
  p.push_back({cnn + "classifier.2.weight", {21, 256}});
  p.push_back({cnn + "classifier.2.bias", {21}});
  add_point_feature_parameters(&p, 256);
  const int head_in[4] = {1408, 640, 256, 128}, head_out[3] = {640, 256, 128};
  const int last[3] = {4 * num_obj, 3 * num_obj, num_obj};
  for (int layer = 0; layer < 4; ++layer)
    for (int h = 0; h < 3; ++h) {
      const std::string name = "conv" + std::to_string(layer + 1) + "_" + "rtc"[h];
      const std::int64_t out = layer < 3 ? head_out[layer] : last[h];
      p.push_back({name + ".weight", {out, head_in[layer], 1}});
      p.push_back({name + ".bias", {out}});
    }
  return p;
}

ParamList refiner_parameters(int num_obj) {
  ParamList p;
  add_point_feature_parameters(&p, 384);
  const std::pair<const char*, Shape> heads[] = {
      {"conv1_r", {512, 1024}}, {"conv1_t", {512, 1024}},        {"conv2_r", {128, 512}},
      {"conv2_t", {128, 512}},  {"conv3_r", {4 * num_obj, 128}}, {"conv3_t", {3 * num_obj, 128}}};
  for (const auto& [name, shape] : heads) {
    p.push_back({std::string(name) + ".weight", shape});
    p.push_back({std::string(name) + ".bias", {shape[0]}});
  }
  return p;
}

using Params = std::map<std::string, torch::Tensor>;

/// Seeded weights in list order (the fixture script draws the same ones).
Params random_params(const ParamList& list, int seed) {
  torch::manual_seed(seed);
  Params out;
  for (const auto& [name, shape] : list) {
    torch::Tensor t = torch::empty(shape);
    const double std = shape.size() > 1 ? 1.0 / std::sqrt(double(t.numel() / shape[0])) : 0.1;
    t.normal_(0.0, std);
    out[name] = t;
  }
  return out;
}

Params file_params(const ParamList& list, const std::string& path) {
  const auto tensors = read_tensors(path);
  Params out;
  for (const auto& [name, shape] : list) {
    std::string key = name;  // buffers of the converted file: '.' written as "__"
    for (size_t at = key.find('.'); at != std::string::npos; at = key.find('.', at + 2))
      key.replace(at, 1, "__");
    const auto it = tensors.find(key);
    if (it == tensors.end())
      throw IoError(path, "no tensor " + name + " (not a converted checkpoint?)");
    if (it->second.shape != shape)
      throw IoError(path, "tensor " + name + " has another shape than the network's");
    out[name] = torch::from_blob(const_cast<float*>(it->second.values.data()), shape).clone();
  }
  return out;
}

class Net {
 public:
  explicit Net(Params p) : p_(std::move(p)) {}
  const torch::Tensor& operator()(const std::string& name) const { return p_.at(name); }

 private:
  Params p_;
};

torch::Tensor conv(const torch::Tensor& x, const torch::Tensor& w, int stride = 1, int pad = 0,
                   int dil = 1, const torch::Tensor& b = {}) {
  return torch::conv2d(x, w, b, stride, pad, dil);
}

torch::Tensor basic_block(const Net& n, const torch::Tensor& x, const std::string& pre, int stride,
                          int dil, bool downsample) {
  torch::Tensor out = torch::relu(conv(x, n(pre + ".conv1.weight"), stride, dil, dil));
  out = conv(out, n(pre + ".conv2.weight"), 1, dil, dil);
  const torch::Tensor res = downsample ? conv(x, n(pre + ".downsample.0.weight"), stride) : x;
  return torch::relu(out + res);
}

torch::Tensor pspnet(const Net& n, const torch::Tensor& img) {
  const std::string f = "cnn.model.module.feats.";
  torch::Tensor x = torch::relu(conv(img, n(f + "conv1.weight"), 2, 3));
  x = torch::max_pool2d(x, 3, 2, 1);
  const int stride[4] = {1, 2, 1, 1}, dil[4] = {1, 1, 2, 4};
  for (int l = 0; l < 4; ++l) {
    const std::string pre = f + "layer" + std::to_string(l + 1);
    x = basic_block(n, x, pre + ".0", stride[l], 1, l > 0);  // the first block is never dilated
    x = basic_block(n, x, pre + ".1", 1, dil[l], false);
  }
  const std::string c = "cnn.model.module.";
  const std::int64_t h = x.size(2), w = x.size(3);
  std::vector<torch::Tensor> priors;
  const int sizes[4] = {1, 2, 3, 6};
  for (int s = 0; s < 4; ++s) {
    torch::Tensor pr = torch::adaptive_avg_pool2d(x, {sizes[s], sizes[s]});
    pr = conv(pr, n(c + "psp.stages." + std::to_string(s) + ".1.weight"));
    priors.push_back(F::interpolate(
        pr,
        F::InterpolateFuncOptions().size(Shape{h, w}).mode(torch::kBilinear).align_corners(false)));
  }
  priors.push_back(x);
  x = torch::relu(conv(torch::cat(priors, 1), n(c + "psp.bottleneck.weight"), 1, 0, 1,
                       n(c + "psp.bottleneck.bias")));
  for (int u = 1; u <= 3; ++u) {  // dropout: identity at inference
    const std::string pre = c + "up_" + std::to_string(u) + ".conv.";
    x = F::interpolate(x, F::InterpolateFuncOptions()
                              .size(Shape{2 * x.size(2), 2 * x.size(3)})
                              .mode(torch::kBilinear)
                              .align_corners(true));
    x = torch::prelu(conv(x, n(pre + "1.weight"), 1, 1, 1, n(pre + "1.bias")), n(pre + "2.weight"));
  }
  x = conv(x, n(c + "final.0.weight"), 1, 0, 1, n(c + "final.0.bias"));
  return torch::log_softmax(x, 1);
}

torch::Tensor c1d(const Net& n, const std::string& name, const torch::Tensor& x) {
  return torch::conv1d(x, n(name + ".weight"), n(name + ".bias"));
}

/// The PointNet / dense-fusion features: {pointfeat_1, pointfeat_2, pooled global feature}.
std::array<torch::Tensor, 3> point_features(const Net& n, const torch::Tensor& x,
                                            const torch::Tensor& emb, bool refiner) {
  torch::Tensor a = torch::relu(c1d(n, "feat.conv1", x));
  torch::Tensor e = torch::relu(c1d(n, "feat.e_conv1", emb));
  const torch::Tensor pf1 = torch::cat({a, e}, 1);
  a = torch::relu(c1d(n, "feat.conv2", a));
  e = torch::relu(c1d(n, "feat.e_conv2", e));
  const torch::Tensor pf2 = torch::cat({a, e}, 1);
  torch::Tensor g = torch::relu(c1d(n, "feat.conv5", refiner ? torch::cat({pf1, pf2}, 1) : pf2));
  g = torch::relu(c1d(n, "feat.conv6", g));
  return {pf1, pf2, torch::avg_pool1d(g, x.size(2))};
}

Eigen::Matrix4d quaternion_matrix(const double* q_in) {
  Eigen::Vector4d q(q_in[0], q_in[1], q_in[2], q_in[3]);
  const double nn = q.dot(q);
  if (nn < 4 * std::numeric_limits<double>::epsilon()) return Eigen::Matrix4d::Identity();
  q *= std::sqrt(2.0 / nn);
  const Eigen::Matrix4d o = q * q.transpose();
  Eigen::Matrix4d m;
  m << 1 - o(2, 2) - o(3, 3), o(1, 2) - o(3, 0), o(1, 3) + o(2, 0), 0, o(1, 2) + o(3, 0),
      1 - o(1, 1) - o(3, 3), o(2, 3) - o(1, 0), 0, o(1, 3) - o(2, 0), o(2, 3) + o(1, 0),
      1 - o(1, 1) - o(2, 2), 0, 0, 0, 0, 1;
  return m;
}

std::array<double, 4> quaternion_from_matrix(const Eigen::Matrix4d& M) {
  std::array<double, 4> q{};
  double t = M.trace();
  if (t > M(3, 3)) {
    q = {t, M(2, 1) - M(1, 2), M(0, 2) - M(2, 0), M(1, 0) - M(0, 1)};
  } else {
    int i = 0, j = 1, k = 2;
    if (M(1, 1) > M(0, 0)) i = 1, j = 2, k = 0;
    if (M(2, 2) > M(i, i)) i = 2, j = 0, k = 1;
    t = M(i, i) - (M(j, j) + M(k, k)) + M(3, 3);
    std::array<double, 4> v{};
    v[i] = t;
    v[j] = M(i, j) + M(j, i);
    v[k] = M(k, i) + M(i, k);
    v[3] = M(k, j) - M(j, k);
    q = {v[3], v[0], v[1], v[2]};
  }
  const double s = 0.5 / std::sqrt(t * M(3, 3));
  for (double& c : q) c *= s;
  return q;
}

class TorchDenseFusion : public DenseFusionImpl {
 public:
  explicit TorchDenseFusion(const DenseFusionSpec& spec)
      : spec_(spec),
        posenet_list_(posenet_parameters(spec.num_objects)),
        refiner_list_(refiner_parameters(spec.num_objects)),
        posenet_(spec.random_seed >= 0 ? random_params(posenet_list_, spec.random_seed)
                                       : file_params(posenet_list_, spec.posenet_path)),
        refiner_(spec.random_seed >= 0       ? random_params(refiner_list_, spec.random_seed + 1)
                 : spec.refiner_path.empty() ? Params{}
                                             : file_params(refiner_list_, spec.refiner_path)),
        has_refiner_(spec.random_seed >= 0 || !spec.refiner_path.empty()) {}

  DenseFusionPoints estimate(const std::vector<float>& crop, int h, int w,
                             const std::vector<float>& cloud,
                             const std::vector<std::int64_t>& choose, int obj) const override {
    const int np = spec_.num_points;
    if (h % 8 || w % 8 || crop.size() != size_t(3) * h * w || cloud.size() != size_t(3) * np ||
        choose.size() != size_t(np) || obj < 0 || obj >= spec_.num_objects)
      throw std::invalid_argument("densefusion: wrong input sizes");
    for (std::int64_t c : choose)
      if (c < 0 || c >= std::int64_t(h) * w)
        throw std::invalid_argument("densefusion: choose index outside the crop");
    torch::InferenceMode guard;
    const torch::Tensor img = torch::from_blob(const_cast<float*>(crop.data()), {1, 3, h, w});
    const torch::Tensor x = torch::from_blob(const_cast<float*>(cloud.data()), {1, np, 3});
    const torch::Tensor ch =
        torch::from_blob(const_cast<std::int64_t*>(choose.data()), {1, 1, np}, torch::kLong);
    const torch::Tensor out_img = pspnet(posenet_, img);
    const torch::Tensor emb =
        torch::gather(out_img.view({1, 32, -1}), 2, ch.repeat({1, 32, 1})).contiguous();
    const auto [pf1, pf2, g] = point_features(posenet_, x.transpose(2, 1).contiguous(), emb, false);
    const torch::Tensor ap = torch::cat({pf1, pf2, g.repeat({1, 1, np})}, 1);
    torch::Tensor head[3];
    for (int hd = 0; hd < 3; ++hd) {
      torch::Tensor y = ap;
      for (int layer = 1; layer <= 4; ++layer) {
        y = c1d(posenet_, "conv" + std::to_string(layer) + "_" + "rtc"[hd], y);
        if (layer < 4) y = torch::relu(y);
      }
      if (hd == 2) y = torch::sigmoid(y);
      const std::int64_t dims[3] = {4, 3, 1};
      head[hd] = y.view({spec_.num_objects, dims[hd], np})[obj].transpose(0, 1).contiguous();
    }
    auto copy = [](const torch::Tensor& t) {
      return std::vector<float>(t.data_ptr<float>(), t.data_ptr<float>() + t.numel());
    };
    return {copy(head[0]), copy(head[1]), copy(head[2]), copy(emb)};
  }

  DenseFusionPose pose(const DenseFusionPoints& pts, const std::vector<float>& cloud, int obj,
                       int iterations, DenseFusionPose* before) const override {
    const int np = spec_.num_points;
    int best = 0;
    for (int i = 1; i < np; ++i)
      if (pts.confidence[i] > pts.confidence[best]) best = i;
    const float* r = &pts.rotation[4 * best];
    const float norm = std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3]);
    DenseFusionPose pose;
    for (int k = 0; k < 4; ++k) pose.quaternion[k] = r[k] / norm;
    for (int k = 0; k < 3; ++k)
      pose.translation[k] = float(cloud[3 * best + k] + pts.translation[3 * best + k]);
    if (before) *before = pose;
    if (iterations > 0 && !has_refiner_)
      throw std::invalid_argument("densefusion: refinement asked for without a refiner");
    torch::InferenceMode guard;
    const torch::Tensor x = torch::from_blob(const_cast<float*>(cloud.data()), {1, np, 3});
    const torch::Tensor emb =
        torch::from_blob(const_cast<float*>(pts.embedding.data()), {1, 32, np});
    for (int it = 0; it < iterations; ++it) {
      Eigen::Matrix4d m = quaternion_matrix(pose.quaternion.data());
      torch::Tensor R = torch::empty({1, 3, 3});
      torch::Tensor T = torch::empty({1, 1, 3});
      for (int a = 0; a < 3; ++a) {
        for (int b = 0; b < 3; ++b) R[0][a][b] = float(m(a, b));
        T[0][0][a] = float(pose.translation[a]);
        m(a, 3) = double(float(pose.translation[a]));
      }
      const torch::Tensor new_cloud = torch::bmm(x - T, R).contiguous();
      const auto [pf1, pf2, g] =
          point_features(refiner_, new_cloud.transpose(2, 1).contiguous(), emb, true);
      const torch::Tensor ap = g.view({-1, 1024});
      torch::Tensor out[2];
      for (int hd = 0; hd < 2; ++hd) {
        const std::string s(1, "rt"[hd]);
        torch::Tensor y = torch::relu(torch::linear(ap, refiner_("conv1_" + s + ".weight"),
                                                    refiner_("conv1_" + s + ".bias")));
        y = torch::relu(
            torch::linear(y, refiner_("conv2_" + s + ".weight"), refiner_("conv2_" + s + ".bias")));
        y = torch::linear(y, refiner_("conv3_" + s + ".weight"), refiner_("conv3_" + s + ".bias"));
        out[hd] = y.view({spec_.num_objects, hd == 0 ? 4 : 3})[obj].contiguous();
      }
      const torch::Tensor r2 = out[0] / torch::norm(out[0]);
      double q2[4];
      for (int k = 0; k < 4; ++k) q2[k] = r2[k].item<float>();
      Eigen::Matrix4d m2 = quaternion_matrix(q2);
      for (int a = 0; a < 3; ++a) m2(a, 3) = out[1][a].item<float>();
      const Eigen::Matrix4d mf = m * m2;
      Eigen::Matrix4d rot = mf;
      rot.block<3, 1>(0, 3).setZero();
      pose.quaternion = quaternion_from_matrix(rot);
      for (int a = 0; a < 3; ++a) pose.translation[a] = mf(a, 3);
    }
    return pose;
  }

  int num_objects() const override { return spec_.num_objects; }
  int num_points() const override { return spec_.num_points; }
  bool has_refiner() const override { return has_refiner_; }

  ParamList parameters() const override {
    ParamList all = posenet_list_;
    all.insert(all.end(), refiner_list_.begin(), refiner_list_.end());
    return all;
  }

 private:
  DenseFusionSpec spec_;
  ParamList posenet_list_, refiner_list_;
  Net posenet_, refiner_;
  bool has_refiner_;
};

/// The class count of a converted PoseNet file: conv4_r.weight has 4 rows per class.
int file_num_objects(const std::string& path) {
  const auto tensors = read_tensors(path);
  const auto it = tensors.find("conv4_r__weight");
  if (it == tensors.end())
    throw IoError(path, "no tensor conv4_r.weight (not a converted PoseNet checkpoint?)");
  if (it->second.shape.empty() || it->second.shape[0] <= 0 || it->second.shape[0] % 4)
    throw IoError(path, "tensor conv4_r.weight has no 4 rows per class");
  return static_cast<int>(it->second.shape[0] / 4);
}

}  // namespace

std::unique_ptr<DenseFusionImpl> open_densefusion(const DenseFusionSpec& spec_in) {
  DenseFusionSpec spec = spec_in;
  if (spec.num_points <= 0) throw std::invalid_argument("densefusion: num_points must be > 0");
  if (spec.num_objects <= 0) {
    if (spec.random_seed >= 0)
      throw std::invalid_argument("densefusion: seeded weights need num_objects > 0");
    spec.num_objects = file_num_objects(spec.posenet_path);
  }
  if (spec.threads > 0) at::set_num_threads(spec.threads);
  return std::make_unique<TorchDenseFusion>(spec);
}

}  // namespace orpe::nets
