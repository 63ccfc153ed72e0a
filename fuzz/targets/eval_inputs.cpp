// The other inputs of `orpe eval`: the mask index and instance table of `eval masks`
// (eval/mask_run.h) and the keyframe list of `eval poses --keyframes` (eval/pose_metrics.h).
// The same bytes go to all three readers.
#include "orpe/eval/mask_run.h"
#include "orpe/eval/pose_metrics.h"
#include "support/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace orpe::fuzz;
  static const std::string path = scratch_path("eval_input");
  write_file(path, std::string_view(reinterpret_cast<const char*>(data), size));
  expect_clean_refusal([&] { (void)orpe::read_mask_run_index(path); });
  expect_clean_refusal([&] { (void)orpe::read_instance_classes(path); });
  expect_clean_refusal([&] { (void)orpe::read_keyframe_list(path); });
  return 0;
}
