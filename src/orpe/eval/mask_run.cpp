#include "orpe/eval/mask_run.h"
#include "orpe/core/parse_number.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <ostream>
#include <stdexcept>

#include "orpe/core/atomic_file.h"
#include "orpe/core/error.h"
#include "orpe/io/dataset.h"
#include "orpe/io/image_io.h"

namespace orpe {
namespace {

constexpr const char* kFormatTag = "orpe-masks-1";

nlohmann::json image_json(const MaskRunImage& image) {
  nlohmann::json classes = nlohmann::json::object();
  for (const auto& [label, cls] : image.classes) classes[std::to_string(label)] = cls;
  return {{"file", image.file}, {"classes", classes}};
}

nlohmann::json read_json_file(const std::string& path, const char* what) {
  if (!std::filesystem::is_regular_file(path))
    throw IoError(path, fmt::format("{} does not exist or is not a file", what));
  std::ifstream is(path);
  if (!is) throw IoError(path, "cannot open");
  try {
    return nlohmann::json::parse(is);
  } catch (const nlohmann::json::exception& e) {
    throw IoError(path, fmt::format("not valid JSON: {}", e.what()));
  }
}

MaskRunImage image_from_json(const nlohmann::json& j) {
  MaskRunImage image;
  image.file = j.at("file").get<std::string>();
  if (image.file.empty()) throw std::invalid_argument("empty file name");
  for (const auto& [key, value] : j.at("classes").items()) {
    long long label = 0;
    if (!parse_integer(key, 1, 65535, &label, nullptr))
      throw std::invalid_argument(
          fmt::format("label value '{}' is not an integer in 1..65535", key));
    image.classes[static_cast<int>(label)] = value.get<int>();
  }
  return image;
}

/// The labels of `path`, checked against the expected size and the classes listed for them.
LabelImage read_checked_labels(const std::string& path, int width, int height,
                               const LabelClasses& classes, const std::string& index_path) {
  if (!std::filesystem::is_regular_file(path))
    throw IoError(path, "mask image does not exist (listed in " + index_path + ")");
  LabelImage labels = read_label_image(path);
  if (labels.width() != width || labels.height() != height)
    throw IoError(path, fmt::format("mask image is {}x{} but the frame's ground truth is {}x{}",
                                    labels.width(), labels.height(), width, height));
  std::vector<char> seen(65536, 0);  // PNG labels are at most 16-bit
  for (const auto v : labels) {
    if (v <= 0 || v > 65535 || seen[v]) continue;
    seen[v] = 1;
    if (!classes.count(v))
      throw IoError(path, fmt::format("label value {} has no class in {}", v, index_path));
  }
  return labels;
}

nlohmann::json checks_json(const MaskInstanceChecks& c) {
  nlohmann::json objects = nlohmann::json::array();
  for (const auto& o : c.objects)
    objects.push_back({{"object_instance_id", o.object_instance_id},
                       {"class_id", o.class_id},
                       {"instances", o.instances},
                       {"argmax_class", o.argmax_class}});
  return {{"objects", objects},
          {"spurious_instances", c.spurious_instances},
          {"unseen_instances", c.unseen_instances},
          {"objects_with_exactly_one_instance", c.objects_with_exactly_one_instance},
          {"objects_with_correct_class", c.objects_with_correct_class}};
}

}  // namespace

std::string mask_run_index_json(const MaskRunIndex& index) {
  nlohmann::json j;
  j["format"] = kFormatTag;
  j["dataset"] = {{"path", index.dataset_path},
                  {"format", index.dataset_format},
                  {"scene", index.dataset_scene}};
  j["mask_threshold"] = index.mask_threshold;
  j["frames"] = nlohmann::json::array();
  for (const auto& f : index.frames)
    j["frames"].push_back({{"frame", f.frame_index},
                           {"name", f.name},
                           {"input", image_json(f.input)},
                           {"projected", image_json(f.projected)}});
  return j.dump(1);
}

void write_mask_run_index(const std::string& path, const MaskRunIndex& index) {
  const std::string text = mask_run_index_json(index);
  write_file_atomic(path, [&](std::ostream& os) { os << text << "\n"; });
}

MaskRunIndex read_mask_run_index(const std::string& path) {
  const nlohmann::json j = read_json_file(path, "mask index");
  MaskRunIndex index;
  try {
    if (!j.is_object() || j.value("format", std::string()) != kFormatTag)
      throw std::invalid_argument(
          fmt::format("not a mask index (expected \"format\": \"{}\")", kFormatTag));
    const auto& d = j.at("dataset");
    index.dataset_path = d.at("path").get<std::string>();
    index.dataset_format = d.at("format").get<std::string>();
    index.dataset_scene = d.at("scene").get<std::string>();
    index.mask_threshold = j.at("mask_threshold").get<double>();
    for (const auto& f : j.at("frames")) {
      MaskRunFrame frame;
      frame.frame_index = f.at("frame").get<int>();
      frame.name = f.value("name", std::string());
      frame.input = image_from_json(f.at("input"));
      frame.projected = image_from_json(f.at("projected"));
      index.frames.push_back(std::move(frame));
    }
  } catch (const nlohmann::json::exception& e) {
    throw IoError(path, fmt::format("malformed mask index: {}", e.what()));
  } catch (const std::invalid_argument& e) {
    throw IoError(path, fmt::format("malformed mask index: {}", e.what()));
  } catch (const std::out_of_range& e) {
    throw IoError(path, fmt::format("malformed mask index: {}", e.what()));
  }
  return index;
}

std::map<int, int> read_instance_classes(const std::string& path) {
  const nlohmann::json j = read_json_file(path, "instance table");
  std::map<int, int> out;
  try {
    for (const auto& inst : j.at("instances"))
      out[inst.at("id").get<int>()] = inst.at("class_id").get<int>();
  } catch (const nlohmann::json::exception& e) {
    throw IoError(path, fmt::format("malformed instance table: {}", e.what()));
  }
  return out;
}

void MaskInstanceOwnership::add_frame(const LabelImage& gt_labels,
                                      const std::map<std::int32_t, int>& gt_objects,
                                      const LabelClasses& gt_classes, const LabelImage& projected) {
  if (gt_labels.width() != projected.width() || gt_labels.height() != projected.height())
    throw std::invalid_argument("instance ownership: image sizes differ");
  for (const auto& [label, object] : gt_objects) {
    const auto it = gt_classes.find(label);
    if (it != gt_classes.end()) object_class_[object] = it->second;
  }
  for (size_t i = 0; i < projected.size(); ++i) {
    const int id = projected[i];
    if (id <= 0) continue;
    int object = 0;
    if (gt_labels[i] > 0)
      if (const auto it = gt_objects.find(gt_labels[i]); it != gt_objects.end())
        object = it->second;
    ++instance_overlap_[id][object];
  }
}

MaskInstanceChecks MaskInstanceOwnership::result(
    const std::map<int, int>& final_instance_classes) const {
  MaskInstanceChecks r;
  std::map<int, std::vector<std::pair<long, int>>> owned;  // object -> (pixels, instance)
  for (const auto& [id, cls] : final_instance_classes) {
    const auto it = instance_overlap_.find(id);
    if (it == instance_overlap_.end()) {
      r.unseen_instances.push_back(id);
      continue;
    }
    int owner = 0;
    long best = -1;
    for (const auto& [object, px] : it->second)  // ascending object id: ties go to the lower id
      if (px > best) {
        best = px;
        owner = object;
      }
    if (owner == 0)
      r.spurious_instances.push_back(id);
    else
      owned[owner].push_back({best, id});
  }
  for (const auto& [object, cls] : object_class_) {
    MaskObjectRow row;
    row.object_instance_id = object;
    row.class_id = cls;
    if (auto it = owned.find(object); it != owned.end()) {
      auto list = it->second;
      std::sort(list.begin(), list.end(), [](const auto& a, const auto& b) {
        return a.first != b.first ? a.first > b.first : a.second < b.second;
      });
      for (const auto& [px, id] : list) row.instances.push_back(id);
      row.argmax_class = final_instance_classes.at(row.instances.front());
    }
    if (row.instances.size() == 1) {
      ++r.objects_with_exactly_one_instance;
      r.objects_with_correct_class += row.argmax_class == row.class_id;
    }
    r.objects.push_back(row);
  }
  return r;
}

MaskRunEvaluator::MaskRunEvaluator(const MaskMetricsParams& params)
    : params_(params), input_(params), projected_(params) {}

void MaskRunEvaluator::add_run(const DatasetReader& reader, const std::string& masks_dir,
                               const MaskRunIndex& index,
                               const std::map<int, int>* final_instance_classes,
                               const std::string& name) {
  namespace fs = std::filesystem;
  const std::string index_path = (fs::path(masks_dir) / "index.json").string();
  if (index.frames.empty()) throw IoError(index_path, "the mask index lists no frame");
  // Frame number -> position in the reader (annotations only: no image decoding).
  std::map<int, size_t> position_of;
  for (size_t i = 0; i < reader.size(); ++i) position_of[reader.read_annotations(i).index] = i;

  // Scored into copies first, so that a bad file leaves the evaluator as it was.
  MaskEvaluator input = input_, projected = projected_;
  MaskInstanceOwnership ownership;
  for (const MaskRunFrame& f : index.frames) {
    const auto pos = position_of.find(f.frame_index);
    if (pos == position_of.end())
      throw IoError(index_path, fmt::format("frame {} ({}) is not in the dataset {}", f.frame_index,
                                            f.name, reader.info().root));
    const RgbdFrame frame = reader.read(pos->second);
    if (frame.labels_gt.empty())
      throw IoError(frame.name, "the dataset has no ground-truth labels for this frame");
    LabelClasses gt_classes;
    std::map<std::int32_t, int> gt_objects;
    for (size_t k = 0; k < frame.objects_gt.size(); ++k) {
      gt_classes[static_cast<std::int32_t>(k) + 1] = frame.objects_gt[k].class_id;
      gt_objects[static_cast<std::int32_t>(k) + 1] = frame.objects_gt[k].instance_id;
    }
    for (const auto v : frame.labels_gt)
      if (v > 0 && !gt_classes.count(v))
        throw IoError(frame.name,
                      fmt::format("ground-truth label {} names no annotated object", v));
    const int W = frame.labels_gt.width(), H = frame.labels_gt.height();
    const LabelImage input_labels = read_checked_labels(
        (fs::path(masks_dir) / f.input.file).string(), W, H, f.input.classes, index_path);
    const LabelImage projected_labels = read_checked_labels(
        (fs::path(masks_dir) / f.projected.file).string(), W, H, f.projected.classes, index_path);
    input.add_frame(frame.labels_gt, gt_classes, input_labels, f.input.classes);
    projected.add_frame(frame.labels_gt, gt_classes, projected_labels, f.projected.classes);
    ownership.add_frame(frame.labels_gt, gt_objects, gt_classes, projected_labels);
  }
  input_ = std::move(input);
  projected_ = std::move(projected);
  for (const auto& [id, n] : reader.info().class_names) class_names_[id] = n;
  if (final_instance_classes) checks_.emplace_back(name, ownership.result(*final_instance_classes));
}

MaskRunEvaluation MaskRunEvaluator::result() const {
  MaskRunEvaluation ev;
  ev.params = params_;
  ev.input = input_.summary(class_names_);
  ev.projected = projected_.summary(class_names_);
  ev.instances = checks_;
  return ev;
}

MaskRunEvaluation evaluate_mask_run(const DatasetReader& reader, const std::string& masks_dir,
                                    const MaskRunIndex& index, const MaskMetricsParams& params,
                                    const std::map<int, int>* final_instance_classes) {
  MaskRunEvaluator evaluator(params);
  evaluator.add_run(reader, masks_dir, index, final_instance_classes);
  return evaluator.result();
}

int MaskRunEvaluation::objects() const {
  int n = 0;
  for (const auto& [name, c] : instances) n += static_cast<int>(c.objects.size());
  return n;
}
int MaskRunEvaluation::objects_with_exactly_one_instance() const {
  int n = 0;
  for (const auto& [name, c] : instances) n += c.objects_with_exactly_one_instance;
  return n;
}
int MaskRunEvaluation::objects_with_correct_class() const {
  int n = 0;
  for (const auto& [name, c] : instances) n += c.objects_with_correct_class;
  return n;
}
int MaskRunEvaluation::spurious_instances() const {
  int n = 0;
  for (const auto& [name, c] : instances) n += static_cast<int>(c.spurious_instances.size());
  return n;
}

std::string MaskRunEvaluation::report() const {
  std::string s = fmt::format(
      "mask IoU over {} frames ({} matching{}; misses count 0 / matched only):\n", input.frames,
      params.class_agnostic_matching ? "class-agnostic" : "same-class",
      params.min_gt_area_px > 0 ? fmt::format(", objects < {} px not scored", params.min_gt_area_px)
                                : std::string());
  s += fmt::format("{:<28} {:>7} | {:>7} {:>7} {:>7} | {:>7} {:>7} {:>7}\n", "class", "objects",
                   "input", "matched", "missed", "proj.", "matched", "missed");
  auto line = [](const MaskClassSummary& a, const MaskClassSummary& b) {
    return fmt::format("{:<28} {:>7} | {:>7.3f} {:>7.3f} {:>7} | {:>7.3f} {:>7.3f} {:>7}\n", a.name,
                       a.gt_instances, a.mean_instance_iou, a.mean_matched_iou,
                       a.gt_instances - a.matched, b.mean_instance_iou, b.mean_matched_iou,
                       b.gt_instances - b.matched);
  };
  // The two evaluations score the same ground truth, so their class lists hold the same classes
  // with ground-truth instances (a class only predicted has no instances).
  std::map<int, const MaskClassSummary*> proj_by_class;
  for (const auto& c : projected.classes) proj_by_class[c.class_id] = &c;
  for (const auto& c : input.classes) {
    if (c.gt_instances == 0) continue;
    const auto it = proj_by_class.find(c.class_id);
    if (it != proj_by_class.end()) s += line(c, *it->second);
  }
  s += line(input.all, projected.all);
  s += fmt::format(
      "false-positive instance masks: input {}, projected {}; pixel mIoU (mean over classes): "
      "input {:.3f}, projected {:.3f}\n",
      input.false_positive_instances, projected.false_positive_instances,
      input.mean_class_pixel_iou, projected.mean_class_pixel_iou);
  if (!instances.empty()) {
    size_t unseen = 0;
    for (const auto& [name, c] : instances) unseen += c.unseen_instances.size();
    s += fmt::format(
        "instances: {} of {} objects have exactly one instance, {} with the right class; {} "
        "spurious, {} never projected\n",
        objects_with_exactly_one_instance(), objects(), objects_with_correct_class(),
        spurious_instances(), unseen);
    for (const auto& [name, c] : instances) {
      const std::string run = name.empty() ? std::string() : name + ": ";
      for (const auto& o : c.objects)
        if (o.instances.size() != 1 || o.argmax_class != o.class_id)
          s += fmt::format("  {}object {} (class {}): instances [{}], argmax class {}\n", run,
                           o.object_instance_id, o.class_id, fmt::join(o.instances, ", "),
                           o.argmax_class);
      if (!c.spurious_instances.empty())
        s += fmt::format("  {}spurious: [{}]\n", run, fmt::join(c.spurious_instances, ", "));
    }
  }
  return s;
}

std::string MaskRunEvaluation::to_json() const {
  nlohmann::json j;
  j["params"] = {{"min_match_iou", params.min_match_iou},
                 {"class_agnostic_matching", params.class_agnostic_matching},
                 {"min_gt_area_px", params.min_gt_area_px}};
  j["input"] = nlohmann::json::parse(input.to_json());
  j["projected"] = nlohmann::json::parse(projected.to_json());
  j["runs"] = nlohmann::json::array();
  for (const auto& [name, c] : instances) {
    nlohmann::json r = checks_json(c);
    r["run"] = name;
    j["runs"].push_back(r);
  }
  if (instances.empty())
    j["instances"] = nullptr;
  else
    j["instances"] = {{"objects", objects()},
                      {"objects_with_exactly_one_instance", objects_with_exactly_one_instance()},
                      {"objects_with_correct_class", objects_with_correct_class()},
                      {"spurious_instances", spurious_instances()}};
  return j.dump(2);
}

}  // namespace orpe
