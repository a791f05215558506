#pragma once
// One compressed item of a LAZ point (LASzip's "items": POINT10, GPSTIME11, RGB12, BYTE,
// ...). The record of a point is its items' bytes one after another, in LAS order. In a
// pointwise-chunked file the first point of each chunk is stored raw and starts every
// item's context (start()); each later point is coded from the items' state.
#include <cstdint>
#include <memory>

#include "laz/arithmetic_coder.hpp"
#include "laz/laszip_vlr.hpp"

namespace pointfair::io::laz {

class ItemCodec {
 public:
  virtual ~ItemCodec() = default;
  /// Resets the models and takes `item` (the chunk's first point, stored raw) as the last.
  virtual void start(const std::uint8_t* item) = 0;
  /// Decodes the next item into `item`.
  virtual void decode(ArithmeticDecoder& decoder, std::uint8_t* item) = 0;
  /// Encodes `item`.
  virtual void encode(ArithmeticEncoder& encoder, const std::uint8_t* item) = 0;
};

/// Version 2 codecs (LASzip 2.0, point formats 0-5 of LAS 1.0-1.3): POINT10 (the 20 bytes
/// every format 0-5 record starts with), GPSTIME11 (the 8-byte GPS time), RGB12 (three
/// 16-bit colours), and BYTE (`size` extra bytes, each coded from the previous point's).
std::unique_ptr<ItemCodec> make_point10_v2();
std::unique_ptr<ItemCodec> make_gpstime11_v2();
std::unique_ptr<ItemCodec> make_rgb12_v2();
std::unique_ptr<ItemCodec> make_byte_v2(std::size_t size);

/// The version 2 codec of `item` (POINT10, GPSTIME11, RGB12, else BYTE): what a pointwise
/// chunk's reader and writer both run (require_decodable has refused every other type).
inline std::unique_ptr<ItemCodec> make_item_codec_v2(const LazItem& item) {
  switch (item.type) {
    case ItemType::Point10: return make_point10_v2();
    case ItemType::GpsTime11: return make_gpstime11_v2();
    case ItemType::Rgb12: return make_rgb12_v2();
    default: return make_byte_v2(item.size);
  }
}

}  // namespace pointfair::io::laz
