#include "orpe/core/camera.h"

#include <cmath>

namespace orpe {

PinholeIntrinsics PinholeIntrinsics::scaled(int level) const {
  PinholeIntrinsics k = *this;
  for (int i = 0; i < level; ++i) {
    k.width /= 2;
    k.height /= 2;
    k.fx *= 0.5;
    k.fy *= 0.5;
    // A 2x2 block average puts the new pixel centre at the mean of the old centres: u' = (u - 0.5) / 2.
    k.cx = (k.cx - 0.5) * 0.5;
    k.cy = (k.cy - 0.5) * 0.5;
  }
  return k;
}

bool PinholeIntrinsics::IsValid(std::string* why) const {
  auto fail = [&](const char* msg) {
    if (why) *why = msg;
    return false;
  };
  if (width <= 0 || height <= 0) return fail("image size must be positive");
  if (!(std::isfinite(fx) && std::isfinite(fy) && fx > 0 && fy > 0))
    return fail("focal lengths fx, fy must be positive and finite");
  if (!(std::isfinite(cx) && std::isfinite(cy))) return fail("principal point must be finite");
  return true;
}

}  // namespace orpe
