#include <cmath>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>

#include "orpe/core/error.h"
#include "orpe/core/parse_number.h"
#include "orpe/nets/maskrcnn.h"

namespace orpe::nets {

std::int64_t HostTensor::numel() const {
  std::int64_t n = 1;
  for (std::int64_t d : shape) n *= d;
  return n;
}

namespace {

/// The dataset class a class map names: an id of `class_names`, or one of its names.
int dataset_class(const std::string& token, const std::map<int, std::string>& class_names,
                  const std::string& path, const std::string& where) {
  for (const auto& [id, name] : class_names)
    if (name == token) return id;
  long long id = 0;
  std::string why;
  if (parse_integer(token, 1, INT_MAX, &id, &why) && class_names.count(static_cast<int>(id)))
    return static_cast<int>(id);
  throw IoError(path, where + ": '" + token + "' is not a class of the dataset (" +
                          std::to_string(class_names.size()) + " classes)");
}

std::string class_map_path(const SegmentationParams& params) {
  if (!params.maskrcnn_class_map.empty()) return params.maskrcnn_class_map;
  const std::string& m = params.maskrcnn_model;
  const size_t dot = m.find_last_of('.');
  const size_t slash = m.find_last_of('/');
  const bool has_ext = dot != std::string::npos && (slash == std::string::npos || dot > slash);
  return (has_ext ? m.substr(0, dot) : m) + ".classes.txt";
}

}  // namespace

std::map<int, int> read_class_map(const std::string& path, int num_labels,
                                  const std::map<int, std::string>& class_names) {
  std::ifstream in(path);
  if (!in) throw IoError(path, "cannot open the class map");
  std::map<int, int> map;
  std::string line;
  for (int line_no = 1; std::getline(in, line); ++line_no) {
    const size_t hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    std::istringstream fields(line);
    std::string label_text, class_text, extra;
    if (!(fields >> label_text)) continue;
    const std::string where = "line " + std::to_string(line_no);
    if (!(fields >> class_text) || (fields >> extra))
      throw IoError(path, where + ": expected `label class`");
    const int label = parse_int_field(label_text, path, where + ", label", 1, num_labels);
    if (map.count(label))
      throw IoError(path, where + ": label " + std::to_string(label) + " appears twice");
    map[label] = dataset_class(class_text, class_names, path, where);
  }
  if (static_cast<int>(map.size()) != num_labels)
    throw IoError(path, "maps " + std::to_string(map.size()) + " labels, the network has " +
                            std::to_string(num_labels) + " classes besides the background");
  return map;
}

MaskRcnnSegmenter::MaskRcnnSegmenter(const SegmentationParams& params,
                                     const std::map<int, std::string>& class_names)
    : params_(params) {
  MaskRcnnOptions options;
  options.threads = params.maskrcnn_threads;
  options.min_size_px = params.maskrcnn_min_size_px;
  options.max_size_px = params.maskrcnn_max_size_px;
  network_ = std::make_unique<MaskRcnnNetwork>(params.maskrcnn_model, options);
  if (network_->num_classes() < 2)
    throw IoError(
        params.maskrcnn_model,
        "no class count in the model file (export it with scripts/nets/maskrcnn_export.py)");
  class_of_label_ =
      read_class_map(class_map_path(params), network_->num_classes() - 1, class_names);
}

std::vector<Detection> MaskRcnnSegmenter::detect(const RgbdFrame& frame) const {
  const ColorImage& c = frame.color;
  auto size = [](int w, int h) { return std::to_string(w) + "x" + std::to_string(h); };
  if (!frame.depth.empty() &&
      (c.width() != frame.depth.width() || c.height() != frame.depth.height()))
    throw std::invalid_argument("maskrcnn: frame " + frame.name + ": colour image is " +
                                size(c.width(), c.height()) + ", depth image " +
                                size(frame.depth.width(), frame.depth.height()));
  if ((params_.maskrcnn_input_width_px > 0 && c.width() != params_.maskrcnn_input_width_px) ||
      (params_.maskrcnn_input_height_px > 0 && c.height() != params_.maskrcnn_input_height_px))
    throw std::invalid_argument(
        "maskrcnn: frame " + frame.name + " is " + size(c.width(), c.height()) +
        ", segmentation.maskrcnn_input_width_px/height_px ask for " +
        size(params_.maskrcnn_input_width_px, params_.maskrcnn_input_height_px));
  return to_detections(network_->run(c));
}

std::vector<Detection> MaskRcnnSegmenter::to_detections(const MaskRcnnOutput& output) const {
  std::vector<Detection> detections;
  const float threshold = static_cast<float>(params_.mask_threshold);
  for (size_t i = 0; i < output.scores.size(); ++i) {
    if (output.scores[i] < params_.min_score) continue;
    const auto it = class_of_label_.find(output.labels[i]);
    if (it == class_of_label_.end())
      throw std::invalid_argument("maskrcnn: the network gave label " +
                                  std::to_string(output.labels[i]) + ", not in the class map");
    Detection d;
    d.class_id = it->second;
    d.score = output.scores[i];
    d.probability = output.masks[i];
    if (mask_area(d.probability, threshold) < params_.min_mask_area_px) continue;
    d.box = mask_box(d.probability, threshold);
    if (d.box.empty()) {  // no mask pixel: the detector's box
      const auto& b = output.boxes[i];
      d.box = {static_cast<int>(std::floor(b[0])), static_cast<int>(std::floor(b[1])),
               static_cast<int>(std::ceil(b[2])) - 1, static_cast<int>(std::ceil(b[3])) - 1};
    }
    detections.push_back(std::move(d));
  }
  return detections;
}

}  // namespace orpe::nets
