// The layered codecs of LAS 1.4's point formats 6-8 (see layered14.hpp). One routine codes a
// point in both directions: encoding, it codes the value it is given and returns it;
// decoding, it returns the value it reads. So the two directions cannot drift apart.
#include "laz/layered14.hpp"

#include <array>
#include <cassert>
#include <cstring>
#include <limits>
#include <optional>

#include "laz/arithmetic_coder.hpp"
#include "laz/chunk_bytes.hpp"
#include "laz/integer_coder.hpp"
#include "laz/median5.hpp"
#include "laz/rgb_coding.hpp"

namespace pointfair::io::laz {

namespace {

// The return map m (6 contexts) and the return level l (8 contexts) of a point with n
// returns and return number r, completed for invalid combinations (the specification's tables).
constexpr std::uint8_t kReturnMap6[16][16] = {
    {0, 1, 2, 3, 4, 5, 3, 4, 4, 5, 5, 5, 5, 5, 5, 5}, {1, 0, 1, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3},
    {2, 1, 2, 4, 4, 4, 4, 4, 4, 4, 4, 3, 3, 3, 3, 3}, {3, 3, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4},
    {4, 3, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4}, {5, 3, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4},
    {3, 3, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4, 4}, {4, 3, 4, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4},
    {4, 3, 4, 4, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4}, {5, 3, 4, 4, 4, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4},
    {5, 3, 4, 4, 4, 4, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4}, {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5, 4, 4, 4},
    {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5, 5, 4, 4}, {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5, 5, 4},
    {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5, 5}, {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5}};
constexpr std::uint8_t kReturnLevel8[16][16] = {
    {0, 1, 2, 3, 4, 5, 6, 7, 7, 7, 7, 7, 7, 7, 7, 7}, {1, 0, 1, 2, 3, 4, 5, 6, 7, 7, 7, 7, 7, 7, 7, 7},
    {2, 1, 0, 1, 2, 3, 4, 5, 6, 7, 7, 7, 7, 7, 7, 7}, {3, 2, 1, 0, 1, 2, 3, 4, 5, 6, 7, 7, 7, 7, 7, 7},
    {4, 3, 2, 1, 0, 1, 2, 3, 4, 5, 6, 7, 7, 7, 7, 7}, {5, 4, 3, 2, 1, 0, 1, 2, 3, 4, 5, 6, 7, 7, 7, 7},
    {6, 5, 4, 3, 2, 1, 0, 1, 2, 3, 4, 5, 6, 7, 7, 7}, {7, 6, 5, 4, 3, 2, 1, 0, 1, 2, 3, 4, 5, 6, 7, 7},
    {7, 7, 6, 5, 4, 3, 2, 1, 0, 1, 2, 3, 4, 5, 6, 7}, {7, 7, 7, 6, 5, 4, 3, 2, 1, 0, 1, 2, 3, 4, 5, 6},
    {7, 7, 7, 7, 6, 5, 4, 3, 2, 1, 0, 1, 2, 3, 4, 5}, {7, 7, 7, 7, 7, 6, 5, 4, 3, 2, 1, 0, 1, 2, 3, 4},
    {7, 7, 7, 7, 7, 7, 6, 5, 4, 3, 2, 1, 0, 1, 2, 3}, {7, 7, 7, 7, 7, 7, 7, 6, 5, 4, 3, 2, 1, 0, 1, 2},
    {7, 7, 7, 7, 7, 7, 7, 7, 6, 5, 4, 3, 2, 1, 0, 1}, {7, 7, 7, 7, 7, 7, 7, 7, 7, 6, 5, 4, 3, 2, 1, 0}};

// GPS time multipliers (as GPSTIME11 but without the "unchanged" symbol, which the layer of
// changes makes unnecessary).
constexpr std::int32_t kMulti = 500;
constexpr std::int32_t kMultiMinus = -10;
constexpr std::uint32_t kMultiCodeFull = kMulti - kMultiMinus + 1;  // 511
constexpr std::uint32_t kMultiTotal = kMulti - kMultiMinus + 5;     // 515

// The layers, in the order of the chunk.
enum LayerIndex : std::size_t { kXY, kZ, kClass, kFlags, kIntensity, kScanAngle, kUserData, kSourceId, kGpsTime, kPointLayers };

// The 30 bytes of a format 6 record, unpacked.
struct Point14 {
  std::int32_t x = 0, y = 0, z = 0;
  std::uint16_t intensity = 0;
  unsigned r = 0, n = 0;          // return number, number of returns (4 bits each)
  unsigned class_flags = 0;       // synthetic, key point, withheld, overlap (4 bits)
  unsigned channel = 0;           // scanner channel (2 bits)
  unsigned scan_direction = 0, edge = 0;
  unsigned classification = 0, user_data = 0;
  std::int16_t scan_angle = 0;
  std::uint16_t source_id = 0;
  std::int64_t gps = 0;           // the GPS time's bits
  bool gps_change = false;        // the GPS time changed from the previous point of the channel
};

template <typename T>
T load(const std::uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return v;
}
template <typename T>
void store(T v, std::uint8_t* p) {
  std::memcpy(p, &v, sizeof(T));
}

Point14 unpack(const std::uint8_t* p) {
  Point14 q;
  q.x = load<std::int32_t>(p);
  q.y = load<std::int32_t>(p + 4);
  q.z = load<std::int32_t>(p + 8);
  q.intensity = load<std::uint16_t>(p + 12);
  q.r = p[14] & 15u;
  q.n = p[14] >> 4;
  q.class_flags = p[15] & 15u;
  q.channel = (p[15] >> 4) & 3u;
  q.scan_direction = (p[15] >> 6) & 1u;
  q.edge = p[15] >> 7;
  q.classification = p[16];
  q.user_data = p[17];
  q.scan_angle = load<std::int16_t>(p + 18);
  q.source_id = load<std::uint16_t>(p + 20);
  q.gps = load<std::int64_t>(p + 22);
  return q;
}

void pack(const Point14& q, std::uint8_t* p) {
  store(q.x, p);
  store(q.y, p + 4);
  store(q.z, p + 8);
  store(q.intensity, p + 12);
  p[14] = static_cast<std::uint8_t>(q.r | (q.n << 4));
  p[15] = static_cast<std::uint8_t>(q.class_flags | (q.channel << 4) | (q.scan_direction << 6) | (q.edge << 7));
  p[16] = static_cast<std::uint8_t>(q.classification);
  p[17] = static_cast<std::uint8_t>(q.user_data);
  store(q.scan_angle, p + 18);
  store(q.source_id, p + 20);
  store(q.gps, p + 22);
}

// Adds as the format's 64-bit integers do (wrapping, on a corrupt stream).
std::int64_t add64(std::int64_t a, std::int32_t b) {
  return static_cast<std::int64_t>(static_cast<std::uint64_t>(a) + static_cast<std::uint64_t>(static_cast<std::int64_t>(b)));
}

std::int32_t wrap32(std::int64_t v) { return static_cast<std::int32_t>(static_cast<std::uint32_t>(static_cast<std::uint64_t>(v))); }
std::int32_t wrap_sub(std::int32_t a, std::int32_t b) {
  return static_cast<std::int32_t>(static_cast<std::uint32_t>(a) - static_cast<std::uint32_t>(b));
}
std::int64_t sub64(std::int64_t a, std::int64_t b) {
  return static_cast<std::int64_t>(static_cast<std::uint64_t>(a) - static_cast<std::uint64_t>(b));
}
std::int32_t quantize(float value) {
  const float rounded = value >= 0 ? value + 0.5f : value - 0.5f;
  if (!(rounded < 2147483648.0f)) return rounded > 0 ? std::numeric_limits<std::int32_t>::max() : std::numeric_limits<std::int32_t>::min();
  if (!(rounded >= -2147483648.0f)) return std::numeric_limits<std::int32_t>::min();
  return static_cast<std::int32_t>(rounded);
}

// The models and predictions of one scanner channel.
struct Context {
  explicit Context(const Point14& point) : last(point) {
    last.gps_change = false;
    last_z.fill(point.z);
    last_intensity.fill(point.intensity);
    gps_time[0] = point.gps;
  }

