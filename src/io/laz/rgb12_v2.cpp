// RGB12 item, version 2: which of the six colour bytes changed (a 7-bit symbol, bit 6: the
// colour is not grey), then each changed byte coded against a prediction: red from the
// previous red, green and blue from the previous value moved by red's change (blue by the
// mean of red's and green's).
#include <algorithm>
#include <array>

#include "laz/item_codec.hpp"

namespace pointfair::io::laz {

namespace {

std::uint16_t load16(const std::uint8_t* p) { return static_cast<std::uint16_t>(p[0] | (p[1] << 8)); }
void store16(std::uint16_t v, std::uint8_t* p) {
  p[0] = static_cast<std::uint8_t>(v);
  p[1] = static_cast<std::uint8_t>(v >> 8);
}
int clamp8(int v) { return std::clamp(v, 0, 255); }
std::uint32_t fold8(int v) { return static_cast<std::uint8_t>(v); }

class Rgb12V2 final : public ItemCodec {
 public:
  Rgb12V2() : used_(128), diff_{SymbolModel(256), SymbolModel(256), SymbolModel(256), SymbolModel(256), SymbolModel(256), SymbolModel(256)} {}

  void start(const std::uint8_t* item) override {
    used_.reset();
    for (SymbolModel& m : diff_) m.reset();
    for (int c = 0; c < 3; ++c) last_[c] = load16(item + 2 * c);
  }

  void decode(ArithmeticDecoder& decoder, std::uint8_t* item) override {
    const std::uint32_t sym = decoder.decode_symbol(used_);
    std::array<int, 3> lo{}, hi{};
    auto last_lo = [&](int c) { return last_[c] & 0xff; };
    auto last_hi = [&](int c) { return last_[c] >> 8; };
    lo[0] = (sym & 1) ? static_cast<int>(fold8(static_cast<int>(decoder.decode_symbol(diff_[0])) + last_lo(0))) : last_lo(0);
    hi[0] = (sym & 2) ? static_cast<int>(fold8(static_cast<int>(decoder.decode_symbol(diff_[1])) + last_hi(0))) : last_hi(0);
    if (sym & 64) {
      int diff = lo[0] - last_lo(0);
      lo[1] = (sym & 4) ? static_cast<int>(fold8(static_cast<int>(decoder.decode_symbol(diff_[2])) + clamp8(diff + last_lo(1)))) : last_lo(1);
      if (sym & 16) {
        diff = (diff + (lo[1] - last_lo(1))) / 2;
        lo[2] = static_cast<int>(fold8(static_cast<int>(decoder.decode_symbol(diff_[4])) + clamp8(diff + last_lo(2))));
      } else {
        lo[2] = last_lo(2);
      }
      diff = hi[0] - last_hi(0);
      hi[1] = (sym & 8) ? static_cast<int>(fold8(static_cast<int>(decoder.decode_symbol(diff_[3])) + clamp8(diff + last_hi(1)))) : last_hi(1);
      if (sym & 32) {
        diff = (diff + (hi[1] - last_hi(1))) / 2;
        hi[2] = static_cast<int>(fold8(static_cast<int>(decoder.decode_symbol(diff_[5])) + clamp8(diff + last_hi(2))));
      } else {
        hi[2] = last_hi(2);
      }
    } else {
      lo[1] = lo[2] = lo[0];
      hi[1] = hi[2] = hi[0];
    }
    for (int c = 0; c < 3; ++c) {
      last_[c] = static_cast<std::uint16_t>(lo[c] | (hi[c] << 8));
      store16(last_[c], item + 2 * c);
    }
  }

  void encode(ArithmeticEncoder& encoder, const std::uint8_t* item) override {
    std::array<int, 3> lo{}, hi{}, last_lo{}, last_hi{};
    for (int c = 0; c < 3; ++c) {
      const std::uint16_t v = load16(item + 2 * c);
      lo[c] = v & 0xff;
      hi[c] = v >> 8;
      last_lo[c] = last_[c] & 0xff;
      last_hi[c] = last_[c] >> 8;
    }
    std::uint32_t sym = 0;
    for (int c = 0; c < 3; ++c) {
      if (lo[c] != last_lo[c]) sym |= 1u << (2 * c);
      if (hi[c] != last_hi[c]) sym |= 2u << (2 * c);
    }
    const bool colour = lo[0] != lo[1] || hi[0] != hi[1] || lo[0] != lo[2] || hi[0] != hi[2];
    if (colour) sym |= 64;
    encoder.encode_symbol(used_, sym);
    int diff_lo = 0, diff_hi = 0;
    if (sym & 1) {
      diff_lo = lo[0] - last_lo[0];
      encoder.encode_symbol(diff_[0], fold8(diff_lo));
    }
    if (sym & 2) {
      diff_hi = hi[0] - last_hi[0];
      encoder.encode_symbol(diff_[1], fold8(diff_hi));
    }
    if (sym & 64) {
      if (sym & 4) encoder.encode_symbol(diff_[2], fold8(lo[1] - clamp8(diff_lo + last_lo[1])));
      if (sym & 16) {
        diff_lo = (diff_lo + lo[1] - last_lo[1]) / 2;
        encoder.encode_symbol(diff_[4], fold8(lo[2] - clamp8(diff_lo + last_lo[2])));
      }
      if (sym & 8) encoder.encode_symbol(diff_[3], fold8(hi[1] - clamp8(diff_hi + last_hi[1])));
      if (sym & 32) {
        diff_hi = (diff_hi + hi[1] - last_hi[1]) / 2;
        encoder.encode_symbol(diff_[5], fold8(hi[2] - clamp8(diff_hi + last_hi[2])));
      }
    }
    for (int c = 0; c < 3; ++c) last_[c] = static_cast<std::uint16_t>(lo[c] | (hi[c] << 8));
  }

 private:
  SymbolModel used_;
  std::array<SymbolModel, 6> diff_;
  std::array<std::uint16_t, 3> last_{};
};

}  // namespace

std::unique_ptr<ItemCodec> make_rgb12_v2() { return std::make_unique<Rgb12V2>(); }

}  // namespace pointfair::io::laz
