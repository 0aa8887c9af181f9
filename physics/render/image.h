// An RGBA image in memory and its PNG encoding (libpng).
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace yamor::render {

/// An 8-bit RGBA image, rows from top to bottom, no padding.
/// Thread-safety: plain value.
struct Image {
  int width = 0;               ///< Pixels per row.
  int height = 0;              ///< Rows.
  std::vector<uint8_t> rgba;   ///< width·height·4 bytes.

  /// The pixel at column `x`, row `y` (0 = top).
  std::array<uint8_t, 4> At(int x, int y) const;
  friend bool operator==(const Image&, const Image&) = default;
};

/// PNG bytes of `image`: 8-bit RGB when every pixel is opaque, else RGBA.
/// `fast` trades size for speed (zlib level 1, no row filters), as
/// video frames want. Deterministic: the same image gives the same bytes.
/// Throws yamor::Error(INVALID_ARGUMENT) for an inconsistent image, INTERNAL
/// when libpng fails.
std::vector<uint8_t> EncodePng(const Image& image, bool fast = false);

/// Decodes PNG bytes of any colour type into RGBA; throws
/// yamor::Error(INVALID_ARGUMENT) with libpng's reason for bytes that are no PNG
/// or an image above 16384 pixels a side.
Image DecodePng(std::span<const uint8_t> png);

}  // namespace yamor::render
