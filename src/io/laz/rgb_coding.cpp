#include "laz/rgb_coding.hpp"

#include <algorithm>

namespace pointfair::io::laz {

namespace {
int clamp8(int v) { return std::clamp(v, 0, 255); }
std::uint32_t fold8(int v) { return static_cast<std::uint8_t>(v); }
}  // namespace

Rgb decode_rgb(ArithmeticDecoder& decoder, RgbModels& models, const Rgb& last) {
  const std::uint32_t sym = decoder.decode_symbol(models.used);
  std::array<int, 3> lo{}, hi{}, last_lo{}, last_hi{};
  for (int c = 0; c < 3; ++c) {
    last_lo[c] = last[c] & 0xff;
    last_hi[c] = last[c] >> 8;
  }
  auto next = [&](int k, int prediction) {
    return static_cast<int>(fold8(static_cast<int>(decoder.decode_symbol(models.diff[k])) + prediction));
  };
  lo[0] = (sym & 1) ? next(0, last_lo[0]) : last_lo[0];
  hi[0] = (sym & 2) ? next(1, last_hi[0]) : last_hi[0];
  if (sym & 64) {
    int diff = lo[0] - last_lo[0];
    lo[1] = (sym & 4) ? next(2, clamp8(diff + last_lo[1])) : last_lo[1];
    if (sym & 16) {
      diff = (diff + (lo[1] - last_lo[1])) / 2;
      lo[2] = next(4, clamp8(diff + last_lo[2]));
    } else {
      lo[2] = last_lo[2];
    }
    diff = hi[0] - last_hi[0];
    hi[1] = (sym & 8) ? next(3, clamp8(diff + last_hi[1])) : last_hi[1];
    if (sym & 32) {
      diff = (diff + (hi[1] - last_hi[1])) / 2;
      hi[2] = next(5, clamp8(diff + last_hi[2]));
    } else {
      hi[2] = last_hi[2];
    }
  } else {
    lo[1] = lo[2] = lo[0];
    hi[1] = hi[2] = hi[0];
  }
  Rgb out{};
  for (int c = 0; c < 3; ++c) out[c] = static_cast<std::uint16_t>(lo[c] | (hi[c] << 8));
  return out;
}

void encode_rgb(ArithmeticEncoder& encoder, RgbModels& models, const Rgb& last, const Rgb& rgb) {
  std::array<int, 3> lo{}, hi{}, last_lo{}, last_hi{};
  for (int c = 0; c < 3; ++c) {
    lo[c] = rgb[c] & 0xff;
    hi[c] = rgb[c] >> 8;
    last_lo[c] = last[c] & 0xff;
    last_hi[c] = last[c] >> 8;
  }
  std::uint32_t sym = 0;
  for (int c = 0; c < 3; ++c) {
    if (lo[c] != last_lo[c]) sym |= 1u << (2 * c);
    if (hi[c] != last_hi[c]) sym |= 2u << (2 * c);
  }
  if (rgb[0] != rgb[1] || rgb[0] != rgb[2]) sym |= 64;
  encoder.encode_symbol(models.used, sym);
  int diff_lo = 0, diff_hi = 0;
  if (sym & 1) {
    diff_lo = lo[0] - last_lo[0];
    encoder.encode_symbol(models.diff[0], fold8(diff_lo));
  }
  if (sym & 2) {
    diff_hi = hi[0] - last_hi[0];
    encoder.encode_symbol(models.diff[1], fold8(diff_hi));
  }
  if (sym & 64) {
    if (sym & 4) encoder.encode_symbol(models.diff[2], fold8(lo[1] - clamp8(diff_lo + last_lo[1])));
    if (sym & 16) {
      diff_lo = (diff_lo + lo[1] - last_lo[1]) / 2;
      encoder.encode_symbol(models.diff[4], fold8(lo[2] - clamp8(diff_lo + last_lo[2])));
    }
    if (sym & 8) encoder.encode_symbol(models.diff[3], fold8(hi[1] - clamp8(diff_hi + last_hi[1])));
    if (sym & 32) {
      diff_hi = (diff_hi + hi[1] - last_hi[1]) / 2;
      encoder.encode_symbol(models.diff[5], fold8(hi[2] - clamp8(diff_hi + last_hi[2])));
    }
  }
}

}  // namespace pointfair::io::laz
