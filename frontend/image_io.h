// Minimal image writers for the map outputs: 8-bit PGM (what ROS's
// map_server reads) and PNG (gray or RGB), written with zlib alone.
#pragma once

#include <cstdint>
#include <iosfwd>
#include <vector>

namespace cairn::frontend {

// Rows top to bottom; `channels` is 1 (gray) or 3 (RGB).
struct Image {
  int width = 0, height = 0, channels = 1;
  std::vector<uint8_t> pixels;
};

void WritePgm(const Image& gray, std::ostream& out);
void WritePng(const Image& image, std::ostream& out);

}  // namespace cairn::frontend
