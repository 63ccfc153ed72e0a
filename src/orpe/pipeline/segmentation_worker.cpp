#include "orpe/pipeline/segmentation_worker.h"

namespace orpe {

SegmentationWorker::SegmentationWorker() : thread_([this] { loop(); }) {}

SegmentationWorker::~SegmentationWorker() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
    queue_.clear();  // their futures report broken_promise; nobody waits on them any more
  }
  wake_.notify_all();
  thread_.join();
}

std::future<std::vector<Detection>> SegmentationWorker::submit(Job job) {
  std::packaged_task<std::vector<Detection>()> task(std::move(job));
  auto future = task.get_future();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    queue_.push_back(std::move(task));
  }
  wake_.notify_one();
  return future;
}

void SegmentationWorker::loop() {
  while (true) {
    std::packaged_task<std::vector<Detection>()> task;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [this] { return stop_ || !queue_.empty(); });
      if (stop_) return;
      task = std::move(queue_.front());
      queue_.pop_front();
    }
    task();  // exceptions are stored in the future
  }
}

}  // namespace orpe
