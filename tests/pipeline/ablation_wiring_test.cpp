// The ablation switches reach the single-view estimator: DF gets the detection's mask and the
// camera's depth / colour; PM the instance mask rendered from the map; PD / PC the map's depth /
// colour. With a recording estimator double (pipeline_test_util.h) on a small synthetic scene.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <set>

#include "orpe/core/error.h"
#include "orpe/io/dataset.h"
#include "orpe/semantic/detection.h"
#include "orpe/semantic/instance_render.h"
#include "orpe/semantic/semantic_mapper.h"
#include "pipeline/pipeline_test_util.h"

namespace orpe {
namespace {

struct Scene {
  std::unique_ptr<DatasetReader> reader;
  std::vector<RgbdFrame> frames;
};

Scene small_scene() {
  const std::string dir =
      test::synthetic_scene("wiring", test::small_scene_params(160, 120, 5, 4, 2));
  Scene s;
  s.reader = open_dataset(dir, DatasetParams{});
  for (size_t i = 0; i < s.reader->size(); ++i) s.frames.push_back(s.reader->read(i));
  return s;
}

ObjectRpeParams wiring_params(const std::vector<std::string>& variants) {
  ObjectRpeParams p = ObjectRpeParams::from_config(OrpeConfig{});
  // Eroded detections (so detection masks differ from the map's), nothing random beyond that.
  p.segmentation.gt_boundary_shift_min_px = 2;
  p.segmentation.gt_boundary_shift_max_px = 2;
  p.segmentation.gt_boundary_jitter_px = 0;
  p.segmentation.gt_miss_rate = 0;
  p.segmentation.gt_wrong_class_rate = 0;
  p.segmentation.gt_spurious_per_frame = 0;
  p.segmentation.gt_min_visible_px = 40;
  p.segmentation.min_mask_area_px = 20;
  p.pipeline.min_pose_mask_px = 40;
  p.variants.clear();
  for (const auto& v : variants) p.variants.push_back(PoseVariant::named(v));
  return p;
}

bool same_mask(const MaskImage& a, const MaskImage& b) {
  if (a.width() != b.width() || a.height() != b.height()) return false;
  for (size_t k = 0; k < a.size(); ++k)
    if ((a[k] != 0) != (b[k] != 0)) return false;
  return true;
}

/// Fraction of the mask's pixels where two depth images agree exactly.
double depth_agreement(const MaskImage& mask, const DepthImage& a, const DepthImage& b) {
  long n = 0, same = 0;
  for (size_t k = 0; k < mask.size(); ++k)
    if (mask[k]) {
      ++n;
      same += a[k] == b[k];
    }
  return n ? static_cast<double>(same) / n : 0.0;
}
double color_agreement(const MaskImage& mask, const ColorImage& a, const ColorImage& b) {
  long n = 0, same = 0;
  for (size_t k = 0; k < mask.size(); ++k)
    if (mask[k]) {
      ++n;
      same += a[k] == b[k];
    }
  return n ? static_cast<double>(same) / n : 0.0;
}

/// The map as the pipeline renders it for one frame, with an independent renderer: the semantic
/// stage's label-aware instance images, and the render of every surfel around them.
struct MapView {
  LabelImage instance_id;
  DepthImage depth;
  ColorImage color;
};
MapView render_map(const ObjectRpePipeline& pipeline, const RgbdFrame& frame) {
  PinholeIntrinsics K = frame.intrinsics;
  K.width = frame.depth.width();
  K.height = frame.depth.height();
  const SemanticParams& sp = pipeline.params().semantic;
  InstanceRenderer instance_renderer;
  InstanceImages images;
  // The pipeline's windowed render (the window's crop shifts the principal point, which changes
  // float rounding at ~0.02 % of the pixels against a full-image render).
  InstanceRenderOptions ro;
  ro.max_splat_radius_px = static_cast<float>(sp.mask_splat_radius_px);
  ro.splat_radius_scale = static_cast<float>(sp.mask_splat_radius_scale);
  ro.depth_tolerance_m = sp.mask_depth_tolerance_m;
  ro.want_color = true;
  ro.scene_margin_px = pipeline.params().pipeline.render_margin_px;
  instance_renderer.render(pipeline.slam().map(), pipeline.slam().T_world_cam(), K, ro, &images);
  MapView out{images.instance_id, images.scene_depth, images.scene_color};
  for (size_t k = 0; k < out.instance_id.size(); ++k)
    if (out.instance_id[k] > 0) {
      out.depth[k] = images.depth[k];
      out.color[k] = images.color[k];
    }
  return out;
}

struct Checked {
  int calls = 0;
  int mask_is_detection = 0, mask_is_projected = 0;
  double depth_is_camera = 0, depth_is_map = 0, color_is_camera = 0, color_is_map = 0;
  int frames = 0, scene_reused = 0;  // evaluated frames; those reusing the semantic stage's render
};

Checked run_variant(const std::string& name) {
  Scene scene = small_scene();
  ObjectRpePipeline pipeline(wiring_params({name}), scene.reader->info());
  auto shared = std::make_shared<test::RecordingEstimator::Shared>();
  pipeline.set_single_view_estimator(std::make_unique<test::RecordingEstimator>(shared), true);
  Checked c;
  for (const auto& frame : scene.frames) {
    test::set_truth(*shared, frame);
    shared->calls.clear();
    const PipelineFrameResult& r = pipeline.process(frame);
    EXPECT_TRUE(r.evaluated) << "every frame is a keyframe by default";
    const MapView view = render_map(pipeline, frame);
    const auto& detections = pipeline.semantic()->last_step().detections;
    for (const auto& call : shared->calls) {
      ++c.calls;
      for (const auto& d : detections)
        if (same_mask(call.mask, binary_mask(d.probability, 0.5f))) ++c.mask_is_detection;
      std::set<int> ids;
      for (size_t k = 0; k < call.mask.size(); ++k)
        if (call.mask[k]) ids.insert(view.instance_id[k]);
      if (ids.size() == 1 && *ids.begin() > 0) {
        MaskImage projected(call.mask.width(), call.mask.height(), 0);
        for (size_t k = 0; k < projected.size(); ++k)
          projected[k] = view.instance_id[k] == *ids.begin() ? 1 : 0;
        c.mask_is_projected += same_mask(call.mask, projected);
      }
      c.depth_is_camera += depth_agreement(call.mask, call.depth, frame.depth);
      c.depth_is_map += depth_agreement(call.mask, call.depth, view.depth);
      c.color_is_camera += color_agreement(call.mask, call.color, frame.color);
      c.color_is_map += color_agreement(call.mask, call.color, view.color);
    }
  }
  c.frames = static_cast<int>(scene.frames.size());
  c.scene_reused = pipeline.stats().projected_scene_reused;
  if (c.calls > 0) {
    c.depth_is_camera /= c.calls;
    c.depth_is_map /= c.calls;
    c.color_is_camera /= c.calls;
    c.color_is_map /= c.calls;
  }
  return c;
}

TEST(AblationWiring, DfUsesDetectionMaskAndCameraImages) {
  const Checked c = run_variant("DF");
  ASSERT_GT(c.calls, 5);
  EXPECT_EQ(c.mask_is_detection, c.calls);
  EXPECT_LT(c.mask_is_projected, c.calls / 2) << "eroded detections differ from the map's masks";
  EXPECT_DOUBLE_EQ(c.depth_is_camera, 1.0);
  EXPECT_DOUBLE_EQ(c.color_is_camera, 1.0);
  EXPECT_LT(c.depth_is_map, 0.5) << "noisy sensor depth differs from the fused map";
}

TEST(AblationWiring, PmUsesTheMaskRenderedFromTheMap) {
  const Checked c = run_variant("DF-PM");
  ASSERT_GT(c.calls, 5);
  EXPECT_EQ(c.mask_is_projected, c.calls);
  EXPECT_EQ(c.mask_is_detection, 0);
  EXPECT_DOUBLE_EQ(c.depth_is_camera, 1.0);
  EXPECT_DOUBLE_EQ(c.color_is_camera, 1.0);
}

TEST(AblationWiring, PdUsesTheMapsDepth) {
  const Checked c = run_variant("DF-PM-PD");
  ASSERT_GT(c.calls, 5);
  EXPECT_EQ(c.mask_is_projected, c.calls);
  EXPECT_DOUBLE_EQ(c.depth_is_map, 1.0);
  EXPECT_LT(c.depth_is_camera, 0.5);
  EXPECT_DOUBLE_EQ(c.color_is_camera, 1.0);
}

TEST(AblationWiring, PcUsesTheMapsColour) {
  const Checked c = run_variant("DF-PM-PD-PC");
  ASSERT_GT(c.calls, 5);
  EXPECT_EQ(c.mask_is_projected, c.calls);
  EXPECT_DOUBLE_EQ(c.depth_is_map, 1.0);
  EXPECT_DOUBLE_EQ(c.color_is_map, 1.0);
  EXPECT_LT(c.color_is_camera, 0.5)
      << "colour noise makes the camera's colour differ from the map's";
  // The projected images of every frame after the first (whose semantic stage had no labelled
  // surfel to render around) came from the semantic stage's render of the scene; the images are
  // those of the independent render above all the same.
  EXPECT_EQ(c.scene_reused, c.frames - 1);
}

TEST(AblationWiring, NamedConfigurationsSetTheSwitches) {
  PipelineParams p;
  p.apply_ablation("DF");
  EXPECT_FALSE(p.use_projected_mask || p.use_projected_depth || p.use_projected_color || p.use_ekf);
  EXPECT_EQ(p.ablation_name(), "DF");
  p.apply_ablation("DF-PM-PD");
  EXPECT_TRUE(p.use_projected_mask && p.use_projected_depth);
  EXPECT_FALSE(p.use_projected_color || p.use_ekf);
  p.apply_ablation("Object-RPE");
  EXPECT_TRUE(p.use_projected_mask && p.use_projected_depth && p.use_projected_color && p.use_ekf);
  for (const auto& name : PipelineParams::ablation_names()) {
    p.apply_ablation(name);
    EXPECT_EQ(p.ablation_name(), name);
    EXPECT_EQ(PoseVariant::named(name).name, name);
  }
  p.use_projected_mask = false;  // raw mask + EKF: not a named row
  EXPECT_EQ(p.ablation_name(), "custom");
  EXPECT_THROW(p.apply_ablation("DenseFusion"), ConfigError);
  OrpeConfig config;
  apply_config_override(config, "pipeline.use_ekf=false");
  EXPECT_FALSE(config.pipeline.use_ekf);
  apply_config_override(config, "pipeline.pose_every_n_keyframes=0");
  std::string why;
  EXPECT_FALSE(config.IsValid(&why));
  EXPECT_NE(why.find("pipeline"), std::string::npos) << why;
}

TEST(AblationWiring, CombinedPassEqualsSeparateRuns) {
  Scene scene = small_scene();
  auto run = [&](const std::vector<std::string>& names) {
    ObjectRpeParams params = wiring_params(names);
    params.pipeline.ekf_init_views = 1;  // a state from the first measurement on: 5 frames only
    ObjectRpePipeline pipeline(params, scene.reader->info());
    auto shared = std::make_shared<test::RecordingEstimator::Shared>();
    shared->translation_noise_m = 0.01;
    shared->rotation_noise_rad = 0.05;
    shared->record_images = false;
    pipeline.set_single_view_estimator(std::make_unique<test::RecordingEstimator>(shared), false);
    for (const auto& f : scene.frames) {
      test::set_truth(*shared, f);
      pipeline.process(f);
    }
    pipeline.finalize();
    std::map<std::string, std::vector<PoseResultRow>> rows;
    for (size_t v = 0; v < pipeline.num_variants(); ++v)
      rows[pipeline.variant(v).name] = pipeline.pose_rows(v);
    return std::make_pair(rows, pipeline.stats());
  };
  const auto [all, all_stats] = run({"Object-RPE", "DF", "DF-PM", "DF-PM-PD", "DF-PM-PD-PC"});
  EXPECT_GT(all_stats.single_view_cache_hits, 0) << "PC and the EKF reuse DF-PM-PD's estimates";
  for (const std::string name : {"DF", "DF-PM-PD-PC", "Object-RPE"}) {
    const auto [alone, stats] = run({name});
    const auto& a = all.at(name);
    const auto& b = alone.at(name);
    ASSERT_EQ(a.size(), b.size()) << name;
    ASSERT_FALSE(a.empty()) << name;
    for (size_t i = 0; i < a.size(); ++i) {
      EXPECT_EQ(a[i].im_id, b[i].im_id);
      EXPECT_EQ(a[i].obj_id, b[i].obj_id);
      EXPECT_NEAR((a[i].T_cam_obj.translation() - b[i].T_cam_obj.translation()).norm(), 0, 1e-12);
      EXPECT_NEAR(rotation_distance_rad(a[i].T_cam_obj.rotation(), b[i].T_cam_obj.rotation()), 0,
                  1e-9);
    }
  }
  // DF-PM-PD-PC and Object-RPE see the same measurements; the EKF's rows differ from frame 2 on.
  const auto& sv = all.at("DF-PM-PD-PC");
  const auto& ekf = all.at("Object-RPE");
  ASSERT_EQ(sv.size(), ekf.size());
  int differ = 0;
  for (size_t i = 0; i < sv.size(); ++i)
    differ += (sv[i].T_cam_obj.translation() - ekf[i].T_cam_obj.translation()).norm() > 1e-6;
  EXPECT_GT(differ, 0);
}

TEST(AblationWiring, EkfFusesNoisyMeasurementsAndReportsTheStateAfterEachUpdate) {
  // Single-view answers = truth + 1.5 cm / 3 deg noise, truth taken relative to the tracked camera
  // so that tracking drift does not enter (this tests the fusion, not the SLAM).
  const std::string dir =
      test::synthetic_scene("ekf", test::small_scene_params(160, 120, 16, 3, 5));
  const auto reader = open_dataset(dir, DatasetParams{});
  ObjectRpePipeline pipeline(wiring_params({"Object-RPE", "DF-PM-PD-PC"}), reader->info());
  auto shared = std::make_shared<test::RecordingEstimator::Shared>();
  shared->translation_noise_m = 0.015;
  shared->rotation_noise_rad = 0.05;
  shared->record_images = false;
  shared->T_world_cam = [&pipeline] { return pipeline.slam().T_world_cam(); };
  pipeline.set_single_view_estimator(std::make_unique<test::RecordingEstimator>(shared), false);
  std::map<std::pair<int, int>, SE3> truth;  // (frame, class) -> T_cam_obj in the tracked camera
  for (size_t i = 0; i < reader->size(); ++i) {
    const RgbdFrame f = reader->read(i);
    if (i == 0)
      for (const auto& g : f.objects_gt)
        shared->truth_T_world_obj[g.class_id] = *f.T_world_cam_gt * g.T_cam_obj;
    pipeline.process(f);
    for (const auto& [cls, T_world_obj] : shared->truth_T_world_obj)
      truth[{f.index, cls}] = pipeline.slam().T_world_cam().inverse() * T_world_obj;
  }
  pipeline.finalize();
  ASSERT_EQ(pipeline.variant(0).name, "Object-RPE");
  auto mean_error = [&](const std::vector<PoseResultRow>& rows, int from_frame) {
    double sum = 0;
    int n = 0;
    for (const auto& r : rows) {
      if (r.im_id < from_frame) continue;
      sum += (r.T_cam_obj.translation() - truth.at({r.im_id, r.obj_id}).translation()).norm();
      ++n;
    }
    EXPECT_GT(n, 5);
    return n ? sum / n : 1e9;
  };
  if (std::getenv("ORPE_DEBUG_EKF")) {
    for (size_t v = 0; v < 2; ++v)
      for (const auto& r : (v == 0 ? pipeline.final_pose_rows(0) : pipeline.pose_rows(v)))
        std::printf(
            "v%zu frame %d class %d err %.4f\n", v, r.im_id, r.obj_id,
            (r.T_cam_obj.translation() - truth.at({r.im_id, r.obj_id}).translation()).norm());
    for (const auto& o : pipeline.object_poses(0))
      std::printf("inst %d class %d views %d rejected %d reinit %d sym %s\n", o.instance_id,
                  o.class_id, o.num_views, o.num_rejected, o.num_reinitialisations,
                  o.model_symmetry.c_str());
  }
  const double fused = mean_error(pipeline.pose_rows(0), 8);
  const double single = mean_error(pipeline.pose_rows(1), 8);
  EXPECT_LT(fused, 0.6 * single) << "fused " << fused << " m, single view " << single << " m";
  EXPECT_LT(mean_error(pipeline.final_pose_rows(0), 0), 0.6 * single);

  // The last frame's EKF rows are the final state moved into that frame's camera.
  const auto rows = pipeline.pose_rows(0);
  const auto final_rows = pipeline.final_pose_rows(0);
  const int last = rows.back().im_id;
  int compared = 0;
  for (const auto& r : rows) {
    if (r.im_id != last) continue;
    for (const auto& f : final_rows)
      if (f.im_id == last && f.obj_id == r.obj_id) {
        EXPECT_NEAR((f.T_cam_obj.translation() - r.T_cam_obj.translation()).norm(), 0, 1e-9);
        ++compared;
      }
  }
  EXPECT_GT(compared, 0);
  // objects.json content: EKF source, covariance, fused views.
  const auto objects = pipeline.object_poses(0);
  ASSERT_FALSE(objects.empty());
  for (const auto& o : objects) {
    EXPECT_EQ(o.source, "ekf");
    EXPECT_TRUE(o.valid && o.has_covariance);
    EXPECT_GT(o.num_views, 3);
    EXPECT_GT(o.covariance.trace(), 0);
  }
  const auto single_objects = pipeline.object_poses(1);
  for (const auto& o : single_objects) EXPECT_EQ(o.source, "best_single_view");
}

TEST(AblationWiring, SkipRuleSkipsConfidentUnchangedObjectsAndStillReportsThem) {
  // Object-RPE with exact answers: once an object's filter has fused skip_min_fused_views views and
  // the camera barely moves, the estimator is not called for it (at most skip_max_consecutive
  // frames in a row); every frame still reports the object. Switched off, every frame estimates.
  const std::string dir =
      test::synthetic_scene("ekf", test::small_scene_params(160, 120, 16, 3, 5));
  const auto reader = open_dataset(dir, DatasetParams{});
  struct Run {
    int calls = 0, skipped = 0;
    std::set<std::pair<int, int>> rows;  // (frame, class)
  };
  auto run = [&](int min_fused_views, double max_rotation_deg) {
    ObjectRpeParams params = wiring_params({"Object-RPE"});
    params.pipeline.ekf_init_views = 1;
    params.pipeline.skip_min_fused_views = min_fused_views;
    params.pipeline.skip_max_rotation_deg = max_rotation_deg;
    params.pipeline.skip_max_translation_m = 1.0;
    params.pipeline.skip_max_consecutive = 2;
    ObjectRpePipeline pipeline(params, reader->info());
    auto shared = std::make_shared<test::RecordingEstimator::Shared>();
    shared->record_images = false;
    shared->T_world_cam = [&pipeline] { return pipeline.slam().T_world_cam(); };
    pipeline.set_single_view_estimator(std::make_unique<test::RecordingEstimator>(shared), false);
    test::process_frames_with_truth(*reader, pipeline, shared->truth_T_world_obj);
    Run r;
    r.calls = static_cast<int>(shared->calls.size());
    r.skipped = pipeline.stats().single_view_skipped;
    for (const auto& row : pipeline.pose_rows(0)) r.rows.insert({row.im_id, row.obj_id});
    return r;
  };
  const Run skip = run(3, 30.0), off = run(0, 30.0), moving = run(3, 0.0);
  EXPECT_EQ(off.skipped, 0);
  EXPECT_EQ(moving.skipped, 0);  // the camera turns ~2 deg per frame: no view is "unchanged"
  EXPECT_GT(skip.skipped, 5);
  EXPECT_EQ(skip.calls + skip.skipped, off.calls);
  EXPECT_EQ(skip.rows, off.rows);  // skipped objects are reported (their fused pose)
  // At most 2 skips in a row: at least a third of the estimates after the first 3 views remain.
  EXPECT_LE(skip.skipped, 2 * (off.calls - skip.skipped) + 2);
}

/// A single-view double with a prior fast path: given a prior it returns it (from_prior), else it
/// runs a "global search" whose first `wrong_globals` answers per class are the object turned 180
/// degrees (a near-symmetric mode), the later ones the truth.
class PriorModeEstimator final : public SingleViewPoseEstimator {
 public:
  struct Shared {
    std::function<SE3()> T_world_cam;
    std::map<int, SE3> truth_T_world_obj;
    int wrong_globals = 2;
    bool alternate = false;      // instead: every other global search turned (contested modes)
    std::map<int, int> globals;  // per class
    int from_prior = 0;
    int longest_prior_run = 0;
    std::map<int, int> prior_run;  // per class
  };
  explicit PriorModeEstimator(std::shared_ptr<Shared> s) : s_(std::move(s)) {}
  std::string name() const override { return "prior-mode double"; }
  SingleViewPose estimate(const SingleViewInput& in) const override {
    SingleViewPose out;
    out.valid = true;
    out.score = 0.9;
    out.mu_m = 0.005;
    out.num_points = 100;
    int& run = s_->prior_run[in.class_id];
    if (in.T_cam_obj_prior) {
      out.T_cam_obj = *in.T_cam_obj_prior;
      out.from_prior = true;
      ++s_->from_prior;
      s_->longest_prior_run = std::max(s_->longest_prior_run, ++run);
      return out;
    }
    run = 0;
    const SE3 truth = s_->T_world_cam().inverse() * s_->truth_T_world_obj.at(in.class_id);
    const int k = s_->globals[in.class_id]++;
    const bool wrong = s_->alternate ? k % 2 == 1 : k < s_->wrong_globals;
    out.T_cam_obj = wrong ? truth * SE3(so3_exp(Vec3(0, 0, M_PI)), Vec3::Zero()) : truth;
    return out;
  }