  Point14 last;
  std::array<SymbolModel, 8> changed_values{SymbolModel(128), SymbolModel(128), SymbolModel(128), SymbolModel(128),
                                            SymbolModel(128), SymbolModel(128), SymbolModel(128), SymbolModel(128)};
  SymbolModel scanner_channel{3};
  std::array<std::optional<SymbolModel>, 16> number_of_returns, return_number;
  SymbolModel return_number_gps_same{13};
  IntegerCoder dx{32, 2}, dy{32, 22}, z{32, 20};
  std::array<std::optional<SymbolModel>, 64> classification, flags, user_data;
  IntegerCoder intensity{16, 4}, scan_angle{16, 2}, source_id{16, 1};
  SymbolModel gps_multi{kMultiTotal}, gps_0diff{5};
  IntegerCoder gps{32, 9};
  std::array<Median5, 12> median_x{}, median_y{};
  std::array<std::int32_t, 8> last_z{};
  std::array<std::uint16_t, 8> last_intensity{};
  unsigned gps_last = 0, gps_next = 0;
  std::array<std::int64_t, 4> gps_time{};
  std::array<std::int32_t, 4> gps_diff{}, gps_extreme{};

};

// The models and last values of the colours and extra bytes of one context. These items
// follow their own context (see code()), not always the point's scanner channel.
struct ItemContext {
  ItemContext(const std::array<std::uint16_t, 4>& colour, const std::vector<std::uint8_t>& bytes)
      : last_colour(colour), last_bytes(bytes), byte_models(bytes.size(), SymbolModel(256)) {}

