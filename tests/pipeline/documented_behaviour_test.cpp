// Pipeline behaviours that docs/PIPELINE.md promises, each tested so that switching it off fails
// (scripts/mutants.sh applies such breakages): the per-object EKF uses the dataset's symmetry group
// (a symmetric object's flipped single-view answers are the same pose), and an instance merge of
// the semantic map hands the absorbed instance's pose track over to the survivor. With the
// recording estimator double (pipeline_test_util.h) on small synthetic scenes.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <memory>
#include <set>

#include "orpe/io/dataset.h"
#include "pipeline/pipeline_test_util.h"

namespace orpe {
namespace {

ObjectRpeParams exact_mask_params() {
  ObjectRpeParams p = ObjectRpeParams::from_config(OrpeConfig{});
  p.segmentation.gt_degrade = false;  // exact ground-truth masks: the test controls every detection
  p.segmentation.gt_min_visible_px = 40;
  p.segmentation.min_mask_area_px = 20;
  p.pipeline.min_pose_mask_px = 40;
  p.variants = {PoseVariant::named("Object-RPE")};
  return p;
}

/// The 12-frame, 3-object synthetic scene most tests here share.
std::unique_ptr<DatasetReader> small_scene_reader() {
  return open_dataset(test::synthetic_scene("flip", test::small_scene_params(160, 120, 12, 3, 5)),
                      DatasetParams{});
}

/// Gives `pipeline` a recording estimator (exact answers, no image copies); returns its state.
std::shared_ptr<test::RecordingEstimator::Shared> attach_recorder(ObjectRpePipeline& pipeline) {
  auto shared = std::make_shared<test::RecordingEstimator::Shared>();
  shared->record_images = false;
  pipeline.set_single_view_estimator(std::make_unique<test::RecordingEstimator>(shared), false);
  return shared;
}

/// Runs the first `frames` frames of `reader` through `pipeline`, the recorder told each one's truth.
void process_frames(ObjectRpePipeline& pipeline, test::RecordingEstimator::Shared& shared,
                    DatasetReader& reader, size_t frames) {
  for (size_t i = 0; i < frames; ++i) {
    const RgbdFrame f = reader.read(i);
    test::set_truth(shared, f);
    pipeline.process(f);
  }
}

/// Estimator double whose answer for every other call of a class is the truth turned by a symmetry
/// of the object (Rz(pi): every `orpe synth` class has it; docs/SYNTH.md).
class FlippingEstimator final : public SingleViewPoseEstimator {
 public:
  explicit FlippingEstimator(std::shared_ptr<test::RecordingEstimator::Shared> shared)
      : inner_(shared), shared_(std::move(shared)) {}
  std::string name() const override { return "flipping"; }
  SingleViewPose estimate(const SingleViewInput& in) const override {
    SingleViewPose out = inner_.estimate(in);
    if (out.valid && (calls_[in.class_id]++ % 2 == 1))
      out.T_cam_obj = out.T_cam_obj * SE3(so3_exp(Vec3(0, 0, M_PI)), Vec3::Zero());
    return out;
  }

