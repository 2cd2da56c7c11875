// PNG (RFC 2083): signature, IHDR, one IDAT holding the zlib stream of filtered rows, IEND; each
// chunk is length, type, data, CRC-32 of type + data.
#include "io/png.h"

#include "io/atomic_file.h"

#include <zlib.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace sph::io {

namespace {

const char kSignature[8] = {'\x89', 'P', 'N', 'G', '\r', '\n', '\x1a', '\n'};

void put32(std::string& out, uint32_t v) {
  for (int s = 24; s >= 0; s -= 8) out += static_cast<char>((v >> s) & 0xFF);
}

uint32_t get32(const std::string& in, std::size_t pos) {
  uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v = (v << 8) | static_cast<uint8_t>(in[pos + static_cast<std::size_t>(i)]);
  return v;
}

void chunk(std::string& out, const char* type, const std::string& data) {
  put32(out, static_cast<uint32_t>(data.size()));
  const std::string body = std::string(type, 4) + data;
  out += body;
  put32(out, static_cast<uint32_t>(crc32(0L, reinterpret_cast<const Bytef*>(body.data()), static_cast<uInt>(body.size()))));
}

}  // namespace

void writePng(const std::string& path, const RgbImage& image) {
  const std::size_t stride = static_cast<std::size_t>(image.width) * 3;
  if (image.width <= 0 || image.height <= 0 || image.rgb.size() != stride * static_cast<std::size_t>(image.height))
    throw std::runtime_error(path + ": cannot write a PNG of " + std::to_string(image.width) + " x " +
                             std::to_string(image.height) + " pixels from " + std::to_string(image.rgb.size()) + " bytes");
  // Rows with filter type 0 (none), then deflate.
  std::string raw;
  raw.reserve((stride + 1) * static_cast<std::size_t>(image.height));
  for (int y = 0; y < image.height; ++y) {
    raw += '\0';
    raw.append(reinterpret_cast<const char*>(image.at(0, y)), stride);
  }
  uLongf packed_size = compressBound(static_cast<uLong>(raw.size()));
  std::string packed(packed_size, '\0');
  if (compress2(reinterpret_cast<Bytef*>(&packed[0]), &packed_size, reinterpret_cast<const Bytef*>(raw.data()),
                static_cast<uLong>(raw.size()), 6) != Z_OK)
    throw std::runtime_error(path + ": zlib cannot compress the image");
  packed.resize(packed_size);

  // IHDR: width, height, bit depth 8, colour type 2 (RGB), deflate, adaptive filters, no interlace.
  std::string ihdr;
  put32(ihdr, static_cast<uint32_t>(image.width));
  put32(ihdr, static_cast<uint32_t>(image.height));
  ihdr += std::string("\x08\x02\x00\x00\x00", 5);
  std::string png(kSignature, 8);
  chunk(png, "IHDR", ihdr);
  chunk(png, "IDAT", packed);
  chunk(png, "IEND", "");
  writeFileAtomic(path, png);
}

RgbImage readPng(const std::string& path) {
  auto fail = [&](const std::string& what) -> RgbImage { throw std::runtime_error(path + ": " + what); };
  std::ifstream in(path, std::ios::binary);
  if (!in) return fail("cannot open the PNG file");
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string blob = ss.str();
  if (blob.size() < 8 || blob.compare(0, 8, std::string(kSignature, 8)) != 0) return fail("not a PNG file");

  // Walk the chunks: IHDR first, IDATs concatenated, IEND last.
  int width = 0, height = 0, depth = 0, colour_type = -1, interlace = 0;
  std::string packed;
  for (std::size_t pos = 8; pos + 12 <= blob.size();) {
    const uint32_t len = get32(blob, pos);
    if (pos + 12 + len > blob.size()) return fail("truncated chunk");
    const std::string type = blob.substr(pos + 4, 4);
    const std::string data = blob.substr(pos + 8, len);
    if (type == "IHDR" && len >= 13) {
      width = static_cast<int>(get32(data, 0));
      height = static_cast<int>(get32(data, 4));
      depth = static_cast<uint8_t>(data[8]);
      colour_type = static_cast<uint8_t>(data[9]);
      interlace = static_cast<uint8_t>(data[12]);
    } else if (type == "IDAT") {
      packed += data;
    } else if (type == "IEND") {
      break;
    }
    pos += 12 + len;
  }
  const int channels = colour_type == 0 ? 1 : colour_type == 2 ? 3 : colour_type == 4 ? 2 : colour_type == 6 ? 4 : 0;
  if (width <= 0 || height <= 0 || depth != 8 || channels == 0 || interlace != 0)
    return fail("only 8-bit grey, grey+alpha, RGB or RGBA non-interlaced PNGs are read");

  // Inflate, then undo the row filters (RFC 2083 section 6).
  const std::size_t stride = static_cast<std::size_t>(width) * static_cast<std::size_t>(channels);
  uLongf raw_size = static_cast<uLongf>((stride + 1) * static_cast<std::size_t>(height));
  std::string raw(raw_size, '\0');
  if (uncompress(reinterpret_cast<Bytef*>(&raw[0]), &raw_size, reinterpret_cast<const Bytef*>(packed.data()),
                 static_cast<uLong>(packed.size())) != Z_OK ||
      raw_size != raw.size())
    return fail("corrupt image data");
  const std::size_t bpp = static_cast<std::size_t>(channels);
  std::vector<uint8_t> prev(stride, 0), row(stride);
  RgbImage img;
  img.width = width;
  img.height = height;
  img.rgb.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * 3);
  for (int y = 0; y < height; ++y) {
    const std::size_t base = static_cast<std::size_t>(y) * (stride + 1);
    const int filter = static_cast<uint8_t>(raw[base]);
    for (std::size_t i = 0; i < stride; ++i) {
      const int x = static_cast<uint8_t>(raw[base + 1 + i]);
      const int a = i >= bpp ? row[i - bpp] : 0, b = prev[i], c = i >= bpp ? prev[i - bpp] : 0;
      int pred = 0;
      switch (filter) {
        case 0: pred = 0; break;
        case 1: pred = a; break;
        case 2: pred = b; break;
        case 3: pred = (a + b) / 2; break;
        case 4: {
          const int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
          pred = (pa <= pb && pa <= pc) ? a : (pb <= pc ? b : c);
          break;
        }
        default: return fail("bad row filter " + std::to_string(filter));
      }
      row[i] = static_cast<uint8_t>((x + pred) & 0xFF);
    }
    // Grey is spread over R, G and B; alpha is dropped.
    for (int px = 0; px < width; ++px) {
      uint8_t* out = &img.rgb[(static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(px)) * 3];
      const uint8_t* in_px = &row[static_cast<std::size_t>(px) * bpp];
      for (int ch = 0; ch < 3; ++ch) out[ch] = channels >= 3 ? in_px[ch] : in_px[0];
    }
    prev = row;
  }
  return img;
}

}  // namespace sph::io
