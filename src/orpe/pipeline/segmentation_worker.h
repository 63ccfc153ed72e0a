// One background thread that runs a callable per submitted job, in submission order (the
// pipeline's asynchronous keyframe segmentation, pipeline.segmentation_delay_frames /
// segmentation_async). Results and exceptions come back through std::future; a job that throws
// rethrows at get(). The destructor finishes the job in progress and drops the queued ones.
#pragma once

#include <condition_variable>
#include <deque>
#include <functional>
#include <future>
#include <mutex>
#include <thread>
#include <vector>

#include "orpe/semantic/detection.h"

namespace orpe {

class SegmentationWorker {
 public:
  using Job = std::function<std::vector<Detection>()>;
  SegmentationWorker();
  ~SegmentationWorker();
  SegmentationWorker(const SegmentationWorker&) = delete;
  SegmentationWorker& operator=(const SegmentationWorker&) = delete;

  /// Queues `job`; jobs run one at a time, in the order submitted.
  std::future<std::vector<Detection>> submit(Job job);

 private:
  void loop();
  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::packaged_task<std::vector<Detection>()>> queue_;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace orpe
