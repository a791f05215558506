#pragma once
// The LASzip VLR ("laszip encoded", record 22204) of a LAZ file: the compressor, the chunk
// size and the items each point record is made of, with their codec versions.
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace pointfair::io::laz {

constexpr std::string_view kLaszipUserId = "laszip encoded";
constexpr std::uint16_t kLaszipRecordId = 22204;

/// Item types of the LASzip VLR.
enum class ItemType : std::uint16_t {
  Byte = 0,
  Point10 = 6,
  GpsTime11 = 7,
  Rgb12 = 8,
  WavePacket13 = 9,
  Point14 = 10,
  Rgb14 = 11,
  RgbNir14 = 12,
  WavePacket14 = 13,
  Byte14 = 14,
};

struct LazItem {
  ItemType type;
  std::uint16_t size;     // bytes of the item in the record
  std::uint16_t version;  // codec version
};

/// Compressors: 0 none, 1 pointwise (LASzip 1.x), 2 pointwise in chunks, 3 layered in chunks.
constexpr std::uint16_t kPointwiseChunked = 2;
constexpr std::uint16_t kLayeredChunked = 3;
/// A chunk size of 2^32-1 means chunks of varying sizes, each given in the chunk table.
constexpr std::uint32_t kVariableChunkSize = 0xffffffffu;

struct LaszipInfo {
  std::uint16_t compressor = kPointwiseChunked;
  std::uint16_t coder = 0;  // 0: arithmetic
  std::uint8_t version_major = 3, version_minor = 4;
  std::uint16_t version_revision = 3;
  std::uint32_t options = 0;
  std::uint32_t chunk_size = 50000;
  std::int64_t special_evlr_count = -1, special_evlr_offset = -1;
  std::vector<LazItem> items;
};

/// Parses the VLR's payload. Throws IoError "<file>: ..." when it is malformed.
LaszipInfo parse_laszip_vlr(const std::filesystem::path& file, std::string_view data);
std::string serialize_laszip_vlr(const LaszipInfo& info);

/// The items of a point format 0-3 record of `record_length` bytes (version 2 codecs; the
/// bytes after the format's fields are one BYTE item), or of a format 6-8 one (version 3,
/// layered: POINT14, RGB14 or RGBNIR14, BYTE14).
LaszipInfo laszip_info_for(int point_format, std::size_t record_length, std::uint32_t chunk_size);

/// Throws IoError "<file>: ..." naming what this reader cannot decode: another compressor
/// or coder, an item type or version without a codec here, or items that do not make up
/// the records of `point_format` and `record_length`.
void require_decodable(const std::filesystem::path& file, const LaszipInfo& info, int point_format,
                       std::size_t record_length);

/// "POINT10", "GPSTIME11", ... as LASzip names the item types.
std::string item_name(ItemType type);

}  // namespace pointfair::io::laz
