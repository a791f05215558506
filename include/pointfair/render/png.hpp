#pragma once
// RGB images and a PNG writer (8-bit truecolour, no interlace, filter 0 on every row,
// zlib-compressed IDAT; chunk CRCs computed here).
#include <cstdint>
#include <filesystem>
#include <span>
#include <string_view>
#include <vector>

#include "pointfair/common/colour.hpp"

namespace pointfair::render {

struct Image {
  int width = 0;
  int height = 0;
  /// Row-major, 3 bytes a pixel, top row first.
  std::vector<std::uint8_t> rgb;

  Image() = default;
  Image(int w, int h, Rgb fill);
  Rgb at(int x, int y) const;
  void set(int x, int y, Rgb colour);
};

/// CRC-32 (ISO 3309, as PNG chunks use) of `bytes`, continuing from `crc` (0 to start).
std::uint32_t crc32(std::span<const std::uint8_t> bytes, std::uint32_t crc = 0);

/// The PNG file of `image` in memory.
std::vector<std::uint8_t> encode_png(const Image& image);

/// Writes the PNG atomically. Throws io::IoError "<file>: <problem>".
void write_png(const std::filesystem::path& file, const Image& image);

/// Pastes `src` into `dst` with its top-left corner at (x, y), clipped.
void blit(Image& dst, const Image& src, int x, int y);

/// Draws `text` (ASCII; lower case drawn as upper case) with a 5x7 pixel font scaled by
/// `scale`, top-left corner at (x, y).
void draw_text(Image& image, int x, int y, std::string_view text, Rgb colour, int scale = 2);

/// Width in pixels of `text` drawn by draw_text at `scale` (6 columns a character, less the
/// last one's spacing); 0 for empty text.
int text_width(std::string_view text, int scale = 2);

}  // namespace pointfair::render
