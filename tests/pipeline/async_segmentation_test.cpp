// Asynchronous keyframe segmentation (pipeline.segmentation_delay_frames, segmentation_async;
// docs/PIPELINE.md "Asynchronous segmentation"): the back-end runs on its own thread while tracking
// goes on, and a batch run's outputs depend on the delay only, never on the back-end's timing.
#include <gtest/gtest.h>

#include <fmt/format.h>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <random>
#include <thread>

#include "orpe/io/dataset.h"
#include "orpe/pipeline/config.h"
#include "pipeline/pipeline_test_util.h"

namespace orpe {
namespace {

/// The gt back-end behind a controllable delay: random sleeps (timing noise), or a latch that holds
/// the first call until the test opens it.
class SlowSegmenter final : public Segmenter {
 public:
  struct Latch {
    std::mutex mutex;
    std::condition_variable cv;
    bool open = false;
    std::atomic<bool> first_started{false}, first_finished{false}, timed_out{false};
  };
  SlowSegmenter(const SegmentationParams& p, std::vector<int> classes, int max_sleep_ms,
                std::shared_ptr<Latch> latch = nullptr)
      : gt_(p, std::move(classes)), max_sleep_ms_(max_sleep_ms), latch_(std::move(latch)) {}
  std::string name() const override { return "slow_gt"; }
  std::vector<Detection> detect(const RgbdFrame& frame) const override {
    if (latch_ && !latch_->first_started.exchange(true)) {
      std::unique_lock<std::mutex> lock(latch_->mutex);
      if (!latch_->cv.wait_for(lock, std::chrono::seconds(3), [&] { return latch_->open; }))
        latch_->timed_out = true;
      latch_->first_finished = true;
    }
    if (max_sleep_ms_ > 0) {  // not seeded: the timing differs from run to run
      std::uniform_int_distribution<int> ms(0, max_sleep_ms_);
      std::this_thread::sleep_for(std::chrono::milliseconds(ms(rng_)));
    }
    return gt_.detect(frame);
  }

