// RGB12 item, version 2: three 16-bit colours coded as rgb_coding.hpp describes.
#include "laz/item_codec.hpp"
#include "laz/rgb_coding.hpp"

namespace pointfair::io::laz {

namespace {

Rgb load(const std::uint8_t* p) {
  Rgb rgb{};
  for (int c = 0; c < 3; ++c) rgb[c] = static_cast<std::uint16_t>(p[2 * c] | (p[2 * c + 1] << 8));
  return rgb;
}

class Rgb12V2 final : public ItemCodec {
 public:
  void start(const std::uint8_t* item) override {
    models_.reset();
    last_ = load(item);
  }
  void decode(ArithmeticDecoder& decoder, std::uint8_t* item) override {
    last_ = decode_rgb(decoder, models_, last_);
    for (int c = 0; c < 3; ++c) {
      item[2 * c] = static_cast<std::uint8_t>(last_[c]);
      item[2 * c + 1] = static_cast<std::uint8_t>(last_[c] >> 8);
    }
  }
  void encode(ArithmeticEncoder& encoder, const std::uint8_t* item) override {
    const Rgb rgb = load(item);
    encode_rgb(encoder, models_, last_, rgb);
    last_ = rgb;
  }

 private:
  RgbModels models_;
  Rgb last_{};
};

}  // namespace

std::unique_ptr<ItemCodec> make_rgb12_v2() { return std::make_unique<Rgb12V2>(); }

}  // namespace pointfair::io::laz
