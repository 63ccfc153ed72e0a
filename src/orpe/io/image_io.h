// Image files <-> library images. The only place (with the dataset readers) where pixel encodings
// and depth scales are handled: everything past this edge is metres and RGB8.
#pragma once

#include <string>

#include "orpe/core/image.h"

namespace orpe {

/// Reads an 8-bit colour image (PNG/JPG, 3 or 4 channels, or grey) as RGB8. Throws IoError naming
/// the file when it is missing, unreadable, truncated (a JPEG without its end marker, which the
/// decoder would otherwise pad with grey) or not 8-bit.
ColorImage read_color_image(const std::string& path);

/// Statistics of a depth conversion, so callers can report how much of a frame was invalid.
struct DepthReadStats {
  size_t invalid_pixels = 0;  ///< zero, NaN, inf or negative input values (stored as 0)
  size_t nonfinite_or_negative_pixels =
      0;  ///< the NaN, inf or negative ones among them (float input)
};

/// Reads a 16-bit depth PNG: metres = value / depth_units_per_m (e.g. TUM 5000, 7-Scenes 1000,
/// YCB-Video 10000). Float (32-bit, metres) TIFF/EXR-like images are accepted with units ignored.
/// Throws IoError for a missing/corrupt file, an 8-bit image, or depth_units_per_m <= 0.
DepthImage read_depth_image(const std::string& path, double depth_units_per_m,
                            DepthReadStats* stats = nullptr);

/// Reads an 8- or 16-bit single-channel label image (values kept as integers).
LabelImage read_label_image(const std::string& path);

/// Writers: all atomic (temp file + rename), folders created. Depth is written as 16-bit PNG with
/// value = round(metres * depth_units_per_m), saturating at 65535; invalid (0) stays 0.
void write_color_png(const std::string& path, const ColorImage& image);
void write_depth_png(const std::string& path, const DepthImage& depth, double depth_units_per_m);
/// Labels as 16-bit PNG (or 8-bit when `eight_bit` and all values < 256). Negative values -> 0.
void write_label_png(const std::string& path, const LabelImage& labels, bool eight_bit = false);
void write_mask_png(const std::string& path, const MaskImage& mask);  ///< 0 / 255, 8-bit
/// A float image mapped linearly from [lo, hi] to 0..255 grey, for looking at (depth, probability).
void write_gray_png(const std::string& path, const Image<float>& image, float lo, float hi);

}  // namespace orpe