 private:
  GroundTruthSegmenter gt_;
  int max_sleep_ms_;
  std::shared_ptr<Latch> latch_;
  mutable std::mt19937 rng_{std::random_device{}()};
};

std::string scene() {
  SynthParams p = test::small_scene_params(160, 120, 12, 3, 5);
  p.scene = "table";
  p.span_deg = 24;
  return test::synthetic_scene("async_segmentation", p);
}

OrpeConfig config(int delay, bool async) {
  OrpeConfig c;
  c.pose_registration.num_rotations = 40;
  c.pipeline.segmentation_delay_frames = delay;
  c.pipeline.segmentation_async = async;
  c.pipeline.progress_every_n_frames = 0;
  return c;
}

/// Every output of a run as text (pose rows without their time column, fused poses, instances).
std::string digest(ObjectRpePipeline& pipeline) {
  std::string s;
  auto pose = [](const SE3& T) {
    const Mat4 M = T.matrix();
    std::string out;
    for (int i = 0; i < 12; ++i) out += fmt::format("{:.9g} ", M(i / 4, i % 4));
    return out;
  };
  for (const auto& r : pipeline.pose_rows(0))
    s += fmt::format("row {} {} {:.9g} {}\n", r.im_id, r.obj_id, r.score, pose(r.T_cam_obj));
  for (const auto& r : pipeline.final_pose_rows(0))
    s += fmt::format("final {} {} {}\n", r.im_id, r.obj_id, pose(r.T_cam_obj));
  for (const auto& o : pipeline.object_poses(0))
    s += fmt::format("object {} {} {} {} {}\n", o.instance_id, o.class_id, o.num_views,
                     o.num_rejected, pose(o.T_world_obj));
  for (const auto& [id, inst] : pipeline.semantic()->fusion().instances())
    s += fmt::format("instance {} {} {:.9g}\n", id, inst.argmax_class(), inst.argmax_probability());
  for (int f : pipeline.evaluated_frames()) s += fmt::format("evaluated {}\n", f);
  return s;
}

struct RunOutput {
  std::string digest;
  PipelineStats stats;
};

RunOutput run(int delay, bool async, int max_sleep_ms) {
  const auto reader = open_dataset(scene(), DatasetParams{});
  const OrpeConfig c = config(delay, async);
  ObjectRpePipeline pipeline(ObjectRpeParams::from_config(c), reader->info());
  std::vector<int> classes;
  for (const auto& [id, name] : reader->info().class_names) classes.push_back(id);
  pipeline.set_segmenter(std::make_unique<SlowSegmenter>(c.segmentation, classes, max_sleep_ms));
  for (size_t i = 0; i < reader->size(); ++i) pipeline.process(reader->read(i));
  pipeline.finalize();
  return {digest(pipeline), pipeline.stats()};
}

TEST(AsyncSegmentation, BatchOutputsDependOnTheDelayNotOnTheBackEndsTiming) {
  // The same delay three ways: the back-end on its own thread with random 0-25 ms sleeps (twice),
  // and on the pipeline's thread when the delay is up (the documented order).
  const RunOutput a = run(3, true, 25), b = run(3, true, 25), sync_delayed = run(3, false, 0);
  ASSERT_GT(a.stats.evaluated_frames, 8);
  ASSERT_GT(a.stats.single_view_estimates, 10);
  EXPECT_EQ(a.stats.keyframes, 12);  // every frame, the last three fused at the end of the stream
  EXPECT_EQ(a.digest, b.digest);
  EXPECT_EQ(a.digest, sync_delayed.digest);
  // The delay is a real change of the order (the map has three more frames when a keyframe is
  // fused), so the outputs differ from the undelayed run's.
  const RunOutput undelayed = run(0, true, 0);
  EXPECT_EQ(undelayed.stats.keyframes, 12);
  EXPECT_NE(a.digest, undelayed.digest);
}

TEST(AsyncSegmentation, TrackingGoesOnWhileTheBackEndWorks) {
  // The back-end's first call blocks until the test opens the latch, which it does only after the
  // pipeline has tracked two more frames: possible only when segmentation runs beside tracking.
  // Without the worker thread (segmentation_async=false) the first keyframe is not even being
  // segmented then; without the delay process(frame 0) blocks until the latch times out.
  for (const auto& [delay, async, works] :
       {std::tuple{3, true, true}, std::tuple{3, false, false}, std::tuple{0, true, false}}) {
    SCOPED_TRACE(fmt::format("delay {} async {}", delay, async));
    const auto reader = open_dataset(scene(), DatasetParams{});
    const OrpeConfig c = config(delay, async);
    ObjectRpeParams params = ObjectRpeParams::from_config(c);
    params.variants.clear();  // tracking and semantic mapping only
    ObjectRpePipeline pipeline(params, reader->info());
    std::vector<int> classes;
    for (const auto& [id, name] : reader->info().class_names) classes.push_back(id);
    auto latch = std::make_shared<SlowSegmenter::Latch>();
    pipeline.set_segmenter(std::make_unique<SlowSegmenter>(c.segmentation, classes, 0, latch));
    for (size_t i = 0; i < 3; ++i) pipeline.process(reader->read(i));
    // Frame 0's segmentation has started and waits, while frames 0-2 were tracked.
    const bool concurrent = latch->first_started && !latch->first_finished;
    {
      std::lock_guard<std::mutex> lock(latch->mutex);
      latch->open = true;
    }
    latch->cv.notify_all();
    for (size_t i = 3; i < reader->size(); ++i) pipeline.process(reader->read(i));
    pipeline.finalize();
    EXPECT_EQ(concurrent && !latch->timed_out, works);
    EXPECT_EQ(pipeline.stats().keyframes, 12);
    EXPECT_GT(pipeline.semantic()->fusion().instances().size(), 0u);
  }
}

}  // namespace
}  // namespace orpe
