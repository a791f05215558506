#include "laz/integer_coder.hpp"

#include <cassert>
#include <limits>

namespace pointfair::io::laz {

IntegerCoder::IntegerCoder(unsigned bits, unsigned contexts, unsigned bits_high) : bits_high_(bits_high) {
  assert(bits >= 1 && bits <= 32 && contexts >= 1);
  if (bits < 32) {
    corr_bits_ = bits;
    corr_range_ = 1u << bits;
    corr_min_ = -static_cast<std::int32_t>(corr_range_ / 2);
    corr_max_ = corr_min_ + static_cast<std::int32_t>(corr_range_ - 1);
  } else {
    corr_bits_ = 32;
    corr_range_ = 0;
    corr_min_ = std::numeric_limits<std::int32_t>::min();
    corr_max_ = std::numeric_limits<std::int32_t>::max();
  }
  k_models_.assign(contexts, SymbolModel(corr_bits_ + 1));
  for (unsigned k = 1; k <= corr_bits_; ++k) {
    corrector_models_.emplace_back(k <= bits_high_ ? 1u << k : 1u << bits_high_);
  }
}

std::int32_t IntegerCoder::decompress(ArithmeticDecoder& decoder, std::int32_t prediction, unsigned context) {
  assert(context < k_models_.size());
  // Modular arithmetic on the corrector range (2^32 for 32 bits: unsigned wrap-around).
  std::int64_t real = static_cast<std::int64_t>(prediction) + read_corrector(decoder, k_models_[context]);
  if (corr_range_ != 0) {
    if (real < 0) {
      real += corr_range_;
    } else if (real >= static_cast<std::int64_t>(corr_range_)) {
      real -= corr_range_;
    }
  }
  return static_cast<std::int32_t>(static_cast<std::uint32_t>(real));
}

std::int32_t IntegerCoder::read_corrector(ArithmeticDecoder& decoder, SymbolModel& bits) {
  k_ = decoder.decode_symbol(bits);
  if (k_ == 0) return static_cast<std::int32_t>(decoder.decode_bit(corrector_0_));
  if (k_ >= 32) return corr_min_;
  std::uint32_t c;
  if (k_ <= bits_high_) {
    c = decoder.decode_symbol(corrector_models_[k_ - 1]);
  } else {
    const unsigned low_bits = k_ - bits_high_;
    c = decoder.decode_symbol(corrector_models_[k_ - 1]);
    c = (c << low_bits) | decoder.read_bits(low_bits);
  }
  // c in [0, 2^k): the upper half are the positive correctors 2^(k-1)+1 .. 2^k, the lower
  // half the negative ones -(2^k - 1) .. -2^(k-1).
  const std::int64_t half = std::int64_t{1} << (k_ - 1);
  const std::int64_t value = c >= half ? std::int64_t{c} + 1 : std::int64_t{c} - ((std::int64_t{1} << k_) - 1);
  return static_cast<std::int32_t>(value);
}

void IntegerCoder::compress(ArithmeticEncoder& encoder, std::int32_t prediction, std::int32_t real, unsigned context) {
  assert(context < k_models_.size());
  std::int64_t corrector = static_cast<std::int64_t>(real) - prediction;
  if (corr_range_ != 0) {
    if (corrector < corr_min_) {
      corrector += corr_range_;
    } else if (corrector > corr_max_) {
      corrector -= corr_range_;
    }
  } else {
    corrector = static_cast<std::int32_t>(static_cast<std::uint32_t>(corrector));  // wraps like int32
  }
  write_corrector(encoder, static_cast<std::int32_t>(corrector), k_models_[context]);
}

void IntegerCoder::write_corrector(ArithmeticEncoder& encoder, std::int32_t corrector, SymbolModel& bits) {
  const std::int64_t c = corrector;
  std::uint64_t magnitude = c <= 0 ? static_cast<std::uint64_t>(-c) : static_cast<std::uint64_t>(c - 1);
  k_ = 0;
  while (magnitude != 0) {
    magnitude >>= 1;
    ++k_;
  }
  encoder.encode_symbol(bits, k_);
  if (k_ == 0) {
    encoder.encode_bit(corrector_0_, static_cast<std::uint32_t>(c));
    return;
  }
  if (k_ >= 32) return;  // only the minimum int32, implied by k
  const auto shifted =
      static_cast<std::uint32_t>(c < 0 ? c + ((std::int64_t{1} << k_) - 1) : c - 1);
  if (k_ <= bits_high_) {
    encoder.encode_symbol(corrector_models_[k_ - 1], shifted);
  } else {
    const unsigned low_bits = k_ - bits_high_;
    encoder.encode_symbol(corrector_models_[k_ - 1], shifted >> low_bits);
    encoder.write_bits(low_bits, shifted & ((1u << low_bits) - 1));
  }
}

}  // namespace pointfair::io::laz
