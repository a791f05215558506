#include "pointfair/render/png.hpp"

#include <cstring>
#include <string>

#include <gtest/gtest.h>
#include <zlib.h>

namespace pointfair::render {
namespace {

std::uint32_t be32(const std::uint8_t* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | p[3];
}

// A bitwise CRC-32 (no table) as an independent reference.
std::uint32_t reference_crc(const std::uint8_t* p, std::size_t n) {
  std::uint32_t c = 0xffffffffu;
  for (std::size_t i = 0; i < n; ++i) {
    c ^= p[i];
    for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
  }
  return ~c;
}

std::uint32_t reference_adler(const std::vector<std::uint8_t>& data) {
  std::uint32_t a = 1, b = 0;
  for (const std::uint8_t x : data) {
    a = (a + x) % 65521;
    b = (b + a) % 65521;
  }
  return (b << 16) | a;
}

TEST(Png, KnownCrc) {
  const std::string text = "123456789";
  EXPECT_EQ(crc32({reinterpret_cast<const std::uint8_t*>(text.data()), text.size()}), 0xcbf43926u);
}

TEST(Png, ChunksCrcsAndPixelsDecode) {
  Image image(7, 3, {10, 20, 30});
  image.set(6, 2, {255, 0, 128});
  image.set(100, 100, {1, 1, 1});  // outside: ignored
  const std::vector<std::uint8_t> png = encode_png(image);
  const std::uint8_t signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  ASSERT_EQ(std::memcmp(png.data(), signature, 8), 0);
  std::size_t at = 8;
  std::vector<std::uint8_t> idat;
  std::vector<std::string> types;
  while (at + 12 <= png.size()) {
    const std::uint32_t length = be32(&png[at]);
    const std::string type(reinterpret_cast<const char*>(&png[at + 4]), 4);
    types.push_back(type);
    ASSERT_LE(at + 12 + length, png.size());
    EXPECT_EQ(be32(&png[at + 8 + length]), reference_crc(&png[at + 4], length + 4)) << type;
    if (type == "IHDR") {
      EXPECT_EQ(be32(&png[at + 8]), 7u);
      EXPECT_EQ(be32(&png[at + 12]), 3u);
      EXPECT_EQ(png[at + 16], 8);  // bit depth
      EXPECT_EQ(png[at + 17], 2);  // truecolour
    }
    if (type == "IDAT") idat.insert(idat.end(), png.begin() + static_cast<std::ptrdiff_t>(at + 8),
                                    png.begin() + static_cast<std::ptrdiff_t>(at + 8 + length));
    at += 12 + length;
  }
  EXPECT_EQ(at, png.size());
  EXPECT_EQ(types, (std::vector<std::string>{"IHDR", "IDAT", "IEND"}));
  std::vector<std::uint8_t> raw(3 * (1 + 7 * 3));
  uLongf size = static_cast<uLongf>(raw.size());
  ASSERT_EQ(uncompress(raw.data(), &size, idat.data(), static_cast<uLong>(idat.size())), Z_OK);
  ASSERT_EQ(size, raw.size());
  EXPECT_EQ(be32(&idat[idat.size() - 4]), reference_adler(raw));
  EXPECT_EQ(raw[0], 0);  // filter None
  EXPECT_EQ(raw[1], 10);
  const std::size_t last = 2 * 22 + 1 + 6 * 3;
  EXPECT_EQ(raw[last], 255);
  EXPECT_EQ(raw[last + 2], 128);
}

TEST(Png, TextDrawsPixels) {
  Image image(40, 20, {255, 255, 255});
  draw_text(image, 1, 1, "A1", {0, 0, 0}, 1);
  int dark = 0;
  for (int y = 0; y < 20; ++y)
    for (int x = 0; x < 40; ++x) dark += image.at(x, y)[0] == 0;
  EXPECT_GT(dark, 15);
  EXPECT_EQ(image.at(1, 1)[0], 255);  // 'A' has an empty top-left corner
  EXPECT_EQ(image.at(2, 1)[0], 0);
}

}  // namespace
}  // namespace pointfair::render
