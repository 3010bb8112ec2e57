#include "cairn/frontend/image_io.h"

#include <zlib.h>

#include <ostream>
#include <stdexcept>
#include <string>

namespace cairn::frontend {

void WritePgm(const Image& gray, std::ostream& out) {
  if (gray.channels != 1) throw std::invalid_argument("PGM needs a gray image");
  out << "P5\n" << gray.width << ' ' << gray.height << "\n255\n";
  out.write(reinterpret_cast<const char*>(gray.pixels.data()),
            static_cast<std::streamsize>(gray.pixels.size()));
}

namespace {

void Put32(std::string* s, uint32_t v) {
  for (int k = 3; k >= 0; --k) s->push_back(static_cast<char>((v >> (8 * k)) & 0xff));
}

// A chunk is length, type, data, and a CRC over type and data.
void Chunk(std::ostream& out, const char* type, const std::string& data) {
  std::string c;
  Put32(&c, static_cast<uint32_t>(data.size()));
  c.append(type, 4);
  c += data;
  const uLong crc = crc32(0L, reinterpret_cast<const Bytef*>(c.data() + 4),
                          static_cast<uInt>(c.size() - 4));
  Put32(&c, static_cast<uint32_t>(crc));
  out.write(c.data(), static_cast<std::streamsize>(c.size()));
}

}  // namespace

void WritePng(const Image& image, std::ostream& out) {
  if (image.channels != 1 && image.channels != 3)
    throw std::invalid_argument("PNG writer takes gray or RGB images");
  static const char kSignature[] = "\x89PNG\r\n\x1a\n";
  out.write(kSignature, 8);
  std::string ihdr;
  Put32(&ihdr, static_cast<uint32_t>(image.width));
  Put32(&ihdr, static_cast<uint32_t>(image.height));
  ihdr.push_back(8);                                   // bit depth
  ihdr.push_back(image.channels == 1 ? 0 : 2);         // gray or truecolour
  ihdr.append(std::string("\0\0\0", 3));               // deflate, adaptive filter, no interlace
  Chunk(out, "IHDR", ihdr);
  // Each row starts with its filter type; 0 (none) keeps this simple.
  const size_t row = static_cast<size_t>(image.width) * image.channels;
  std::string raw;
  raw.reserve((row + 1) * image.height);
  for (int y = 0; y < image.height; ++y) {
    raw.push_back(0);
    raw.append(reinterpret_cast<const char*>(image.pixels.data() + y * row), row);
  }
  uLongf size = compressBound(static_cast<uLong>(raw.size()));
  std::string z(size, '\0');
  if (compress2(reinterpret_cast<Bytef*>(&z[0]), &size, reinterpret_cast<const Bytef*>(raw.data()),
                static_cast<uLong>(raw.size()), 6) != Z_OK)
    throw std::runtime_error("PNG compression failed");
  z.resize(size);
  Chunk(out, "IDAT", z);
  Chunk(out, "IEND", "");
}

}  // namespace cairn::frontend