  std::array<std::uint16_t, 4> last_colour;  // red, green, blue, nir
  RgbModels rgb;
  SymbolModel nir_used{4}, nir_low{256}, nir_high{256};
  std::vector<std::uint8_t> last_bytes;
  std::vector<SymbolModel> byte_models;
};

SymbolModel& lazy(std::optional<SymbolModel>& slot, std::uint32_t symbols) {
  if (!slot) slot.emplace(symbols);
  return *slot;
}

// One layer: its coder in one direction, and whether its attributes changed in the chunk.
struct Layer {
  std::vector<std::uint8_t> out;                 // encoding
  std::optional<ArithmeticEncoder> encoder;
  std::unique_ptr<ChunkBytes> in;                // decoding
  std::optional<ArithmeticDecoder> decoder;
  bool changed = false;
};

}  // namespace

struct Layered14Codec::State {
  int point_format;
  std::size_t extra;
  bool encoding = false;
  std::vector<Layer> layers;
  std::array<std::optional<Context>, 4> contexts;
  unsigned current = 0;
  std::array<std::optional<ItemContext>, 4> item_contexts;
  unsigned item_current = 0;

  bool has_rgb() const { return point_format >= 7; }
  bool has_nir() const { return point_format == 8; }
  std::size_t rgb_layer() const { return kPointLayers; }
  std::size_t nir_layer() const { return kPointLayers + 1; }
  std::size_t byte_layer(std::size_t i) const { return kPointLayers + (has_rgb() ? 1 : 0) + (has_nir() ? 1 : 0) + i; }
  std::size_t layer_count() const { return byte_layer(extra); }

  // Encoding: always (the layer is dropped if nothing changed); decoding: if it has bytes.
  bool active(std::size_t layer) const { return encoding || layers[layer].decoder.has_value(); }
  std::uint32_t symbol(std::size_t layer, SymbolModel& model, std::uint32_t value) {
    Layer& l = layers[layer];
    if (encoding) {
      l.encoder->encode_symbol(model, value);
      return value;
    }
    return l.decoder->decode_symbol(model);
  }
  std::int32_t integer(std::size_t layer, IntegerCoder& coder, std::int32_t prediction, std::int32_t value, unsigned context) {
    Layer& l = layers[layer];
    if (encoding) {
      coder.compress(*l.encoder, prediction, value, context);
      return value;
    }
    return coder.decompress(*l.decoder, prediction, context);
  }
  std::uint32_t raw_int(std::size_t layer, std::uint32_t value) {
    Layer& l = layers[layer];
    if (encoding) {
      l.encoder->write_int(value);
      return value;
    }
    return l.decoder->read_int();
  }

  // Splits a record into the point, colours and extra bytes.
  void split(const std::uint8_t* record, Point14& point, std::array<std::uint16_t, 4>& colour,
             std::vector<std::uint8_t>& bytes) const {
    point = unpack(record);
    colour.fill(0);
    std::size_t at = 30;
    if (has_rgb()) {
      for (int c = 0; c < 3; ++c) colour[c] = load<std::uint16_t>(record + at + 2 * c);
      at += 6;
    }
    if (has_nir()) {
      colour[3] = load<std::uint16_t>(record + at);
      at += 2;
    }
    bytes.assign(record + at, record + at + extra);
  }
  void join(const Point14& point, const ItemContext& c, std::uint8_t* record) const {
    pack(point, record);
    std::size_t at = 30;
    if (has_rgb()) {
      for (int k = 0; k < 3; ++k) store(c.last_colour[k], record + at + 2 * k);
      at += 6;
    }
    if (has_nir()) {
      store(c.last_colour[3], record + at);
      at += 2;
    }
    if (extra > 0) std::memcpy(record + at, c.last_bytes.data(), extra);  // an empty vector's data() may be null
  }

