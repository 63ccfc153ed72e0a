// Procedural textures for the synthetic warehouse: printed package faces (colour bands, text-like
// blocks, logos, barcodes), cardboard, wood, concrete. Deterministic for a given random generator.
#pragma once

#include <cstdint>
#include <random>

#include "orpe/core/image.h"

namespace orpe::synth {

/// Colour scheme and layout choices of one product's print; drawn once per product type.
struct PrintStyle {
  Rgb8 background{235, 230, 220};  ///< board colour under the print (cardboard brown or white)
  Rgb8 primary{200, 30, 40};       ///< brand colour: bands and logo
  Rgb8 secondary{250, 200, 40};    ///< accent colour
  Rgb8 ink{30, 30, 35};            ///< text-like blocks
  bool cardboard = false;          ///< brown corrugated board with sparse print (shipping carton)
  int logo_shape = 0;              ///< 0 circle, 1 diamond, 2 star, 3 rounded square
  std::uint64_t seed = 1;          ///< layout details
};

/// A random but pleasant print style (distinct brand colours, dark or light ink).
PrintStyle random_print_style(std::mt19937_64& rng, bool cardboard);

/// Draws one package face of `width_px` x `height_px` (upright: row 0 is the top edge of the face).
/// `role`: 0 front (big logo, bands, text), 1 back (text columns, barcode), 2 side (narrow label),
/// 3 top/bottom (flaps with tape). `variant` changes the layout details between faces.
ColorImage draw_package_face(int width_px, int height_px, const PrintStyle& style, int role,
                             int variant);

/// Can label, wrapped around the side: bands, logo, text, a nutrition-like table.
ColorImage draw_can_label(int width_px, int height_px, const PrintStyle& style);
/// Can lid or bottom: brushed metal with rims.
ColorImage draw_can_lid(int size_px, std::uint64_t seed);

/// Tileable-ish natural textures.
ColorImage draw_wood(int width_px, int height_px, std::uint64_t seed, Rgb8 base = {196, 160, 112});
ColorImage draw_concrete(int size_px, std::uint64_t seed);
ColorImage draw_painted_wall(int size_px, std::uint64_t seed, Rgb8 base);

}  // namespace orpe::synth
