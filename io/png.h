// A minimal PNG encoder and decoder over zlib (RFC 2083): 8-bit RGB images, enough for the
// viewer's screenshots and for tests that look at them. The decoder also takes RGBA and grey, all
// five row filters; it refuses interlaced, palette and 16-bit images.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace sph::io {

struct RgbImage {
  int width = 0;
  int height = 0;
  std::vector<uint8_t> rgb;  ///< (height x width x 3), rows top to bottom
  const uint8_t* at(int x, int y) const { return &rgb[(static_cast<std::size_t>(y) * width + x) * 3]; }
};

/// Writes `image` as a PNG (atomically: temporary file, then rename). Throws std::runtime_error.
void writePng(const std::string& path, const RgbImage& image);

/// Reads a PNG written by writePng (or any 8-bit grey / RGB / RGBA non-interlaced PNG) as RGB.
/// Throws std::runtime_error naming the file when it is missing or not such a PNG.
RgbImage readPng(const std::string& path);

}  // namespace sph::io