 private:
  test::RecordingEstimator inner_;
  std::shared_ptr<test::RecordingEstimator::Shared> shared_;
  mutable std::map<int, int> calls_;
};

struct SymmetryRun {
  int rejected = 0, views = 0, objects = 0;
};

SymmetryRun run_flipping(const std::string& ekf_symmetry) {
  const std::string dir =
      test::synthetic_scene("flip", test::small_scene_params(160, 120, 12, 3, 5));
  const auto reader = open_dataset(dir, DatasetParams{});
  ObjectRpeParams params = exact_mask_params();
  params.pipeline.ekf_symmetry = ekf_symmetry;
  ObjectRpePipeline pipeline(params, reader->info());
  auto shared = std::make_shared<test::RecordingEstimator::Shared>();
  shared->record_images = false;
  shared->translation_noise_m = 0.002;
  shared->rotation_noise_rad = 0.01;
  shared->T_world_cam = [&pipeline] { return pipeline.slam().T_world_cam(); };
  pipeline.set_single_view_estimator(std::make_unique<FlippingEstimator>(shared), false);
  test::process_frames_with_truth(*reader, pipeline, shared->truth_T_world_obj);
  pipeline.finalize();
  SymmetryRun r;
  for (const auto& o : pipeline.object_poses(0)) {
    r.rejected += o.num_rejected;
    r.views += o.num_views;
    ++r.objects;
  }
  return r;
}

TEST(DocumentedBehaviour, EkfTreatsSymmetricFlipsAsTheSamePose) {
  // docs/PIPELINE.md: the EKF fuses with the class's symmetry group (ekf_symmetry = dataset: the
  // annotated group of models_info.json), so answers that differ by a symmetry are consistent.
  const SymmetryRun with = run_flipping("dataset");
  ASSERT_GE(with.objects, 2);
  EXPECT_EQ(with.rejected, 0) << "flipped answers of a symmetric object gated out: " << with.views
                              << " views fused";
  EXPECT_GE(with.views, 8 * with.objects);
  // Control: without a symmetry group the same answers disagree (so the check above can fail).
  const SymmetryRun without = run_flipping("none");
  EXPECT_GT(without.rejected, with.objects * 2) << "views fused " << without.views;
}

/// Frames of a scene where one object's labels are cut: frames < `b_frame` show only its left part
/// (A), frame `b_frame` only the rest (B, a second instance), later frames all of it but A's
/// leftmost third, so that one detection overlaps both instances and B (fully covered) is the
/// survivor.
struct MergeScene {
  std::vector<RgbdFrame> frames;
  int label = 0;  ///< the object's label in labels_gt (objects_gt[label - 1])
  int class_id = 0;
};

MergeScene merge_scene(int frames, int b_frame) {
  const std::string dir =
      test::synthetic_scene("merge", test::small_scene_params(160, 120, frames, 3, 5));
  const auto reader = open_dataset(dir, DatasetParams{});
  MergeScene s;
  for (size_t i = 0; i < reader->size(); ++i) s.frames.push_back(reader->read(i));
  // The object with the most labelled pixels in the first frame.
  std::map<int, int> area;
  for (const auto l : s.frames[0].labels_gt)
    if (l > 0) ++area[l];
  s.label = std::max_element(area.begin(), area.end(), [](auto& a, auto& b) {
              return a.second < b.second;
            })->first;
  s.class_id = s.frames[0].objects_gt[s.label - 1].class_id;
  for (int i = 0; i < static_cast<int>(s.frames.size()); ++i) {
    RgbdFrame& f = s.frames[i];
    int u_min = f.labels_gt.width(), u_max = -1;
    for (int v = 0; v < f.labels_gt.height(); ++v)
      for (int u = 0; u < f.labels_gt.width(); ++u)
        if (f.labels_gt.at(u, v) == s.label) u_min = std::min(u_min, u), u_max = std::max(u_max, u);
    const int split = u_min + (u_max - u_min) * 4 / 10;  // A = the left 40 %
    const int cut =
        u_min + (u_max - u_min) * 15 / 100;  // later frames hide A's left 15 % of the box
    for (int v = 0; v < f.labels_gt.height(); ++v)
      for (int u = 0; u < f.labels_gt.width(); ++u) {
        auto& l = f.labels_gt.at(u, v);
        if (l != s.label) continue;
        if ((i < b_frame && u >= split) || (i == b_frame && u < split) || (i > b_frame && u < cut))
          l = 0;
      }
  }
  return s;
}

TEST(DocumentedBehaviour, AMergedInstancesPoseTrackMovesToTheSurvivor) {
  // docs/PIPELINE.md: when the semantic map merges two instances, the per-instance EKF of the
  // absorbed one moves onto the survivor (the one with more views wins). Here the absorbed instance
  // A has 6 views, the survivor B one: the merged object must keep A's track (its views), not
  // restart.
  const int frames = 12, b_frame = 6;
  MergeScene scene = merge_scene(frames, b_frame);
  const auto reader =
      open_dataset(test::synthetic_scene("merge", test::small_scene_params(160, 120, frames, 3, 5)),
                   DatasetParams{});
  ObjectRpeParams params = exact_mask_params();
  // The split at frame b_frame is a matter of a pixel or two at 160 x 120: with the photometric
  // brightness gain (session 25) the camera is tracked as well (ATE 2.06 mm against 2.12 mm
  // without, 12 frames) but B's segment overlaps A's rendered surfels by more than
  // association_min_overlap and joins A at once, so the scene no longer has two instances to merge.
  // This test is about the merge, not the tracking: it keeps the tracking the scene was made with.
  params.slam.tracker.rgb_estimate_gain = false;
  ObjectRpePipeline pipeline(params, reader->info());
  auto shared = std::make_shared<test::RecordingEstimator::Shared>();
  shared->record_images = false;
  shared->translation_noise_m = 0.002;
  shared->rotation_noise_rad = 0.01;
  shared->T_world_cam = [&pipeline] { return pipeline.slam().T_world_cam(); };
  pipeline.set_single_view_estimator(std::make_unique<test::RecordingEstimator>(shared), false);
  for (const auto& g : scene.frames[0].objects_gt)
    shared->truth_T_world_obj[g.class_id] = *scene.frames[0].T_world_cam_gt * g.T_cam_obj;
  for (const auto& f : scene.frames) pipeline.process(f);

  // The scene really merges: A (first seen in frame 0) into B (first seen in frame b_frame).
  const auto& merged = pipeline.semantic()->fusion().merged_into();
  std::map<int, int> first_frame;  // instance -> first frame with a single-view record of the class
  std::map<int, int> views;        // instance -> valid single-view estimates
  for (const auto& r : pipeline.single_view_records(0)) {
    if (r.class_id != scene.class_id) continue;
    if (!first_frame.count(r.instance_id)) first_frame[r.instance_id] = r.frame_index;
    views[r.instance_id] += r.estimate.valid;
  }
  int a = 0, b = 0;
  for (const auto& [id, frame] : first_frame) {
    if (frame == 0) a = id;
    if (frame == b_frame) b = id;
  }
  ASSERT_GT(a, 0);
  ASSERT_GT(b, 0) << "the cut frame makes a second instance";
  ASSERT_TRUE(merged.count(a)) << "instance " << a << " is merged away";
  ASSERT_EQ(pipeline.semantic()->fusion().resolve_instance(a), b);
  ASSERT_GE(views[a], b_frame - 1);

  pipeline.finalize();
  int found = 0;
  for (const auto& o : pipeline.object_poses(0)) {
    if (o.class_id != scene.class_id) continue;
    ++found;
    EXPECT_EQ(o.instance_id, b);
    // A's views before the merge + the survivor's after it (B's own single view is dropped: the
    // lighter track).
    const int after = views[b] - 1;
    EXPECT_GE(o.num_views, views[a] + after - 1)
        << "the merged object kept " << o.num_views << " views; A had " << views[a]
        << ", B after the merge " << after;
    EXPECT_TRUE(o.valid);
  }
  EXPECT_EQ(found, 1);
}

TEST(DocumentedBehaviour, OnlyKeyframesAreSegmentedAndEveryNthKeyframeEvaluated) {
  // docs/SEMANTIC.md / PIPELINE.md: segmentation.keyframe_every_n_frames picks the frames that are
  // segmented and fused; pipeline.pose_every_n_keyframes the keyframes whose objects get poses.
  const auto reader = small_scene_reader();
  ObjectRpeParams params = exact_mask_params();
  params.segmentation.keyframe_every_n_frames = 3;
  params.pipeline.pose_every_n_keyframes = 2;
  ObjectRpePipeline pipeline(params, reader->info());
  const auto shared = attach_recorder(pipeline);
  std::vector<int> keyframes, evaluated, segmented;
  for (size_t i = 0; i < reader->size(); ++i) {
    const RgbdFrame f = reader->read(i);
    test::set_truth(*shared, f);
    const PipelineFrameResult& r = pipeline.process(f);
    if (r.keyframe) keyframes.push_back(f.index);
    if (r.evaluated) evaluated.push_back(f.index);
    if (!pipeline.semantic()->last_step().detections.empty()) segmented.push_back(f.index);
  }
  EXPECT_EQ(keyframes, (std::vector<int>{0, 3, 6, 9}));
  EXPECT_EQ(segmented, keyframes);
  EXPECT_EQ(evaluated, (std::vector<int>{0, 6}));
  EXPECT_EQ(pipeline.stats().keyframes, 4);
  EXPECT_EQ(pipeline.semantic()->keyframes(), 4);
  std::set<int> pose_frames;
  for (const auto& row : pipeline.pose_rows(0)) pose_frames.insert(row.im_id);
  EXPECT_EQ(pose_frames, (std::set<int>{0, 6}));
}

TEST(DocumentedBehaviour, ARowOfAnInstanceDetectedOnceWeighsLessThanAConfirmedOnes) {
  // docs/PIPELINE.md "Score": a per-frame row's score carries the instance's existence,
  // min(1, detections / semantic.min_confirmed_detections), so that of two rows of one class in one
  // image an instance detected once (a spurious blob) ranks below an established object. Exact
  // masks: class probability 1, the double's score 0.9 on every view.
  const auto reader = small_scene_reader();
  ObjectRpeParams params = exact_mask_params();
  ASSERT_EQ(params.semantic.min_confirmed_detections, 2);
  ObjectRpePipeline pipeline(params, reader->info());
  const auto shared = attach_recorder(pipeline);
  process_frames(pipeline, *shared, *reader, 3);
  std::map<int, std::map<int, double>> score;  // frame -> class -> score
  for (const auto& row : pipeline.pose_rows(0)) score[row.im_id][row.obj_id] = row.score;
  ASSERT_EQ(score[0].size(), 3u);
  for (const auto& [cls, s0] : score[0]) {
    ASSERT_TRUE(score[1].count(cls) && score[2].count(cls)) << cls;
    EXPECT_NEAR(s0, 0.45, 1e-9) << cls;  // detected once: half of 0.9
    EXPECT_NEAR(score[1][cls], 0.9, 1e-9) << cls;
    EXPECT_NEAR(score[2][cls], 0.9, 1e-9) << cls;
  }
}

TEST(DocumentedBehaviour, TheAutoMaskThresholdScalesWithTheImageAreaBelow640x480) {
  // docs/PIPELINE.md: pipeline.min_pose_mask_px = 0 (default) is 200 pixels at 640 x 480 and above,
  // scaled down by the image's area below; an explicit value is a pixel count at any resolution.
  PipelineParams pp;
  ASSERT_EQ(pp.min_pose_mask_px, 0);
  EXPECT_EQ(pp.min_pose_mask_px_for(640, 480), 200);
  EXPECT_EQ(pp.min_pose_mask_px_for(1280, 720), 200);
  EXPECT_EQ(pp.min_pose_mask_px_for(320, 240), 50);
  EXPECT_EQ(pp.min_pose_mask_px_for(160, 120), 13);
  EXPECT_EQ(pp.min_pose_mask_px_for(0, 0), 1);
  pp.min_pose_mask_px = 120;
  EXPECT_EQ(pp.min_pose_mask_px_for(320, 240), 120);
  pp.min_pose_mask_px = -1;
  EXPECT_FALSE(pp.IsValid(nullptr));
  // In the pipeline, on a 160 x 120 scene seen from 2.5 m: two of its objects' masks have 70-120
  // pixels; they are estimated with the auto threshold, and not with 200 pixels.
  SynthParams far = test::small_scene_params(160, 120, 4, 3, 5);
  far.distance_m = 2.5;
  const std::string dir = test::synthetic_scene("far", far);
  auto estimates = [&dir](int min_pose_mask_px) {
    const auto reader = open_dataset(dir, DatasetParams{});
    ObjectRpeParams params = exact_mask_params();
    params.pipeline.min_pose_mask_px = min_pose_mask_px;
    ObjectRpePipeline pipeline(params, reader->info());
    const auto shared = attach_recorder(pipeline);
    process_frames(pipeline, *shared, *reader, 4);
    return pipeline.stats().single_view_estimates;
  };
  const int automatic = estimates(0), fixed = estimates(200);
  test::print_figure("estimates_auto", automatic);
  test::print_figure("estimates_200px", fixed);
  EXPECT_EQ(automatic, 12);  // 3 objects x 4 frames
  EXPECT_EQ(fixed, 4);       // the large one
}

TEST(DocumentedBehaviour, LostFramesAreNeitherSegmentedNorEvaluated) {
  // docs/PIPELINE.md: a frame whose tracking is LOST (here: no depth) has no camera pose to place
  // detections or poses with; it is not segmented, fused or evaluated, and has no pose rows.
  const auto reader = small_scene_reader();
  ObjectRpeParams params = exact_mask_params();
  params.segmentation.keyframe_every_n_frames = 1;  // every tracked frame is a keyframe
  params.pipeline.pose_every_n_keyframes = 1;
  ObjectRpePipeline pipeline(params, reader->info());
  const auto shared = attach_recorder(pipeline);
  const std::set<int> no_depth = {5, 6};
  std::set<int> lost, segmented;
  for (size_t i = 0; i < reader->size(); ++i) {
    RgbdFrame f = reader->read(i);
    if (no_depth.count(f.index))
      for (auto& z : f.depth) z = 0.0f;
    test::set_truth(*shared, f);
    const PipelineFrameResult& r = pipeline.process(f);
    if (r.slam.status == slam::TrackingStatus::kLost) lost.insert(f.index);
    if (r.keyframe || r.evaluated) segmented.insert(f.index);
  }
  EXPECT_EQ(lost, no_depth);
  for (int i : no_depth) EXPECT_FALSE(segmented.count(i)) << "LOST frame " << i << " was segmented";
  EXPECT_EQ(pipeline.semantic()->keyframes(), 10);
  EXPECT_EQ(pipeline.stats().evaluated_frames, 10);
  for (const auto& row : pipeline.pose_rows(0))
    EXPECT_FALSE(no_depth.count(row.im_id)) << "a pose row for LOST frame " << row.im_id;
}

TEST(DocumentedBehaviour, FinalizeDropsTheTrackOfAnInstanceWhoseClassChanged) {
  // docs/PIPELINE.md: after the last frame, the filter of an instance whose final (argmax) class
  // differs from the filter's class is dropped: its pose came from another class's model. Here one
  // object is detected as class A on frames 0-3 and as class B on frames 4-11, and only frame 0 is
  // evaluated, so the only filter is A's while the instance ends as B.
  const auto reader = small_scene_reader();
  ObjectRpeParams params = exact_mask_params();
  params.segmentation.keyframe_every_n_frames = 1;
  params.pipeline.pose_every_n_keyframes = 100;  // frame 0 only
  params.pipeline.ekf_init_views = 1;
  ObjectRpePipeline pipeline(params, reader->info());
  const auto shared = attach_recorder(pipeline);
  const RgbdFrame first = reader->read(0);
  ASSERT_GE(first.objects_gt.size(), 2u);
  const int class_a = first.objects_gt[0].class_id, class_b = first.objects_gt[1].class_id;
  ASSERT_NE(class_a, class_b);
  for (size_t i = 0; i < reader->size(); ++i) {
    RgbdFrame f = reader->read(i);
    if (i >= 4)
      for (auto& g : f.objects_gt)
        if (g.class_id == class_a) g.class_id = class_b;
    test::set_truth(*shared, f);
    pipeline.process(f);
  }
  // Before finalize: a filter of class A sits on an instance whose argmax class is now B.
  const auto& instances = pipeline.semantic()->fusion().instances();
  int relabelled = 0;
  for (const auto& o : pipeline.object_poses(0))
    if (o.class_id == class_a && instances.at(o.instance_id).argmax_class() == class_b)
      relabelled = o.instance_id;
  ASSERT_GT(relabelled, 0) << "the scene must end with a class-A filter on a class-B instance";
  pipeline.finalize();
  for (const auto& o : pipeline.object_poses(0)) {
    const auto inst = instances.find(o.instance_id);
    ASSERT_NE(inst, instances.end());
    EXPECT_EQ(o.class_id, inst->second.argmax_class())
        << "instance " << o.instance_id << " is reported with its filter's class " << o.class_id;
    EXPECT_NE(o.instance_id, relabelled);
  }
}

}  // namespace
}  // namespace orpe
