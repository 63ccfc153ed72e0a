// A DatasetReader over frames held in memory, for tests of code that reads through the interface.
#pragma once

#include <utility>
#include <vector>

#include "orpe/io/dataset.h"

namespace orpe::test {

class InMemoryReader final : public DatasetReader {
 public:
  InMemoryReader(DatasetInfo info, std::vector<RgbdFrame> frames)
      : info_(std::move(info)), frames_(std::move(frames)) {}
  const DatasetInfo& info() const override { return info_; }
  size_t size() const override { return frames_.size(); }
  RgbdFrame read(size_t i) const override { return frames_.at(i); }

 private:
  DatasetInfo info_;
  std::vector<RgbdFrame> frames_;
};

}  // namespace orpe::test
