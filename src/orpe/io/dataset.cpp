#include "orpe/io/dataset.h"

#include <spdlog/spdlog.h>

#include "orpe/core/error.h"

namespace orpe {

bool DatasetParams::IsValid(std::string* why) const {
  auto fail = [&](const std::string& msg) {
    if (why) *why = msg;
    return false;
  };
  if (format != "auto" && format != "tum" && format != "7scenes" && format != "ycbv" && format != "bop")
    return fail("format must be one of auto, tum, 7scenes, ycbv, bop (got '" + format + "')");
  if (first_frame < 0) return fail("first_frame must be >= 0");
  if (last_frame >= 0 && last_frame < first_frame) return fail("last_frame must be -1 or >= first_frame");
  if (stride < 1) return fail("stride must be >= 1");
  if (depth_units_per_m < 0) return fail("depth_units_per_m must be >= 0 (0 = preset)");
  if (fx < 0 || fy < 0) return fail("fx, fy must be >= 0 (0 = preset)");
  if (max_depth_m < 0) return fail("max_depth_m must be >= 0 (0 = keep all)");
  return true;
}

bool FrameStream::next(RgbdFrame& frame) {
  while (pos_ < reader_.size()) {
    const size_t i = pos_++;
    try {
      frame = reader_.read(i);
      return true;
    } catch (const IoError& e) {
      spdlog::warn("skipping frame {}: {}", i, e.what());
      skipped_.emplace_back(i, e.what());
    }
  }
  return false;
}

}  // namespace orpe
