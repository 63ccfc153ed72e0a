// Helpers for the pipeline tests: small synthetic scenes written once per test process (orpe synth's
// generator, BOP layout), and a single-view estimator double that records its inputs.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <random>
#include <set>
#include <string>
#include <vector>

#include <unistd.h>

#include "orpe/pipeline/object_rpe.h"
#include "orpe/pose/single_view.h"
#include "orpe/synth/generator.h"
#include "support/test_data.h"

namespace orpe::test {

/// Writes (once per process and `key`) a synthetic BOP scene into the process's scratch folder;
/// returns its path.
/// The scene folder is named 000000 (its scene id) so that keyframe lists (`SSSS/NNNNNN`) of
/// `orpe eval poses --keyframes` name it.
inline std::string synthetic_scene(const std::string& key, const SynthParams& params) {
  static std::mutex mutex;
  static std::map<std::string, std::string> made;
  std::lock_guard<std::mutex> lock(mutex);
  if (const auto it = made.find(key); it != made.end()) return it->second;
  const auto dir = std::filesystem::path(process_scratch_dir("pipeline_scene_" + key)) / "000000";
  synth::SyntheticSceneGenerator(params).write_bop(dir.string());
  made[key] = dir.string();
  return dir.string();
}

inline SynthParams small_scene_params(int width, int height, int frames, int objects, int seed) {
  SynthParams p;
  p.seed = seed;
  p.frames = frames;
  p.objects = objects;
  p.width = width;
  p.height = height;
  p.span_deg = 2.0 * frames;  // ~2 degrees per frame: easy tracking
  p.noise = true;
  p.model_points = 800;
  p.preview_stride = 0;
  p.threads = 1;
  return p;
}

/// A single-view "estimator" that records copies of its inputs and answers the frame's ground-truth
/// pose of the object of that class (set by the test before each frame), perturbed by noise that is
/// a deterministic function of the input (so identical inputs give identical answers in any order).
class RecordingEstimator final : public SingleViewPoseEstimator {
 public:
  struct Call {
    int class_id = 0;
    MaskImage mask;
    DepthImage depth;
    ColorImage color;
  };
  struct Shared {
    std::vector<Call> calls;
    std::map<int, SE3> truth_T_cam_obj;  // class -> pose in the current frame
    /// When set: answer T_world_cam()^-1 * truth_T_world_obj[class] instead (poses consistent with
    /// the tracked camera, so that tests of the fusion do not see tracking drift).
    std::function<SE3()> T_world_cam;
    std::map<int, SE3> truth_T_world_obj;
    double translation_noise_m = 0;
    double rotation_noise_rad = 0;
    double mu_m = 0.005;
    bool record_images = true;
  };
  explicit RecordingEstimator(std::shared_ptr<Shared> shared) : shared_(std::move(shared)) {}
  std::string name() const override { return "recording"; }
  SingleViewPose estimate(const SingleViewInput& in) const override {
    Call c;
    c.class_id = in.class_id;
    if (shared_->record_images) {
      c.mask = *in.mask;
      c.depth = *in.depth;
      c.color = *in.color;
    }
    long area = 0;
    double depth_sum = 0;
    for (size_t k = 0; k < in.mask->size(); ++k)
      if ((*in.mask)[k]) {
        ++area;
        depth_sum += (*in.depth)[k];
      }
    shared_->calls.push_back(std::move(c));
    SingleViewPose out;
    SE3 truth;
    if (shared_->T_world_cam) {
      const auto t = shared_->truth_T_world_obj.find(in.class_id);
      if (t == shared_->truth_T_world_obj.end()) {
        out.reason = "no truth for the class";
        return out;
      }
      truth = shared_->T_world_cam().inverse() * t->second;
    } else {
      const auto t = shared_->truth_T_cam_obj.find(in.class_id);
      if (t == shared_->truth_T_cam_obj.end()) {
        out.reason = "no truth for the class";
        return out;
      }
      truth = t->second;
    }
    std::mt19937 rng(static_cast<unsigned>(in.class_id * 7919 + area * 31 +
                                           static_cast<long>(depth_sum * 1000)));
    std::normal_distribution<double> n(0.0, 1.0);
    Vec6 xi;
    for (int i = 0; i < 3; ++i) xi[i] = shared_->translation_noise_m * n(rng);
    for (int i = 3; i < 6; ++i) xi[i] = shared_->rotation_noise_rad * n(rng);
    out.valid = true;
    out.T_cam_obj = truth * SE3::exp(xi);
    out.score = 0.9;
    out.mu_m = shared_->mu_m;
    out.num_points = static_cast<int>(area);
    return out;
  }

 private:
  std::shared_ptr<Shared> shared_;
};

/// Sets the estimator's truth to the frame's ground truth (class -> T_cam_obj).
inline void set_truth(RecordingEstimator::Shared& shared, const RgbdFrame& frame) {
  shared.truth_T_cam_obj.clear();
  for (const auto& g : frame.objects_gt) shared.truth_T_cam_obj[g.class_id] = g.T_cam_obj;
}

/// Processes every frame of `reader` in order; before the first, `truth_T_world_obj` gets the
/// world pose of each of the first frame's objects, by class (what the estimator doubles answer
/// from). `last`, when given, gets the last frame.
inline void process_frames_with_truth(const DatasetReader& reader, ObjectRpePipeline& pipeline,
                                      std::map<int, SE3>& truth_T_world_obj,
                                      RgbdFrame* last = nullptr) {
  RgbdFrame f;
  for (size_t i = 0; i < reader.size(); ++i) {
    f = reader.read(i);
    if (i == 0)
      for (const auto& g : f.objects_gt)
        truth_T_world_obj[g.class_id] = *f.T_world_cam_gt * g.T_cam_obj;
    pipeline.process(f);
  }
  if (last) *last = std::move(f);
}

}  // namespace orpe::test