  void start(const std::uint8_t* record) {
    Point14 point;
    std::array<std::uint16_t, 4> colour{};
    std::vector<std::uint8_t> bytes;
    split(record, point, colour, bytes);
    for (auto& c : contexts) c.reset();
    for (auto& c : item_contexts) c.reset();
    current = item_current = point.channel;
    contexts[current].emplace(point);
    item_contexts[item_current].emplace(colour, bytes);
  }

  // A new sequence of GPS times: the high 32 bits predicted, the low ones raw.
  void gps_new_sequence(Context& c, std::int64_t time) {
    const auto high = static_cast<std::uint32_t>(integer(kGpsTime, c.gps, static_cast<std::int32_t>(static_cast<std::uint64_t>(c.gps_time[c.gps_last]) >> 32),
                                                         static_cast<std::int32_t>(static_cast<std::uint64_t>(time) >> 32), 8));
    const std::uint32_t low = raw_int(kGpsTime, static_cast<std::uint32_t>(static_cast<std::uint64_t>(time)));
    c.gps_next = (c.gps_next + 1) & 3;
    c.gps_time[c.gps_next] = static_cast<std::int64_t>((std::uint64_t{high} << 32) | low);
    c.gps_last = c.gps_next;
    c.gps_diff[c.gps_last] = 0;
    c.gps_extreme[c.gps_last] = 0;
  }

  void gps_extreme(Context& c, std::int32_t diff) {
    if (++c.gps_extreme[c.gps_last] > 3) {
      c.gps_diff[c.gps_last] = diff;
      c.gps_extreme[c.gps_last] = 0;
    }
  }

  // The other sequence (1..3 ahead) within 32 bits of `time`; 0: none.
  static unsigned other_sequence(const Context& c, std::int64_t time) {
    for (unsigned i = 1; i < 4; ++i) {
      const std::int64_t diff = sub64(time, c.gps_time[(c.gps_last + i) & 3]);
      if (diff == static_cast<std::int32_t>(diff)) return i;
    }
    return 0;
  }

  // Codes a GPS time that differs from the channel's last one (`time`: encoding only).
  void code_gps(Context& c, std::int64_t time) {
    for (;;) {
      const std::int64_t diff64 = sub64(time, c.gps_time[c.gps_last]);
      const bool fits = diff64 == static_cast<std::int32_t>(diff64);
      const auto diff = static_cast<std::int32_t>(diff64);
      if (c.gps_diff[c.gps_last] == 0) {
        std::uint32_t s = 0;
        if (encoding && !fits) {
          const unsigned other = other_sequence(c, time);
          s = other != 0 ? other + 1 : 1;
        }
        s = symbol(kGpsTime, c.gps_0diff, s);
        if (s == 0) {
          const std::int32_t d = integer(kGpsTime, c.gps, 0, diff, 0);
          c.gps_diff[c.gps_last] = d;
          c.gps_time[c.gps_last] = add64(c.gps_time[c.gps_last], d);
          c.gps_extreme[c.gps_last] = 0;
        } else if (s == 1) {
          gps_new_sequence(c, time);
        } else {
          c.gps_last = (c.gps_last + s - 1) & 3;
          continue;
        }
        return;
      }
      const std::int32_t last_diff = c.gps_diff[c.gps_last];
      std::uint32_t s = 0;
      std::int32_t multi = 0;
      if (encoding) {
        if (fits) {
          multi = quantize(static_cast<float>(diff) / static_cast<float>(last_diff));
          if (multi == 1) {
            s = 1;
          } else if (multi > 0) {
            s = static_cast<std::uint32_t>(multi < kMulti ? multi : kMulti);
          } else if (multi < 0) {
            s = static_cast<std::uint32_t>(kMulti - (multi > kMultiMinus ? multi : kMultiMinus));
          } else {
            s = 0;
          }
        } else {
          const unsigned other = other_sequence(c, time);
          s = kMultiCodeFull + other;
        }
      }
      s = symbol(kGpsTime, c.gps_multi, s);
      if (s == 1) {
        const std::int32_t d = integer(kGpsTime, c.gps, last_diff, diff, 1);
        c.gps_time[c.gps_last] = add64(c.gps_time[c.gps_last], d);
        c.gps_extreme[c.gps_last] = 0;
      } else if (s < kMultiCodeFull) {
        std::int32_t d;
        if (s == 0) {
          d = integer(kGpsTime, c.gps, 0, diff, 7);
          gps_extreme(c, d);
        } else if (s < static_cast<std::uint32_t>(kMulti)) {
          d = integer(kGpsTime, c.gps, wrap32(std::int64_t{static_cast<std::int32_t>(s)} * last_diff), diff, s < 10 ? 2 : 3);
        } else if (s == static_cast<std::uint32_t>(kMulti)) {
          d = integer(kGpsTime, c.gps, wrap32(std::int64_t{kMulti} * last_diff), diff, 4);
          gps_extreme(c, d);
        } else {
          const std::int32_t negative = kMulti - static_cast<std::int32_t>(s);
          if (negative > kMultiMinus) {
            d = integer(kGpsTime, c.gps, wrap32(std::int64_t{negative} * last_diff), diff, 5);
          } else {
            d = integer(kGpsTime, c.gps, wrap32(std::int64_t{kMultiMinus} * last_diff), diff, 6);
            gps_extreme(c, d);
          }
        }
        c.gps_time[c.gps_last] = add64(c.gps_time[c.gps_last], d);
      } else if (s == kMultiCodeFull) {
        gps_new_sequence(c, time);
      } else {
        c.gps_last = (c.gps_last + s - kMultiCodeFull) & 3;
        continue;
      }
      return;
    }
  }

