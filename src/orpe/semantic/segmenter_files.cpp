// The files back-end: precomputed detections of an external detector (format: docs/SEMANTIC.md).
#include <opencv2/imgcodecs.hpp>

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "orpe/core/atomic_file.h"
#include "orpe/core/error.h"
#include "orpe/core/parse_number.h"
#include "orpe/io/image_io.h"
#include "orpe/semantic/segmenter.h"

namespace orpe {
namespace {

/// Reads an 8-bit (v / 255) or 16-bit (v / 65535) single-channel probability image.
ProbabilityImage read_probability_image(const std::string& path) {
  const cv::Mat raw = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (raw.empty()) throw IoError(path, "cannot read probability image");
  if (raw.channels() != 1) throw IoError(path, "probability image must have one channel");
  double scale;
  if (raw.depth() == CV_8U)
    scale = 1.0 / 255.0;
  else if (raw.depth() == CV_16U)
    scale = 1.0 / 65535.0;
  else
    throw IoError(path, "probability image must be 8- or 16-bit");
  cv::Mat1f p;
  raw.convertTo(p, CV_32F, scale);
  ProbabilityImage out(p.cols, p.rows);
  for (int v = 0; v < p.rows; ++v)
    for (int u = 0; u < p.cols; ++u) out.at(u, v) = p(v, u);
  return out;
}

}  // namespace

std::string detection_json_path(const std::string& dir, int frame_index) {
  return (std::filesystem::path(dir) / fmt::format("{:06d}.json", frame_index)).string();
}

FileSegmenter::FileSegmenter(const SegmentationParams& params) : params_(params) {
  if (!std::filesystem::is_directory(params.files_dir))
    throw IoError(params.files_dir, "detections folder not found (segmentation.files_dir)");
}

std::vector<Detection> FileSegmenter::read(const std::string& dir, int frame_index, int width,
                                           int height) {
  const std::string path = detection_json_path(dir, frame_index);
  std::vector<Detection> out;
  if (!std::filesystem::exists(path)) return out;
  std::ifstream is(path);
  if (!is) throw IoError(path, "cannot open detections file");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(is);
  } catch (const std::exception& e) {
    throw IoError(path, std::string("invalid JSON: ") + e.what());
  }
  try {
    if (!j.is_object() || !j.contains("detections") || !j["detections"].is_array())
      throw IoError(path, "expected an object with a \"detections\" array");
    int n = 0;
    for (const auto& jd : j["detections"]) {
      const std::string where = fmt::format("detection {}: ", n++);
      if (!jd.is_object()) throw IoError(path, where + "not an object");
      Detection det;
      det.class_id = jd.at("class_id").get<int>();
      if (det.class_id <= 0) throw IoError(path, where + "class_id must be > 0");
      det.score = jd.value("score", 1.0f);
      if (!(det.score >= 0 && det.score <= 1))
        throw IoError(path, where + "score must be in [0, 1]");
      const std::string mask_file = jd.value("mask", std::string());
      const std::string prob_file = jd.value("probability", std::string());
      if (mask_file.empty() && prob_file.empty())
        throw IoError(path, where + "needs \"mask\" or \"probability\"");
      if (!prob_file.empty()) {
        det.probability = read_probability_image((std::filesystem::path(dir) / prob_file).string());
      } else {
        const std::string mp = (std::filesystem::path(dir) / mask_file).string();
        const LabelImage mask = read_label_image(mp);
        det.probability = ProbabilityImage(mask.width(), mask.height(), 0.0f);
        for (size_t i = 0; i < mask.size(); ++i) det.probability[i] = mask[i] > 0 ? 1.0f : 0.0f;
      }
      if (det.probability.width() != width || det.probability.height() != height)
        throw IoError(path,
                      where + fmt::format("mask is {}x{}, the frame {}x{}", det.probability.width(),
                                          det.probability.height(), width, height));
      for (float p : det.probability)
        if (!std::isfinite(p)) throw IoError(path, where + "non-finite probability");
      if (jd.contains("box")) {
        const auto b = jd.at("box").get<std::vector<int>>();
        if (b.size() != 4) throw IoError(path, where + "box must be [u_min, v_min, u_max, v_max]");
        det.box = {b[0], b[1], b[2], b[3]};
      }
      if (jd.contains("class_probabilities")) {
        for (const auto& [key, value] : jd.at("class_probabilities").items()) {
          const int c = parse_int_field(key, path, where + "class_probabilities key", 1);
          const float p = value.get<float>();
          if (c <= 0 || !(p >= 0 && p <= 1))
            throw IoError(path, where + "class_probabilities: ids > 0, values in [0, 1]");
          det.class_probabilities.emplace_back(c, p);
        }
      }
      out.push_back(std::move(det));
    }
  } catch (const nlohmann::json::exception& e) {
    throw IoError(path, std::string("malformed detection: ") + e.what());
  } catch (const std::invalid_argument&) {
    throw IoError(path, "class_probabilities keys must be integer class ids");
  }
  return out;
}

std::vector<Detection> FileSegmenter::detect(const RgbdFrame& frame) const {
  const int width = frame.color.empty() ? frame.intrinsics.width : frame.color.width();
  const int height = frame.color.empty() ? frame.intrinsics.height : frame.color.height();
  auto all = read(params_.files_dir, frame.index, width, height);
  const float threshold = static_cast<float>(params_.mask_threshold);
  std::vector<Detection> out;
  for (auto& det : all) {
    const BoxPx box = mask_box(det.probability, threshold);
    if (det.box.empty()) det.box = box;
    if (det.score < params_.min_score) continue;
    if (box.empty() || mask_area(det.probability, threshold) < params_.min_mask_area_px) continue;
    out.push_back(std::move(det));
  }
  return out;
}

void write_detection_files(const std::string& dir, int frame_index,
                           const std::vector<Detection>& detections, float mask_threshold) {
  nlohmann::json j;
  j["frame_index"] = frame_index;
  j["detections"] = nlohmann::json::array();
  for (size_t i = 0; i < detections.size(); ++i) {
    const Detection& det = detections[i];
    const std::string stem = fmt::format("{:06d}_{:02d}", frame_index, i);
    write_mask_png((std::filesystem::path(dir) / (stem + "_mask.png")).string(),
                   binary_mask(det.probability, mask_threshold));
    LabelImage prob16(det.probability.width(), det.probability.height());
    for (size_t k = 0; k < prob16.size(); ++k)
      prob16[k] = static_cast<std::int32_t>(
          std::lround(std::clamp(det.probability[k], 0.0f, 1.0f) * 65535.0));
    write_label_png((std::filesystem::path(dir) / (stem + "_prob.png")).string(), prob16, false);
    nlohmann::json jd;
    jd["class_id"] = det.class_id;
    jd["score"] = det.score;
    jd["box"] = {det.box.u_min, det.box.v_min, det.box.u_max, det.box.v_max};
    jd["mask"] = stem + "_mask.png";
    jd["probability"] = stem + "_prob.png";
    if (!det.class_probabilities.empty()) {
      nlohmann::json cp = nlohmann::json::object();
      for (const auto& [c, p] : det.class_probabilities) cp[std::to_string(c)] = p;
      jd["class_probabilities"] = cp;
    }
    j["detections"].push_back(jd);
  }
  write_file_atomic(detection_json_path(dir, frame_index),
                    [&](std::ostream& os) { os << j.dump(2) << "\n"; });
}

}  // namespace orpe
