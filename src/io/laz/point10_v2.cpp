// POINT10 item, version 2: the 20 bytes X, Y, Z (int32), intensity, the return byte,
// classification, scan angle rank, user data, point source id. A 6-bit symbol says which of
// the return byte, intensity, classification, scan angle, user data and source id changed;
// each changed one is coded in a context of the previous value or the return. X and Y are
// coded as differences predicted by the median of the last five differences of the same
// return type, Z from the last Z of the same return level; the contexts of Y and Z include
// the bit lengths of the X (and Y) correctors.
#include <array>
#include <cstring>
#include <memory>
#include <optional>

#include "laz/integer_coder.hpp"
#include "laz/item_codec.hpp"
#include "laz/median5.hpp"

namespace pointfair::io::laz {

namespace {

// The return type (number of returns n, return number r, both 0..7) as one of 16 kinds.
constexpr std::uint8_t kReturnMap[8][8] = {
    {15, 14, 13, 12, 11, 10, 9, 8},  {14, 0, 1, 3, 6, 10, 10, 9},    {13, 1, 2, 4, 7, 11, 11, 10},
    {12, 3, 4, 5, 8, 12, 12, 11},    {11, 6, 7, 8, 9, 13, 13, 12},   {10, 10, 11, 12, 13, 14, 14, 13},
    {9, 10, 11, 12, 13, 14, 15, 14}, {8, 9, 10, 11, 12, 13, 14, 15}};
// |n - r|: the return level.
constexpr std::uint8_t return_level(unsigned n, unsigned r) { return static_cast<std::uint8_t>(n > r ? n - r : r - n); }

std::int32_t load32(const std::uint8_t* p) {
  std::int32_t v;
  std::memcpy(&v, p, 4);
  return v;
}
void store32(std::int32_t v, std::uint8_t* p) { std::memcpy(p, &v, 4); }
std::uint16_t load16(const std::uint8_t* p) { return static_cast<std::uint16_t>(p[0] | (p[1] << 8)); }
void store16(std::uint16_t v, std::uint8_t* p) {
  p[0] = static_cast<std::uint8_t>(v);
  p[1] = static_cast<std::uint8_t>(v >> 8);
}

// Byte offsets in the item.
constexpr int kIntensity = 12, kReturnByte = 14, kClass = 15, kScanAngle = 16, kUserData = 17, kSourceId = 18;

// Contexts of Y and Z from the bit length of the X (and Y) correctors.
unsigned y_context(unsigned n, unsigned k) { return (n == 1 ? 1u : 0u) + (k < 20 ? (k & ~1u) : 20u); }
unsigned z_context(unsigned n, unsigned k) { return (n == 1 ? 1u : 0u) + (k < 18 ? (k & ~1u) : 18u); }

class Point10V2 final : public ItemCodec {
 public:
  void start(const std::uint8_t* item) override {
    changed_ = std::make_unique<SymbolModel>(64);
    intensity_ = IntegerCoder(16, 4);
    scan_angle_[0] = std::make_unique<SymbolModel>(256);
    scan_angle_[1] = std::make_unique<SymbolModel>(256);
    source_id_ = IntegerCoder(16);
    for (auto& m : bit_byte_) m.reset();
    for (auto& m : classification_) m.reset();
    for (auto& m : user_data_) m.reset();
    dx_ = IntegerCoder(32, 2);
    dy_ = IntegerCoder(32, 22);
    z_ = IntegerCoder(32, 20);
    for (int i = 0; i < 16; ++i) {
      median_x_[i].reset();
      median_y_[i].reset();
      last_intensity_[i] = 0;
    }
    last_height_.fill(0);
    std::memcpy(last_.data(), item, 20);
    // The intensity is predicted from last_intensity_ (0 at the start), never from the raw point.
    store16(0, last_.data() + kIntensity);
  }

  void decode(ArithmeticDecoder& d, std::uint8_t* item) override {
    std::uint8_t* last = last_.data();
    const std::uint32_t changed = d.decode_symbol(*changed_);
    unsigned r, n, m, l;
    if (changed != 0) {
      if (changed & 32) last[kReturnByte] = static_cast<std::uint8_t>(d.decode_symbol(model(bit_byte_, last[kReturnByte])));
      r = last[kReturnByte] & 7;
      n = (last[kReturnByte] >> 3) & 7;
      m = kReturnMap[n][r];
      l = return_level(n, r);
      if (changed & 16) {
        const auto intensity = static_cast<std::uint16_t>(intensity_.decompress(d, last_intensity_[m], m < 3 ? m : 3));
        last_intensity_[m] = intensity;
        store16(intensity, last + kIntensity);
      } else {
        store16(last_intensity_[m], last + kIntensity);
      }
      if (changed & 8) last[kClass] = static_cast<std::uint8_t>(d.decode_symbol(model(classification_, last[kClass])));
      if (changed & 4) {
        const std::uint32_t delta = d.decode_symbol(*scan_angle_[(last[kReturnByte] >> 6) & 1]);
        last[kScanAngle] = static_cast<std::uint8_t>(delta + last[kScanAngle]);
      }
      if (changed & 2) last[kUserData] = static_cast<std::uint8_t>(d.decode_symbol(model(user_data_, last[kUserData])));
      if (changed & 1) {
        store16(static_cast<std::uint16_t>(source_id_.decompress(d, load16(last + kSourceId), 0)), last + kSourceId);
      }
    } else {
      r = last[kReturnByte] & 7;
      n = (last[kReturnByte] >> 3) & 7;
      m = kReturnMap[n][r];
      l = return_level(n, r);
    }
    std::int32_t diff = dx_.decompress(d, median_x_[m].get(), n == 1 ? 1 : 0);
    store32(wrap_add(load32(last), diff), last);
    median_x_[m].add(diff);
    diff = dy_.decompress(d, median_y_[m].get(), y_context(n, dx_.k()));
    store32(wrap_add(load32(last + 4), diff), last + 4);
    median_y_[m].add(diff);
    const std::int32_t z = z_.decompress(d, last_height_[l], z_context(n, (dx_.k() + dy_.k()) / 2));
    store32(z, last + 8);
    last_height_[l] = z;
    std::memcpy(item, last, 20);
  }