  // Codes the record after the chunk's first (`record`: encoding only; decoding writes it).
  void code(const std::uint8_t* in_record, std::uint8_t* out_record) {
    Point14 item;
    std::array<std::uint16_t, 4> colour{};
    std::vector<std::uint8_t> bytes;
    if (encoding) split(in_record, item, colour, bytes);

    Context* c = &*contexts[current];
    bool switched = false;
    {
      const Point14& previous = c->last;  // the directly previous point
      const unsigned lpr = (previous.r == 1 ? 1u : 0u) + (previous.r >= previous.n ? 2u : 0u) + (previous.gps_change ? 4u : 0u);
      std::uint32_t changed = 0;
      if (encoding) {
        const Point14& last = item.channel != current && contexts[item.channel] ? contexts[item.channel]->last : previous;
        changed = (item.channel != current ? 64u : 0u) | (last.source_id != item.source_id ? 32u : 0u) |
                  (last.gps != item.gps ? 16u : 0u) | (last.scan_angle != item.scan_angle ? 8u : 0u) |
                  (last.n != item.n ? 4u : 0u);
        if (item.r != last.r) changed |= item.r == ((last.r + 1) & 15) ? 1u : item.r == ((last.r + 15) & 15) ? 2u : 3u;
      }
      changed_ = symbol(kXY, c->changed_values[lpr], changed);
      if (changed_ & 64) {
        const std::uint32_t step = symbol(kXY, c->scanner_channel, encoding ? ((item.channel + 4 - current) & 3) - 1 : 0);
        const unsigned channel = (current + step + 1) & 3;
        if (!contexts[channel]) contexts[channel].emplace(c->last);
        current = channel;
        c = &*contexts[current];
        switched = true;
        c->last.channel = channel;
      }
    }
    Point14& last = c->last;
    const bool source_change = (changed_ & 32) != 0, gps_change = (changed_ & 16) != 0, angle_change = (changed_ & 8) != 0;
    const unsigned last_n = last.n, last_r = last.r;
    if (changed_ & 4) last.n = symbol(kXY, lazy(c->number_of_returns[last_n], 16), item.n);
    const unsigned n = last.n;
    switch (changed_ & 3) {
      case 1: last.r = (last_r + 1) & 15; break;
      case 2: last.r = (last_r + 15) & 15; break;
      case 3:
        if (gps_change) {
          last.r = symbol(kXY, lazy(c->return_number[last_r], 16), item.r);
        } else {
          const std::uint32_t step = symbol(kXY, c->return_number_gps_same, encoding ? (item.r + 32 - last_r - 2) & 15 : 0);
          last.r = (last_r + step + 2) & 15;
        }
        break;
      default: break;
    }
    const unsigned r = last.r;
    const unsigned m = kReturnMap6[n][r], l = kReturnLevel8[n][r];
    const unsigned cpr = (r == 1 ? 2u : 0u) + (r >= n ? 1u : 0u);
    const unsigned slot = (m << 1) | (gps_change ? 1u : 0u);

    std::int32_t diff = integer(kXY, c->dx, c->median_x[slot].get(), wrap_sub(item.x, last.x), n == 1 ? 1 : 0);
    last.x = static_cast<std::int32_t>(static_cast<std::uint32_t>(last.x) + static_cast<std::uint32_t>(diff));
    c->median_x[slot].add(diff);
    unsigned k = c->dx.k();
    diff = integer(kXY, c->dy, c->median_y[slot].get(), wrap_sub(item.y, last.y), (n == 1 ? 1u : 0u) + (k < 20 ? (k & ~1u) : 20u));
    last.y = static_cast<std::int32_t>(static_cast<std::uint32_t>(last.y) + static_cast<std::uint32_t>(diff));
    c->median_y[slot].add(diff);

    if (active(kZ)) {
      k = (c->dx.k() + c->dy.k()) / 2;
      const std::int32_t z = integer(kZ, c->z, c->last_z[l], item.z, (n == 1 ? 1u : 0u) + (k < 18 ? (k & ~1u) : 18u));
      if (z != last.z) layers[kZ].changed = true;
      last.z = c->last_z[l] = z;
    }
    if (active(kClass)) {
      const unsigned context = ((last.classification & 0x1f) << 1) + (cpr == 3 ? 1u : 0u);
      const unsigned value = symbol(kClass, lazy(c->classification[context], 256), item.classification);
      if (value != last.classification) layers[kClass].changed = true;
      last.classification = value;
    }
    if (active(kFlags)) {
      const unsigned last_flags = (last.edge << 5) | (last.scan_direction << 4) | last.class_flags;
      const unsigned flags = symbol(kFlags, lazy(c->flags[last_flags], 64), (item.edge << 5) | (item.scan_direction << 4) | item.class_flags);
      if (flags != last_flags) layers[kFlags].changed = true;
      last.edge = (flags >> 5) & 1u;
      last.scan_direction = (flags >> 4) & 1u;
      last.class_flags = flags & 15u;
    }
    if (active(kIntensity)) {
      const unsigned at = (cpr << 1) | (gps_change ? 1u : 0u);
      const auto value = static_cast<std::uint16_t>(integer(kIntensity, c->intensity, c->last_intensity[at], item.intensity, cpr));
      c->last_intensity[at] = value;
      if (value != last.intensity) layers[kIntensity].changed = true;
      last.intensity = value;
    }
    if (active(kScanAngle) && angle_change) {
      last.scan_angle = static_cast<std::int16_t>(integer(kScanAngle, c->scan_angle, last.scan_angle, item.scan_angle, gps_change ? 1 : 0));
      layers[kScanAngle].changed = true;
    }
    if (active(kUserData)) {
      const unsigned value = symbol(kUserData, lazy(c->user_data[last.user_data / 4], 256), item.user_data);
      if (value != last.user_data) layers[kUserData].changed = true;
      last.user_data = value;
    }
    if (active(kSourceId) && source_change) {
      last.source_id = static_cast<std::uint16_t>(integer(kSourceId, c->source_id, last.source_id, item.source_id, 0));
      layers[kSourceId].changed = true;
    }
    if (active(kGpsTime) && gps_change) {
      code_gps(*c, item.gps);
      last.gps = c->gps_time[c->gps_last];
      layers[kGpsTime].changed = true;
    }
    last.gps_change = gps_change;

    // The colours and extra bytes: LASzip hands these items the new scanner channel at a
    // switch and channel 0 at every other point, and each item predicts from the values of
    // the context it last used unless the context is new (then from a copy of them). Every
    // LAZ reader and writer must do the same to read the same points.
    const unsigned item_channel = switched ? current : 0;
    ItemContext* v = &*item_contexts[item_current];
    if (item_channel != item_current) {
      item_current = item_channel;
      if (!item_contexts[item_channel]) {
        item_contexts[item_channel].emplace(v->last_colour, v->last_bytes);
        v = &*item_contexts[item_channel];
      }
    }
    ItemContext* ic = &*item_contexts[item_current];

    if (has_rgb() && active(rgb_layer())) {
      const Rgb previous{v->last_colour[0], v->last_colour[1], v->last_colour[2]};
      Rgb rgb{colour[0], colour[1], colour[2]};
      if (encoding) {
        encode_rgb(*layers[rgb_layer()].encoder, ic->rgb, previous, rgb);
      } else {
        rgb = decode_rgb(*layers[rgb_layer()].decoder, ic->rgb, previous);
      }
      if (rgb != previous) layers[rgb_layer()].changed = true;
      for (int k2 = 0; k2 < 3; ++k2) v->last_colour[k2] = rgb[k2];
    }
    if (has_nir() && active(nir_layer())) {
      const unsigned last_low = v->last_colour[3] & 0xffu, last_high = v->last_colour[3] >> 8;
      const std::uint32_t used = symbol(nir_layer(), ic->nir_used,
                                        ((colour[3] & 0xffu) != last_low ? 1u : 0u) | ((colour[3] >> 8) != last_high ? 2u : 0u));
      unsigned low = last_low, high = last_high;
      if (used & 1) low = (symbol(nir_layer(), ic->nir_low, ((colour[3] & 0xffu) - last_low) & 0xffu) + last_low) & 0xffu;
      if (used & 2) high = (symbol(nir_layer(), ic->nir_high, ((colour[3] >> 8) - last_high) & 0xffu) + last_high) & 0xffu;
      if (used != 0) layers[nir_layer()].changed = true;
      v->last_colour[3] = static_cast<std::uint16_t>(low | (high << 8));
    }
    for (std::size_t i = 0; i < extra; ++i) {
      if (!active(byte_layer(i))) continue;
      const std::uint32_t delta = symbol(byte_layer(i), ic->byte_models[i], encoding ? static_cast<std::uint8_t>(bytes[i] - v->last_bytes[i]) : 0u);
      if (delta != 0) layers[byte_layer(i)].changed = true;
      v->last_bytes[i] = static_cast<std::uint8_t>(v->last_bytes[i] + delta);
    }
    if (out_record != nullptr) join(c->last, *v, out_record);
  }

