// Weighted Pearson correlation accumulated pair by pair, of numbers or of vectors (Eigen column
// vectors: the covariance summed over the components over the root of the product of the summed
// variances). Used by the pose stage's colour evidence (grey levels, chromaticity) and by the
// synthetic scenes' appearance symmetries (RGB).
#pragma once

#include <algorithm>
#include <cmath>
#include <type_traits>

namespace orpe {

template <class V>
class WeightedCorrelation {
 public:
  void add(const V& x, const V& y, double w = 1.0) {
    sw_ += w, sx_ += w * x, sy_ += w * y;
    sxx_ += dot(w * x, x), syy_ += dot(w * y, y), sxy_ += dot(w * x, y);
  }
  /// The correlation in [-1, 1] into *r; false (r untouched) when there is no weight or a side's
  /// variance is under min_var_x / min_var_y.
  bool correlation(double* r, double min_var_x = 1e-6, double min_var_y = 1e-6) const {
    if (!(sw_ > 0)) return false;
    const V mx = sx_ / sw_, my = sy_ / sw_;
    const double vx = sxx_ / sw_ - dot(mx, mx), vy = syy_ / sw_ - dot(my, my);
    const double cxy = sxy_ / sw_ - dot(mx, my);
    if (vx < min_var_x || vy < min_var_y) return false;
    *r = std::clamp(cxy / std::sqrt(vx * vy), -1.0, 1.0);
    return true;
  }

 private:
  static V zero() {
    if constexpr (std::is_arithmetic_v<V>)
      return 0;
    else
      return V::Zero();
  }
  static double dot(const V& a, const V& b) {
    if constexpr (std::is_arithmetic_v<V>)
      return a * b;
    else
      return a.dot(b);
  }
  double sw_ = 0, sxx_ = 0, syy_ = 0, sxy_ = 0;
  V sx_ = zero(), sy_ = zero();
};

}  // namespace orpe
