#include "laz/laszip_vlr.hpp"

#include <cstring>

#include "io_error.hpp"

namespace pointfair::io::laz {

namespace fs = std::filesystem;

namespace {

template <typename T>
T load(std::string_view data, std::size_t at) {
  T value;
  std::memcpy(&value, data.data() + at, sizeof(T));
  return value;  // little endian (LAS headers are read the same way)
}

template <typename T>
void put(std::string& out, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  out.append(bytes, sizeof(T));
}

constexpr std::size_t kFixedSize = 34;
constexpr std::size_t kItemSize = 6;

}  // namespace

std::string item_name(ItemType type) {
  switch (type) {
    case ItemType::Byte: return "BYTE";
    case ItemType::Point10: return "POINT10";
    case ItemType::GpsTime11: return "GPSTIME11";
    case ItemType::Rgb12: return "RGB12";
    case ItemType::WavePacket13: return "WAVEPACKET13";
    case ItemType::Point14: return "POINT14";
    case ItemType::Rgb14: return "RGB14";
    case ItemType::RgbNir14: return "RGBNIR14";
    case ItemType::WavePacket14: return "WAVEPACKET14";
    case ItemType::Byte14: return "BYTE14";
  }
  return "type " + std::to_string(static_cast<unsigned>(type));
}

LaszipInfo parse_laszip_vlr(const fs::path& file, std::string_view data) {
  if (data.size() < kFixedSize) {
    detail::fail(file, "the LASzip VLR has " + std::to_string(data.size()) + " bytes, fewer than its " +
                           std::to_string(kFixedSize) + " fixed ones");
  }
  LaszipInfo info;
  info.compressor = load<std::uint16_t>(data, 0);
  info.coder = load<std::uint16_t>(data, 2);
  info.version_major = load<std::uint8_t>(data, 4);
  info.version_minor = load<std::uint8_t>(data, 5);
  info.version_revision = load<std::uint16_t>(data, 6);
  info.options = load<std::uint32_t>(data, 8);
  info.chunk_size = load<std::uint32_t>(data, 12);
  info.special_evlr_count = load<std::int64_t>(data, 16);
  info.special_evlr_offset = load<std::int64_t>(data, 24);
  const std::size_t count = load<std::uint16_t>(data, 32);
  if (data.size() != kFixedSize + kItemSize * count) {
    detail::fail(file, "the LASzip VLR lists " + std::to_string(count) + " items in " + std::to_string(data.size()) +
                           " bytes (expected " + std::to_string(kFixedSize + kItemSize * count) + ")");
  }
  for (std::size_t i = 0; i < count; ++i) {
    const std::size_t at = kFixedSize + kItemSize * i;
    info.items.push_back({static_cast<ItemType>(load<std::uint16_t>(data, at)), load<std::uint16_t>(data, at + 2),
                          load<std::uint16_t>(data, at + 4)});
  }
  return info;
}

std::string serialize_laszip_vlr(const LaszipInfo& info) {
  std::string out;
  put(out, info.compressor);
  put(out, info.coder);
  put(out, info.version_major);
  put(out, info.version_minor);
  put(out, info.version_revision);
  put(out, info.options);
  put(out, info.chunk_size);
  put(out, info.special_evlr_count);
  put(out, info.special_evlr_offset);
  put(out, static_cast<std::uint16_t>(info.items.size()));
  for (const LazItem& item : info.items) {
    put(out, static_cast<std::uint16_t>(item.type));
    put(out, item.size);
    put(out, item.version);
  }
  return out;
}

LaszipInfo laszip_info_for(int point_format, std::size_t record_length, std::uint32_t chunk_size) {
  LaszipInfo info;
  info.chunk_size = chunk_size;
  if (point_format >= 6) {
    info.compressor = kLayeredChunked;
    std::size_t used = 30;
    info.items.push_back({ItemType::Point14, 30, 3});
    if (point_format == 7) {
      info.items.push_back({ItemType::Rgb14, 6, 3});
      used += 6;
    } else if (point_format == 8) {
      info.items.push_back({ItemType::RgbNir14, 8, 3});
      used += 8;
    }
    if (record_length > used) info.items.push_back({ItemType::Byte14, static_cast<std::uint16_t>(record_length - used), 3});
    return info;
  }
  std::size_t used = 20;
  info.items.push_back({ItemType::Point10, 20, 2});
  if (point_format == 1 || point_format == 3) {
    info.items.push_back({ItemType::GpsTime11, 8, 2});
    used += 8;
  }
  if (point_format == 2 || point_format == 3) {
    info.items.push_back({ItemType::Rgb12, 6, 2});
    used += 6;
  }
  if (record_length > used) info.items.push_back({ItemType::Byte, static_cast<std::uint16_t>(record_length - used), 2});
  return info;
}

void require_decodable(const fs::path& file, const LaszipInfo& info, int point_format, std::size_t record_length) {
  if (info.coder != 0) detail::fail(file, "LAZ coder " + std::to_string(info.coder) + " is unknown (0: arithmetic)");
  if (point_format == 4 || point_format == 5 || point_format > 8) {
    detail::fail(file, "LAZ of point format " + std::to_string(point_format) +
                           " (with wave packets) is not supported; formats 0-3 and 6-8 are");
  }
  const bool layered = point_format >= 6;
  const std::uint16_t compressor = layered ? kLayeredChunked : kPointwiseChunked;
  if (info.compressor != compressor) {
    detail::fail(file, "LAZ compressor " + std::to_string(info.compressor) +
                           (info.compressor == 1 ? " (pointwise, from LASzip 1.x)" : "") + " is not supported for point format " +
                           std::to_string(point_format) + " (only " + std::to_string(compressor) +
                           (layered ? ": layered in chunks)" : ": pointwise in chunks)"));
  }
  const std::uint16_t version = layered ? 3 : 2;
  std::size_t size = 0;
  for (const LazItem& item : info.items) {
    const bool known = layered ? item.type == ItemType::Point14 || item.type == ItemType::Rgb14 ||
                                     item.type == ItemType::RgbNir14 || item.type == ItemType::Byte14
                               : item.type == ItemType::Point10 || item.type == ItemType::GpsTime11 ||
                                     item.type == ItemType::Rgb12 || item.type == ItemType::Byte;
    if (!known) detail::fail(file, "LAZ item " + item_name(item.type) + " is not supported for point format " + std::to_string(point_format));
    if (item.version != version) {
      detail::fail(file, "LAZ item " + item_name(item.type) + " version " + std::to_string(item.version) +
                             " is not supported (only version " + std::to_string(version) + ")");
    }
    size += item.size;
  }
  const LaszipInfo expected = laszip_info_for(point_format, record_length, info.chunk_size);
  bool same = expected.items.size() == info.items.size();
  for (std::size_t i = 0; same && i < info.items.size(); ++i) {
    same = expected.items[i].type == info.items[i].type && expected.items[i].size == info.items[i].size;
  }
  if (!same) {
    std::string list;
    for (const LazItem& item : info.items) list += (list.empty() ? "" : ", ") + item_name(item.type) + "/" + std::to_string(item.size);
    detail::fail(file, "the LAZ items (" + list + ", " + std::to_string(size) + " bytes) do not make up point format " +
                           std::to_string(point_format) + " records of " + std::to_string(record_length) + " bytes");
  }
  if (info.chunk_size == 0) detail::fail(file, "the LASzip VLR gives a chunk size of 0 points");
}

}  // namespace pointfair::io::laz