  void encode(ArithmeticEncoder& e, const std::uint8_t* item) override {
    std::uint8_t* last = last_.data();
    const unsigned r = item[kReturnByte] & 7;
    const unsigned n = (item[kReturnByte] >> 3) & 7;
    const unsigned m = kReturnMap[n][r];
    const unsigned l = return_level(n, r);
    const std::uint16_t intensity = load16(item + kIntensity);
    const std::uint32_t changed = (last[kReturnByte] != item[kReturnByte] ? 32u : 0u) |
                                  (last_intensity_[m] != intensity ? 16u : 0u) |
                                  (last[kClass] != item[kClass] ? 8u : 0u) |
                                  (last[kScanAngle] != item[kScanAngle] ? 4u : 0u) |
                                  (last[kUserData] != item[kUserData] ? 2u : 0u) |
                                  (load16(last + kSourceId) != load16(item + kSourceId) ? 1u : 0u);
    e.encode_symbol(*changed_, changed);
    if (changed & 32) e.encode_symbol(model(bit_byte_, last[kReturnByte]), item[kReturnByte]);
    if (changed & 16) {
      intensity_.compress(e, last_intensity_[m], intensity, m < 3 ? m : 3);
      last_intensity_[m] = intensity;
    }
    if (changed & 8) e.encode_symbol(model(classification_, last[kClass]), item[kClass]);
    if (changed & 4) {
      e.encode_symbol(*scan_angle_[(item[kReturnByte] >> 6) & 1], static_cast<std::uint8_t>(item[kScanAngle] - last[kScanAngle]));
    }
    if (changed & 2) e.encode_symbol(model(user_data_, last[kUserData]), item[kUserData]);
    if (changed & 1) source_id_.compress(e, load16(last + kSourceId), load16(item + kSourceId), 0);

    std::int32_t diff = wrap_sub(load32(item), load32(last));
    dx_.compress(e, median_x_[m].get(), diff, n == 1 ? 1 : 0);
    median_x_[m].add(diff);
    diff = wrap_sub(load32(item + 4), load32(last + 4));
    dy_.compress(e, median_y_[m].get(), diff, y_context(n, dx_.k()));
    median_y_[m].add(diff);
    const std::int32_t z = load32(item + 8);
    z_.compress(e, last_height_[l], z, z_context(n, (dx_.k() + dy_.k()) / 2));
    last_height_[l] = z;
    std::memcpy(last, item, 20);
  }

 private:
  static std::int32_t wrap_add(std::int32_t a, std::int32_t b) {
    return static_cast<std::int32_t>(static_cast<std::uint32_t>(a) + static_cast<std::uint32_t>(b));
  }
  static std::int32_t wrap_sub(std::int32_t a, std::int32_t b) {
    return static_cast<std::int32_t>(static_cast<std::uint32_t>(a) - static_cast<std::uint32_t>(b));
  }
  // The model of a byte given its previous value, created when first needed.
  static SymbolModel& model(std::array<std::optional<SymbolModel>, 256>& models, std::uint8_t previous) {
    std::optional<SymbolModel>& slot = models[previous];
    if (!slot) slot.emplace(256);
    return *slot;
  }

  std::unique_ptr<SymbolModel> changed_;
  IntegerCoder intensity_, source_id_, dx_, dy_, z_;
  std::array<std::unique_ptr<SymbolModel>, 2> scan_angle_;
  std::array<std::optional<SymbolModel>, 256> bit_byte_, classification_, user_data_;
  std::array<Median5, 16> median_x_, median_y_;
  std::array<std::uint16_t, 16> last_intensity_{};
  std::array<std::int32_t, 8> last_height_{};
  std::array<std::uint8_t, 20> last_{};
};

}  // namespace

std::unique_ptr<ItemCodec> make_point10_v2() { return std::make_unique<Point10V2>(); }

}  // namespace pointfair::io::laz
