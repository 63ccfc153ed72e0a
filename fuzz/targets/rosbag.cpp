// ROS 1 bags (io/dataset_rosbag.cpp through rosbag_storage, io/rosbag_messages.cpp): the input is
// the .bag file, opened as a dataset with the default (TUM) topics; every frame pair is read, its
// colour and depth decoded from the messages (orpe's code, not OpenCV's).
#include "orpe/core/error.h"
#include "orpe/io/dataset.h"
#include "support/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace orpe::fuzz;
  static const std::string path = scratch_path("input.bag");
  write_file(path, std::string_view(reinterpret_cast<const char*>(data), size));
  expect_clean_refusal([&] {
    orpe::DatasetParams params;
    params.format = "rosbag";
    const auto reader = orpe::open_dataset(path, params);
    for (size_t i = 0; i < reader->size() && i < 8; ++i) (void)reader->read(i);
  });
  return 0;
}
