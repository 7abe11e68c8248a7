// The PNG writer: signature, chunk layout and CRCs, and an IDAT that inflates back to the pixels
// (zlib's own inflate, the reader every browser's decoder agrees with on this).
#include <gtest/gtest.h>

#include <cstdint>
#include <string>

#include <zlib.h>

#include "planner/png_image.hpp"

namespace cmm::planner {
namespace {

std::uint32_t read_u32(const std::string& bytes, std::size_t at) {
  std::uint32_t v = 0;
  for (std::size_t i = 0; i < 4; ++i) v = (v << 8) | static_cast<std::uint8_t>(bytes.at(at + i));
  return v;
}

struct Chunk {
  std::string type, data;
};

// Splits the file after its signature into chunks, checking each CRC.
std::vector<Chunk> chunks(const std::string& png) {
  std::vector<Chunk> out;
  for (std::size_t at = 8; at < png.size();) {
    const std::uint32_t length = read_u32(png, at);
    Chunk chunk{png.substr(at + 4, 4), png.substr(at + 8, length)};
    const std::string body = png.substr(at + 4, 4 + length);
    EXPECT_EQ(read_u32(png, at + 8 + length),
              crc32(0L, reinterpret_cast<const Bytef*>(body.data()), static_cast<uInt>(body.size())))
        << chunk.type;
    out.push_back(chunk);
    at += 12 + length;
  }
  return out;
}

TEST(PngImage, EncodesChunksThatInflateToThePixels) {
  RgbImage image(7, 3, {255, 255, 255});
  image.set(0, 0, {255, 0, 0});
  image.set(6, 2, {0, 0, 255});
  image.set(-1, 5, {1, 2, 3});  // outside: ignored
  const std::string png = encode_png(image);
  ASSERT_EQ(png.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));

  const std::vector<Chunk> parts = chunks(png);
  ASSERT_EQ(parts.size(), 3u);
  EXPECT_EQ(parts[0].type, "IHDR");
  EXPECT_EQ(read_u32(parts[0].data, 0), 7u);
  EXPECT_EQ(read_u32(parts[0].data, 4), 3u);
  EXPECT_EQ(parts[0].data.substr(8), std::string("\x08\x02\x00\x00\x00", 5));
  EXPECT_EQ(parts[1].type, "IDAT");
  EXPECT_EQ(parts[2].type, "IEND");

  std::string raw(3 * (1 + 7 * 3), '\0');
  uLongf raw_size = raw.size();
  ASSERT_EQ(uncompress(reinterpret_cast<Bytef*>(raw.data()), &raw_size,
                       reinterpret_cast<const Bytef*>(parts[1].data.data()), parts[1].data.size()),
            Z_OK);
  ASSERT_EQ(raw_size, raw.size());
  for (int y = 0; y < 3; ++y) {
    EXPECT_EQ(raw[y * 22], '\0') << "filter of row " << y;
    for (int x = 0; x < 7; ++x) {
      const Rgb pixel = image.at(x, y);
      const std::size_t i = y * 22 + 1 + x * 3;
      EXPECT_EQ(static_cast<std::uint8_t>(raw[i]), pixel.r);
      EXPECT_EQ(static_cast<std::uint8_t>(raw[i + 1]), pixel.g);
      EXPECT_EQ(static_cast<std::uint8_t>(raw[i + 2]), pixel.b);
    }
  }
  EXPECT_EQ(image.at(0, 0), (Rgb{255, 0, 0}));
  EXPECT_EQ(image.at(6, 2), (Rgb{0, 0, 255}));
}

TEST(PngImage, DataUriIsBase64OfTheFile) {
  const std::string uri = png_data_uri(RgbImage(2, 2, {0, 0, 0}));
  ASSERT_EQ(uri.rfind("data:image/png;base64,", 0), 0u);
  EXPECT_EQ(uri.substr(22, 12), "iVBORw0KGgoA");  // base64 of the signature's first 9 bytes
  EXPECT_EQ((uri.size() - 22) % 4, 0u);
}

TEST(PngImage, RefusesBadImages) {
  EXPECT_THROW(RgbImage(0, 5, {}), std::invalid_argument);
  RgbImage image(2, 2, {});
  image.pixels.pop_back();
  EXPECT_THROW(encode_png(image), std::invalid_argument);
  EXPECT_THROW(static_cast<void>(RgbImage(2, 2, {}).at(2, 0)), std::out_of_range);
}

}  // namespace
}  // namespace cmm::planner
