// An RGB picture in memory and its PNG encoding (zlib's deflate and CRC), for pictures a report
// embeds as a data: URI: no image library, the few chunks a viewer needs.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace cmm::planner {

struct Rgb {
  std::uint8_t r = 0, g = 0, b = 0;
  bool operator==(const Rgb&) const = default;
};

// Row-major, top row first, three bytes a pixel.
struct RgbImage {
  int width = 0, height = 0;
  std::vector<std::uint8_t> pixels;

  RgbImage() = default;
  RgbImage(int width, int height, Rgb fill);
  Rgb at(int x, int y) const;
  void set(int x, int y, Rgb colour);  // outside the picture: ignored (shapes may overhang its border)
};

// The PNG file's bytes: 8-bit truecolour, no interlace, filter 0 on every row. Throws
// std::runtime_error naming zlib's error when compression fails, std::invalid_argument for an
// empty or inconsistent image.
std::string encode_png(const RgbImage& image);

// "data:image/png;base64,…" of encode_png(image), for an <img src> that needs no file beside it.
std::string png_data_uri(const RgbImage& image);

}  // namespace cmm::planner