 private:
  std::shared_ptr<Shared> s_;
};

/// Object-RPE over a scene with a PriorModeEstimator double: the EKF starts from one view, never
/// skips, never snaps to a symmetry (the turned pose is another mode) and takes the prior;
/// `configure` sets the rest. Returns the pipeline after the last frame (`last` gets that frame).
std::unique_ptr<ObjectRpePipeline> run_with_prior_double(
    const DatasetReader& reader, const std::function<void(ObjectRpeParams&)>& configure,
    const std::shared_ptr<PriorModeEstimator::Shared>& shared, RgbdFrame* last) {
  ObjectRpeParams params = wiring_params({"Object-RPE"});
  params.pipeline.ekf_init_views = 1;
  params.pipeline.skip_min_fused_views = 0;
  params.pipeline.ekf_symmetry = "none";
  params.pipeline.ekf_prior_hypothesis = true;
  configure(params);
  auto pipeline = std::make_unique<ObjectRpePipeline>(params, reader.info());
  ObjectRpePipeline* p = pipeline.get();
  shared->T_world_cam = [p] { return p->slam().T_world_cam(); };
  pipeline->set_single_view_estimator(std::make_unique<PriorModeEstimator>(shared), false);
  test::process_frames_with_truth(reader, *pipeline, shared->truth_T_world_obj, last);
  return pipeline;
}

TEST(AblationWiring, PriorFastPathLeavesAWrongModeBecauseGlobalSearchesRecurAndPriorsDoNotVote) {
  // Object-RPE whose first two global searches per object return the object turned 180 degrees,
  // the later ones the truth. With the rule (pipeline.prior_max_consecutive 2, prior_mode_weight 0)
  // every third estimate is a global search and the prior-refined ones do not vote, so the filter
  // ends in the true mode (with the back-off too: those votes disagree with the turned mode, so
  // the runs of prior estimates do not grow). Without recurring global searches, or with prior
  // estimates voting for the mode they were refined from, it stays turned.
  const std::string dir =
      test::synthetic_scene("prior_modes", test::small_scene_params(160, 120, 16, 3, 5));
  const auto reader = open_dataset(dir, DatasetParams{});
  struct Run {
    int from_prior = 0, longest_prior_run = 0, objects = 0, right_side_at_end = 0;
  };
  auto run = [&](int max_consecutive, double mode_weight) {
    auto shared = std::make_shared<PriorModeEstimator::Shared>();
    RgbdFrame last;
    const auto pipeline = run_with_prior_double(
        *reader,
        [&](ObjectRpeParams& p) {
          p.pipeline.prior_max_consecutive = max_consecutive;
          p.pipeline.prior_mode_weight = mode_weight;
        },
        shared, &last);
    Run r;
    r.from_prior = shared->from_prior;
    r.longest_prior_run = shared->longest_prior_run;
    for (const auto& row : pipeline->pose_rows(0)) {
      if (row.im_id != last.index) continue;
      ++r.objects;
      const SE3 truth =
          pipeline->slam().T_world_cam().inverse() * shared->truth_T_world_obj.at(row.obj_id);
      r.right_side_at_end += (truth.inverse() * row.T_cam_obj).rotation_angle_deg() < 10;
    }
    return r;
  };
  const Run rule = run(2, 0.0), no_recurring_global = run(1000, 0.0), voting = run(2, 1.0);
  EXPECT_GT(rule.from_prior, 10);
  EXPECT_EQ(rule.longest_prior_run, 2);
  ASSERT_GT(rule.objects, 0);
  EXPECT_EQ(rule.right_side_at_end, rule.objects);
  EXPECT_GT(no_recurring_global.longest_prior_run, 2);
  EXPECT_EQ(no_recurring_global.right_side_at_end, 0);
  EXPECT_EQ(voting.right_side_at_end, 0);
}

TEST(AblationWiring, GlobalSearchesThatAgreeWithTheFusedModeComeLessOften) {
  // The back-off (pipeline.prior_max_consecutive_limit): after init, a global search the filter
  // takes into its reported mode doubles the object's run of prior estimates (2, 4, 8); while the
  // global searches contradict each other (every other one turned 180 degrees) the run stays short.
  const std::string dir =
      test::synthetic_scene("prior_backoff", test::small_scene_params(160, 120, 24, 3, 5));
  const auto reader = open_dataset(dir, DatasetParams{});
  struct Run {
    int globals = 0, longest_prior_run = 0;
  };
  auto run = [&](int limit, bool contested) {
    auto shared = std::make_shared<PriorModeEstimator::Shared>();
    shared->wrong_globals = 0;
    shared->alternate = contested;
    RgbdFrame last;
    run_with_prior_double(
        *reader,
        [&](ObjectRpeParams& p) {
          p.pipeline.prior_max_consecutive = 2;
          p.pipeline.prior_max_consecutive_limit = limit;
        },
        shared, &last);
    Run r;
    for (const auto& [c, n] : shared->globals) r.globals += n;
    r.longest_prior_run = shared->longest_prior_run;
    return r;
  };
  const Run backoff = run(8, false), fixed = run(2, false), contested = run(8, true);
  EXPECT_EQ(fixed.longest_prior_run, 2);
  EXPECT_EQ(backoff.longest_prior_run, 8);
  EXPECT_LT(backoff.globals * 3, fixed.globals * 2);  // 24 frames: 5 against 9 per object
  EXPECT_LE(contested.longest_prior_run, 4);
}

TEST(AblationWiring, ProjectedMasksRecoverObjectsTheDetectorMissed) {
  Scene scene = small_scene();
  ObjectRpeParams params = wiring_params({"DF", "DF-PM"});
  params.segmentation.gt_miss_rate = 0.4;
  ObjectRpePipeline pipeline(params, scene.reader->info());
  auto shared = std::make_shared<test::RecordingEstimator::Shared>();
  shared->record_images = false;
  pipeline.set_single_view_estimator(std::make_unique<test::RecordingEstimator>(shared), false);
  for (const auto& f : scene.frames) {
    test::set_truth(*shared, f);
    pipeline.process(f);
  }
  const auto& df = pipeline.pose_rows(0);
  const auto& pm = pipeline.pose_rows(1);
  ASSERT_EQ(pipeline.variant(1).name, "DF-PM");
  std::set<std::pair<int, int>> df_objects, recovered;
  for (const auto& r : df) df_objects.insert({r.im_id, r.obj_id});
  for (const auto& r : pm)
    if (!df_objects.count({r.im_id, r.obj_id})) recovered.insert({r.im_id, r.obj_id});
  EXPECT_FALSE(recovered.empty())
      << "a miss leaves DF without a pose in that frame; the map still shows the object";
  EXPECT_GT(pipeline.stats().detections, 0);
}

}  // namespace
}  // namespace orpe
