// GPSTIME11 item, version 2: the GPS time's 64 bits read as an integer, coded as a
// difference from the previous time of one of four sequences (interleaved flight lines).
// A difference that fits 32 bits is coded as a multiple of the sequence's last difference
// plus a corrector (the multiple a symbol: 1..499, 500 for larger, -1..-10, 0); a larger
// one starts a new sequence with the time's high 32 bits predicted and its low 32 bits raw.
#include <array>
#include <cmath>
#include <cstring>
#include <limits>

#include "laz/integer_coder.hpp"
#include "laz/item_codec.hpp"

namespace pointfair::io::laz {

namespace {

constexpr std::int32_t kMulti = 500;
constexpr std::int32_t kMultiMinus = -10;
constexpr std::uint32_t kMultiUnchanged = kMulti - kMultiMinus + 1;  // 511
constexpr std::uint32_t kMultiCodeFull = kMulti - kMultiMinus + 2;   // 512
constexpr std::uint32_t kMultiTotal = kMulti - kMultiMinus + 6;      // 516

// 32-bit products and sums wrap as the format's int32 arithmetic does.
// Adds as the format's 64-bit integers do (wrapping, on a corrupt stream).
std::int64_t add64(std::int64_t a, std::int32_t b) {
  return static_cast<std::int64_t>(static_cast<std::uint64_t>(a) + static_cast<std::uint64_t>(static_cast<std::int64_t>(b)));
}

std::int32_t wrap32(std::int64_t v) { return static_cast<std::int32_t>(static_cast<std::uint32_t>(static_cast<std::uint64_t>(v))); }

// Rounds to nearest as the format's float quantisation does; saturated to int32.
std::int32_t quantize(float value) {
  const float rounded = value >= 0 ? value + 0.5f : value - 0.5f;
  if (!(rounded < 2147483648.0f)) return rounded > 0 ? std::numeric_limits<std::int32_t>::max() : std::numeric_limits<std::int32_t>::min();
  if (!(rounded >= -2147483648.0f)) return std::numeric_limits<std::int32_t>::min();
  return static_cast<std::int32_t>(rounded);
}

class GpsTime11V2 final : public ItemCodec {
 public:
  GpsTime11V2() : multi_(kMultiTotal), zero_diff_(6), ic_(32, 9) {}

  void start(const std::uint8_t* item) override {
    multi_.reset();
    zero_diff_.reset();
    ic_ = IntegerCoder(32, 9);
    last_ = next_ = 0;
    diff_.fill(0);
    extreme_.fill(0);
    time_.fill(0);
    std::memcpy(&time_[0], item, 8);
  }

  void decode(ArithmeticDecoder& d, std::uint8_t* item) override {
    decode_time(d);
    std::memcpy(item, &time_[last_], 8);
  }

  void encode(ArithmeticEncoder& e, const std::uint8_t* item) override {
    std::int64_t time;
    std::memcpy(&time, item, 8);
    encode_time(e, time);
  }

 private:
  void start_sequence_decoded(ArithmeticDecoder& d) {
    next_ = (next_ + 1) & 3;
    const auto high = static_cast<std::uint32_t>(ic_.decompress(d, static_cast<std::int32_t>(static_cast<std::uint64_t>(time_[last_]) >> 32), 8));
    const std::uint32_t low = d.read_int();
    time_[next_] = static_cast<std::int64_t>((std::uint64_t{high} << 32) | low);
    last_ = next_;
    diff_[last_] = 0;
    extreme_[last_] = 0;
  }

  void count_extreme(std::int32_t diff) {
    if (++extreme_[last_] > 3) {
      diff_[last_] = diff;
      extreme_[last_] = 0;
    }
  }

  void decode_time(ArithmeticDecoder& d) {
    for (;;) {
      if (diff_[last_] == 0) {
        const std::uint32_t multi = d.decode_symbol(zero_diff_);
        if (multi == 1) {
          diff_[last_] = ic_.decompress(d, 0, 0);
          time_[last_] = add64(time_[last_], diff_[last_]);
          extreme_[last_] = 0;
        } else if (multi == 2) {
          start_sequence_decoded(d);
        } else if (multi > 2) {
          last_ = (last_ + multi - 2) & 3;
          continue;  // the time continues another sequence
        }
        return;
      }
      const std::uint32_t multi = d.decode_symbol(multi_);
      if (multi == 1) {
        diff_[last_] = ic_.decompress(d, diff_[last_], 1);
        time_[last_] = add64(time_[last_], diff_[last_]);
        extreme_[last_] = 0;
      } else if (multi < kMultiUnchanged) {
        std::int32_t diff;
        if (multi == 0) {
          diff = ic_.decompress(d, 0, 7);
          count_extreme(diff);
        } else if (multi < static_cast<std::uint32_t>(kMulti)) {
          diff = ic_.decompress(d, wrap32(std::int64_t{static_cast<std::int32_t>(multi)} * diff_[last_]), multi < 10 ? 2 : 3);
        } else if (multi == static_cast<std::uint32_t>(kMulti)) {
          diff = ic_.decompress(d, wrap32(std::int64_t{kMulti} * diff_[last_]), 4);
          count_extreme(diff);
        } else {
          const std::int32_t negative = kMulti - static_cast<std::int32_t>(multi);
          if (negative > kMultiMinus) {
            diff = ic_.decompress(d, wrap32(std::int64_t{negative} * diff_[last_]), 5);
          } else {
            diff = ic_.decompress(d, wrap32(std::int64_t{kMultiMinus} * diff_[last_]), 6);
            count_extreme(diff);
          }
        }
        time_[last_] = add64(time_[last_], diff);
      } else if (multi == kMultiCodeFull) {
        start_sequence_decoded(d);
      } else if (multi > kMultiCodeFull) {
        last_ = (last_ + multi - kMultiCodeFull) & 3;
        continue;
      }
      return;
    }
  }

