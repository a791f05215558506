#include "laz/arithmetic_coder.hpp"

#include <cassert>

namespace pointfair::io::laz {

namespace {
// The interval is renormalised when its length falls below 2^24.
constexpr std::uint32_t kMinLength = 0x01000000u;
constexpr std::uint32_t kMaxLength = 0xffffffffu;
// Bit probabilities in units of 2^-13, symbol distributions in units of 2^-15; the counts
// are halved beyond these totals.
constexpr unsigned kBitLengthShift = 13;
constexpr std::uint32_t kBitMaxCount = 1u << kBitLengthShift;
constexpr unsigned kSymbolLengthShift = 15;
constexpr std::uint32_t kSymbolMaxCount = 1u << kSymbolLengthShift;
}  // namespace

void BitModel::reset() {
  bit_0_count = 1;
  bit_count = 2;
  bit_0_prob = 1u << (kBitLengthShift - 1);
  update_cycle = bits_until_update = 4;
}

void BitModel::update() {
  if ((bit_count += update_cycle) > kBitMaxCount) {
    bit_count = (bit_count + 1) >> 1;
    bit_0_count = (bit_0_count + 1) >> 1;
    if (bit_0_count == bit_count) ++bit_count;
  }
  const std::uint32_t scale = 0x80000000u / bit_count;
  bit_0_prob = (bit_0_count * scale) >> (31 - kBitLengthShift);
  update_cycle = (5 * update_cycle) >> 2;
  if (update_cycle > 64) update_cycle = 64;
  bits_until_update = update_cycle;
}

SymbolModel::SymbolModel(std::uint32_t symbol_count_)
    : symbols(symbol_count_), last_symbol(symbol_count_ - 1), distribution(symbol_count_), symbol_count(symbol_count_) {
  assert(symbols >= 2 && symbols <= 2048);
  if (symbols > 16) {
    unsigned table_bits = 3;
    while (symbols > (1u << (table_bits + 2))) ++table_bits;
    decoder_table.assign((std::size_t{1} << table_bits) + 2, 0);
    table_shift = kSymbolLengthShift - table_bits;
  }
  reset();
}

void SymbolModel::reset() {
  total_count = 0;
  update_cycle = symbols;
  std::fill(symbol_count.begin(), symbol_count.end(), 1u);
  update();
  symbols_until_update = update_cycle = (symbols + 6) >> 1;
}

void SymbolModel::update() {
  if ((total_count += update_cycle) > kSymbolMaxCount) {
    total_count = 0;
    for (std::uint32_t& count : symbol_count) {
      count = (count + 1) >> 1;
      total_count += count;
    }
  }
  const std::uint32_t scale = 0x80000000u / total_count;
  std::uint32_t sum = 0;
  for (std::uint32_t k = 0; k < symbols; ++k) {
    distribution[k] = (scale * sum) >> (31 - kSymbolLengthShift);
    sum += symbol_count[k];
  }
  if (!decoder_table.empty()) {
    const std::size_t table_size = decoder_table.size() - 2;
    std::size_t s = 0;
    for (std::uint32_t k = 0; k < symbols; ++k) {
      const std::size_t w = distribution[k] >> table_shift;
      while (s < w) decoder_table[++s] = k - 1;
    }
    decoder_table[0] = 0;
    while (s <= table_size) decoder_table[++s] = symbols - 1;
  }
  update_cycle = (5 * update_cycle) >> 2;
  const std::uint32_t max_cycle = (symbols + 6) << 3;
  if (update_cycle > max_cycle) update_cycle = max_cycle;
  symbols_until_update = update_cycle;
}

// ---- decoder ----

void ArithmeticDecoder::start() {
  length_ = kMaxLength;
  value_ = 0;
  for (int i = 0; i < 4; ++i) value_ = (value_ << 8) | bytes_.get();
  // Every decoding step keeps the value inside the interval (a bit or symbol narrows it to the
  // part that holds the value, raw bits leave the remainder of a division by the new length,
  // renormalising shifts both): only the first four bytes can put it outside, which no encoder
  // writes.
  if (value_ >= length_) throw CorruptCode{};
}

void ArithmeticDecoder::renormalise() {
  do {
    value_ = (value_ << 8) | bytes_.get();
  } while ((length_ <<= 8) < kMinLength);
}

std::uint32_t ArithmeticDecoder::decode_bit(BitModel& m) {
  assert(value_ < length_);
  const std::uint32_t x = m.bit_0_prob * (length_ >> kBitLengthShift);
  const std::uint32_t bit = value_ >= x ? 1u : 0u;
  if (bit == 0) {
    length_ = x;
    ++m.bit_0_count;
  } else {
    value_ -= x;
    length_ -= x;
  }
  if (length_ < kMinLength) renormalise();
  if (--m.bits_until_update == 0) m.update();
  return bit;
}

std::uint32_t ArithmeticDecoder::decode_symbol(SymbolModel& m) {
  // Bisection for the symbol whose cumulative interval holds the value: distribution[k] *
  // length > value exactly when distribution[k] > value / length (integer division), so a
  // table over value / length narrows where it starts. Inside the interval, value / length
  // stays below 2^15 + 2^6, so the table index stays within its two spare entries.
  assert(value_ < length_);
  std::uint32_t y = length_;
  std::uint32_t x = 0, symbol = 0, n = m.symbols;
  length_ >>= kSymbolLengthShift;
  if (!m.decoder_table.empty()) {
    const std::uint32_t scaled = value_ / length_;
    const std::uint32_t t = scaled >> m.table_shift;
    assert(t + 1 < m.decoder_table.size());
    symbol = m.decoder_table[t];
    n = m.decoder_table[t + 1] + 1;
    while (n > symbol + 1) {
      const std::uint32_t k = (symbol + n) >> 1;
      if (m.distribution[k] > scaled) n = k;
      else symbol = k;
    }
    x = m.distribution[symbol] * length_;
    if (symbol != m.last_symbol) y = m.distribution[symbol + 1] * length_;
  } else {
    std::uint32_t k = n >> 1;
    do {
      const std::uint32_t z = length_ * m.distribution[k];
      if (z > value_) {
        n = k;
        y = z;
      } else {
        symbol = k;
        x = z;
      }
    } while ((k = (symbol + n) >> 1) != symbol);
  }
  value_ -= x;
  length_ = y - x;
  if (length_ < kMinLength) renormalise();
  ++m.symbol_count[symbol];
  if (--m.symbols_until_update == 0) m.update();
  return symbol;
}

std::uint32_t ArithmeticDecoder::read_short() {
  length_ >>= 16;
  const std::uint32_t value = value_ / length_;
  value_ -= value * length_;
  if (length_ < kMinLength) renormalise();
  return value;
}

std::uint32_t ArithmeticDecoder::read_bits(unsigned count) {
  assert(count >= 1 && count <= 32);
  if (count > 19) {
    const std::uint32_t lower = read_short();
    return (read_bits(count - 16) << 16) | lower;
  }
  length_ >>= count;
  const std::uint32_t value = value_ / length_;
  value_ -= value * length_;
  if (length_ < kMinLength) renormalise();
  return value;
}

// ---- encoder ----

void ArithmeticEncoder::propagate_carry() {
  std::size_t p = out_.size();
  while (p > first_ && out_[p - 1] == 0xff) out_[--p] = 0;
  assert(p > first_);  // the code value is below 1: a carry never leaves the stream
  ++out_[p - 1];
}

void ArithmeticEncoder::renormalise() {
  do {
    out_.push_back(static_cast<std::uint8_t>(base_ >> 24));
    base_ <<= 8;
  } while ((length_ <<= 8) < kMinLength);
}

void ArithmeticEncoder::encode_bit(BitModel& m, std::uint32_t bit) {
  const std::uint32_t x = m.bit_0_prob * (length_ >> kBitLengthShift);
  if (bit == 0) {
    length_ = x;
    ++m.bit_0_count;
  } else {
    const std::uint32_t init_base = base_;
    base_ += x;
    length_ -= x;
    if (init_base > base_) propagate_carry();
  }
  if (length_ < kMinLength) renormalise();
  if (--m.bits_until_update == 0) m.update();
}

void ArithmeticEncoder::encode_symbol(SymbolModel& m, std::uint32_t symbol) {
  assert(symbol < m.symbols);
  const std::uint32_t init_base = base_;
  if (symbol == m.last_symbol) {
    const std::uint32_t x = m.distribution[symbol] * (length_ >> kSymbolLengthShift);
    base_ += x;
    length_ -= x;
  } else {
    length_ >>= kSymbolLengthShift;
    const std::uint32_t x = m.distribution[symbol] * length_;
    base_ += x;
    length_ = m.distribution[symbol + 1] * length_ - x;
  }
  if (init_base > base_) propagate_carry();
  if (length_ < kMinLength) renormalise();
  ++m.symbol_count[symbol];
  if (--m.symbols_until_update == 0) m.update();
}

void ArithmeticEncoder::write_short(std::uint32_t value) {
  const std::uint32_t init_base = base_;
  base_ += value * (length_ >>= 16);
  if (init_base > base_) propagate_carry();
  if (length_ < kMinLength) renormalise();
}

void ArithmeticEncoder::write_bits(unsigned count, std::uint32_t bits) {
  assert(count >= 1 && count <= 32);
  if (count > 19) {
    write_short(bits & 0xffff);
    bits >>= 16;
    count -= 16;
  }
  const std::uint32_t init_base = base_;
  base_ += bits * (length_ >>= count);
  if (init_base > base_) propagate_carry();
  if (length_ < kMinLength) renormalise();
}

void ArithmeticEncoder::finish() {
  // A final value inside the interval with as few bytes as the decoder's reads need.
  const std::uint32_t init_base = base_;
  bool another_byte = true;
  if (length_ > 2 * kMinLength) {
    base_ += kMinLength;
    length_ = kMinLength >> 1;
  } else {
    base_ += kMinLength >> 1;
    length_ = kMinLength >> 9;
    another_byte = false;
  }
  if (init_base > base_) propagate_carry();
  renormalise();
  // The decoder reads four bytes ahead.
  out_.push_back(0);
  out_.push_back(0);
  if (another_byte) out_.push_back(0);
}

}  // namespace pointfair::io::laz
