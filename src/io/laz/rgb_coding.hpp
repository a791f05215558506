#pragma once
// The RGB coding of LAZ, shared by RGB12 (version 2) and RGB14 (version 3): which of the six
// colour bytes changed (a 7-bit symbol, bit 6: the colour is not grey), then each changed
// byte against a prediction: red from the previous red, green and blue from the previous
// value moved by red's change (blue by the mean of red's and green's).
#include <array>
#include <cstdint>

#include "laz/arithmetic_coder.hpp"

namespace pointfair::io::laz {

struct RgbModels {
  SymbolModel used{128};
  std::array<SymbolModel, 6> diff{SymbolModel(256), SymbolModel(256), SymbolModel(256),
                                  SymbolModel(256), SymbolModel(256), SymbolModel(256)};
  void reset() {
    used.reset();
    for (SymbolModel& m : diff) m.reset();
  }
};

using Rgb = std::array<std::uint16_t, 3>;

/// The colour after `last`.
Rgb decode_rgb(ArithmeticDecoder& decoder, RgbModels& models, const Rgb& last);
/// Codes `rgb`, which follows `last`.
void encode_rgb(ArithmeticEncoder& encoder, RgbModels& models, const Rgb& last, const Rgb& rgb);

}  // namespace pointfair::io::laz
