#include "orpe/core/error.h"
#include "orpe/io/dataset_common.h"

namespace orpe::detail {
bool looks_like_bop(const std::string&) {
  return false;
}
std::unique_ptr<DatasetReader> open_bop(const std::string& path, const DatasetParams&) {
  throw IoError(path, "BOP reader not written yet");
}
}  // namespace orpe::detail