  // The other sequence (1..3 ahead of last_) whose time is within 32 bits of `time`; 0: none.
  unsigned other_sequence(std::int64_t time) const {
    for (unsigned i = 1; i < 4; ++i) {
      const std::int64_t diff = static_cast<std::int64_t>(static_cast<std::uint64_t>(time) - static_cast<std::uint64_t>(time_[(last_ + i) & 3]));
      if (diff == static_cast<std::int32_t>(diff)) return i;
    }
    return 0;
  }

  void start_sequence_encoded(ArithmeticEncoder& e, std::int64_t time) {
    ic_.compress(e, static_cast<std::int32_t>(static_cast<std::uint64_t>(time_[last_]) >> 32),
                 static_cast<std::int32_t>(static_cast<std::uint64_t>(time) >> 32), 8);
    e.write_int(static_cast<std::uint32_t>(static_cast<std::uint64_t>(time)));
    next_ = (next_ + 1) & 3;
    last_ = next_;
    diff_[last_] = 0;
    extreme_[last_] = 0;
  }

  void encode_time(ArithmeticEncoder& e, std::int64_t time) {
    for (;;) {
      const std::int64_t diff64 = static_cast<std::int64_t>(static_cast<std::uint64_t>(time) - static_cast<std::uint64_t>(time_[last_]));
      const bool fits = diff64 == static_cast<std::int32_t>(diff64);
      const auto diff = static_cast<std::int32_t>(diff64);
      if (diff_[last_] == 0) {
        if (time == time_[last_]) {
          e.encode_symbol(zero_diff_, 0);
          return;
        }
        if (fits) {
          e.encode_symbol(zero_diff_, 1);
          ic_.compress(e, 0, diff, 0);
          diff_[last_] = diff;
          extreme_[last_] = 0;
        } else if (const unsigned other = other_sequence(time); other != 0) {
          e.encode_symbol(zero_diff_, other + 2);
          last_ = (last_ + other) & 3;
          continue;
        } else {
          e.encode_symbol(zero_diff_, 2);
          start_sequence_encoded(e, time);
        }
        time_[last_] = time;
        return;
      }
      if (time == time_[last_]) {
        e.encode_symbol(multi_, kMultiUnchanged);
        return;
      }
      if (fits) {
        const std::int32_t multi = quantize(static_cast<float>(diff) / static_cast<float>(diff_[last_]));
        if (multi == 1) {
          e.encode_symbol(multi_, 1);
          ic_.compress(e, diff_[last_], diff, 1);
          diff_[last_] = diff;
          extreme_[last_] = 0;
        } else if (multi > 0) {
          if (multi < kMulti) {
            e.encode_symbol(multi_, static_cast<std::uint32_t>(multi));
            ic_.compress(e, wrap32(std::int64_t{multi} * diff_[last_]), diff, multi < 10 ? 2 : 3);
          } else {
            e.encode_symbol(multi_, static_cast<std::uint32_t>(kMulti));
            ic_.compress(e, wrap32(std::int64_t{kMulti} * diff_[last_]), diff, 4);
            count_extreme(diff);
          }
        } else if (multi < 0) {
          if (multi > kMultiMinus) {
            e.encode_symbol(multi_, static_cast<std::uint32_t>(kMulti - multi));
            ic_.compress(e, wrap32(std::int64_t{multi} * diff_[last_]), diff, 5);
          } else {
            e.encode_symbol(multi_, static_cast<std::uint32_t>(kMulti - kMultiMinus));
            ic_.compress(e, wrap32(std::int64_t{kMultiMinus} * diff_[last_]), diff, 6);
            count_extreme(diff);
          }
        } else {
          e.encode_symbol(multi_, 0);
          ic_.compress(e, 0, diff, 7);
          count_extreme(diff);
        }
      } else if (const unsigned other = other_sequence(time); other != 0) {
        e.encode_symbol(multi_, kMultiCodeFull + other);
        last_ = (last_ + other) & 3;
        continue;
      } else {
        e.encode_symbol(multi_, kMultiCodeFull);
        start_sequence_encoded(e, time);
      }
      time_[last_] = time;
      return;
    }
  }

  SymbolModel multi_, zero_diff_;
  IntegerCoder ic_;
  unsigned last_ = 0, next_ = 0;
  std::array<std::int64_t, 4> time_{};
  std::array<std::int32_t, 4> diff_{};
  std::array<std::int32_t, 4> extreme_{};
};

}  // namespace

std::unique_ptr<ItemCodec> make_gpstime11_v2() { return std::make_unique<GpsTime11V2>(); }

}  // namespace pointfair::io::laz
