// Typed images owned by the library. OpenCV stays behind the I/O edge: these are plain buffers.
//
// Pixel (u, v): u = column (x, right), v = row (y, down), origin at the top-left pixel, whose centre is
// at (0, 0). Storage is row-major: data[v * width + u].
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

namespace orpe {

struct Rgb8 {
  std::uint8_t r = 0, g = 0, b = 0;
  friend bool operator==(const Rgb8&, const Rgb8&) = default;
};

template <class T>
class Image {
 public:
  Image() = default;
  Image(int width, int height, const T& fill = T{})
      : width_(width), height_(height), data_(static_cast<size_t>(width) * height, fill) {}

  int width() const { return width_; }
  int height() const { return height_; }
  bool empty() const { return data_.empty(); }
  size_t size() const { return data_.size(); }
  bool in_bounds(int u, int v) const { return u >= 0 && v >= 0 && u < width_ && v < height_; }

  T& at(int u, int v) { return data_[static_cast<size_t>(v) * width_ + u]; }
  const T& at(int u, int v) const { return data_[static_cast<size_t>(v) * width_ + u]; }
  T& operator[](size_t i) { return data_[i]; }
  const T& operator[](size_t i) const { return data_[i]; }
  T* data() { return data_.data(); }
  const T* data() const { return data_.data(); }
  T* row(int v) { return data_.data() + static_cast<size_t>(v) * width_; }
  const T* row(int v) const { return data_.data() + static_cast<size_t>(v) * width_; }
  void fill(const T& value) { std::fill(data_.begin(), data_.end(), value); }

  auto begin() { return data_.begin(); }
  auto end() { return data_.end(); }
  auto begin() const { return data_.begin(); }
  auto end() const { return data_.end(); }

 private:
  int width_ = 0;
  int height_ = 0;
  std::vector<T> data_;
};

/// Makes `img` w x h: reallocates it, filled with zeros (T::Zero() for Eigen types, else T{}), unless
/// it already has that size, in which case its pixels are left as they are (for scratch images that
/// the caller overwrites every frame).
template <class T>
void ensure_size(Image<T>& img, int w, int h) {
  if (img.width() == w && img.height() == h) return;
  if constexpr (requires { T::Zero(); })
    img = Image<T>(w, h, T::Zero());
  else
    img = Image<T>(w, h, T{});
}

/// Depth along the optical axis (z, not ray length) in metres. 0 marks an invalid pixel; NaN, inf and
/// negative values never appear in a DepthImage (readers map them to 0 and count them).
using DepthImage = Image<float>;
using ColorImage = Image<Rgb8>;
/// Intensity in [0, 1] (used by photometric tracking).
using GrayImage = Image<float>;
/// Per-pixel probability in [0, 1].
using ProbabilityImage = Image<float>;
/// Per-pixel integer labels. Meaning depends on the producer; 0 is background unless stated.
using LabelImage = Image<std::int32_t>;
using MaskImage = Image<std::uint8_t>;  // 0 or 1

}  // namespace orpe
