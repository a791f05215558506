// BYTE item, version 2: each extra byte coded as its difference (mod 256) from the same
// byte of the previous point, with one symbol model per byte.
#include <vector>

#include "laz/item_codec.hpp"

namespace pointfair::io::laz {

namespace {

class ByteV2 final : public ItemCodec {
 public:
  explicit ByteV2(std::size_t size) : last_(size), models_(size, SymbolModel(256)) {}

  void start(const std::uint8_t* item) override {
    for (SymbolModel& model : models_) model.reset();
    std::copy(item, item + last_.size(), last_.begin());
  }

  void decode(ArithmeticDecoder& decoder, std::uint8_t* item) override {
    for (std::size_t i = 0; i < last_.size(); ++i) {
      last_[i] = static_cast<std::uint8_t>(last_[i] + decoder.decode_symbol(models_[i]));
      item[i] = last_[i];
    }
  }

  void encode(ArithmeticEncoder& encoder, const std::uint8_t* item) override {
    for (std::size_t i = 0; i < last_.size(); ++i) {
      encoder.encode_symbol(models_[i], static_cast<std::uint8_t>(item[i] - last_[i]));
      last_[i] = item[i];
    }
  }

 private:
  std::vector<std::uint8_t> last_;
  std::vector<SymbolModel> models_;
};

}  // namespace

std::unique_ptr<ItemCodec> make_byte_v2(std::size_t size) { return std::make_unique<ByteV2>(size); }

}  // namespace pointfair::io::laz