  std::uint32_t changed_ = 0;
};

Layered14Codec::Layered14Codec(int point_format, std::size_t extra_bytes) : state_(std::make_unique<State>()) {
  assert(point_format >= 6 && point_format <= 8);
  state_->point_format = point_format;
  state_->extra = extra_bytes;
}

Layered14Codec::~Layered14Codec() = default;

std::size_t Layered14Codec::layer_count() const { return state_->layer_count(); }

void Layered14Codec::start_decoding(const std::uint8_t* record, std::vector<std::vector<std::uint8_t>> layers) {
  State& s = *state_;
  assert(layers.size() == s.layer_count());
  s.encoding = false;
  s.layers.clear();
  s.layers.resize(layers.size());
  for (std::size_t i = 0; i < layers.size(); ++i) {
    if (layers[i].empty()) continue;
    s.layers[i].in = std::make_unique<ChunkBytes>(std::move(layers[i]));
    s.layers[i].decoder.emplace(*s.layers[i].in);
    s.layers[i].decoder->start();
  }
  s.start(record);
}

void Layered14Codec::decode(std::uint8_t* record) {
  // The returns and XY layer is never empty when there is more than one point.
  if (!state_->layers[kXY].decoder) throw ChunkOverrun{};
  state_->code(nullptr, record);
}

void Layered14Codec::start_encoding(const std::uint8_t* record) {
  State& s = *state_;
  s.encoding = true;
  s.layers.clear();
  s.layers.resize(s.layer_count());
  for (Layer& layer : s.layers) layer.encoder.emplace(layer.out);
  s.start(record);
}

void Layered14Codec::encode(const std::uint8_t* record) { state_->code(record, nullptr); }

std::vector<std::vector<std::uint8_t>> Layered14Codec::finish_encoding() {
  State& s = *state_;
  std::vector<std::vector<std::uint8_t>> out(s.layers.size());
  for (std::size_t i = 0; i < s.layers.size(); ++i) {
    Layer& layer = s.layers[i];
    // The returns and XY layer is always stored; the others only when something changed.
    if (i != kXY && !layer.changed) continue;
    layer.encoder->finish();
    out[i] = std::move(layer.out);
  }
  return out;
}

}  // namespace pointfair::io::laz
