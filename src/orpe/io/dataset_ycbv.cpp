#include "orpe/core/error.h"
#include "orpe/io/dataset_common.h"

namespace orpe::detail {
bool looks_like_ycbv(const std::string&) {
  return false;
}
std::unique_ptr<DatasetReader> open_ycbv(const std::string& path, const DatasetParams&) {
  throw IoError(path, "YCB-Video reader not written yet");
}
}  // namespace orpe::detail
