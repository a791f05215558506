#pragma once
// LAZ's integer compressor: an integer is coded as its difference (the corrector) from a
// prediction. The corrector's bit length k is coded with a symbol model (one per context),
// then the corrector within the 2^(k-1) values of that length: its high bits (at most
// `bits_high`) with a symbol model per k, its low bits raw.
#include <cstdint>
#include <vector>

#include "laz/arithmetic_coder.hpp"

namespace pointfair::io::laz {

class IntegerCoder {
 public:
  /// Integers of `bits` bits (32: any int32, arithmetic wraps), `contexts` sets of models.
  explicit IntegerCoder(unsigned bits = 16, unsigned contexts = 1, unsigned bits_high = 8);

  std::int32_t decompress(ArithmeticDecoder& decoder, std::int32_t prediction, unsigned context);
  void compress(ArithmeticEncoder& encoder, std::int32_t prediction, std::int32_t real, unsigned context);
  /// The bit length of the last corrector (a context for the next value in some codecs).
  unsigned k() const { return k_; }

 private:
  std::int32_t read_corrector(ArithmeticDecoder& decoder, SymbolModel& bits);
  void write_corrector(ArithmeticEncoder& encoder, std::int32_t corrector, SymbolModel& bits);

  unsigned bits_high_;
  unsigned corr_bits_;
  std::uint32_t corr_range_;  // 0: 2^32
  std::int32_t corr_min_, corr_max_;
  std::vector<SymbolModel> k_models_;          // one per context
  BitModel corrector_0_;                        // k = 0: the corrector is 0 or 1
  std::vector<SymbolModel> corrector_models_;  // index k - 1 for k >= 1
  unsigned k_ = 0;
};

}  // namespace pointfair::io::laz
