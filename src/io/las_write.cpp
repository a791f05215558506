// LAS writer: plans the whole file (format, quantization, fields, extra bytes, records)
// and checks it before the output is created, then writes header, VLRs, points and EVLRs.
// A .laz name compresses the records as LAZ (laz/point_writer.hpp); all else is the same.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <ctime>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "io_error.hpp"
#include "las_format.hpp"
#include "laz/laszip_vlr.hpp"
#include "laz/point_writer.hpp"
#include "number_text.hpp"
#include "pointfair/io/atomic_file.hpp"
#include "pointfair/io/las.hpp"
#include "table_checks.hpp"

namespace pointfair::io {

namespace fs = std::filesystem;
using namespace detail;

namespace {

constexpr std::size_t kBlockBytes = std::size_t{4} << 20;
constexpr double kInt32Max = 2147483647.0;
// Scan angle units of formats 6-10, in degrees.
constexpr double kScanAngleUnit = 0.006;

// One value written per record: a standard field or an extra column.
struct Column {
  const Attribute* source = nullptr;  // nullptr: `fallback`
  double factor = 1;                  // applied to the source (scan angle conversion)
  double fallback = 0;
  LasStorage storage = LasStorage::U8;
  std::size_t offset = 0;
  unsigned shift = 0;
  unsigned bits = 0;
};

struct Plan {
  LasHeader header;
  std::vector<Column> columns;
  std::vector<LasRecord> vlrs, evlrs;
  // A version was asked for: bit fields are checked, not clipped (check_bit_fields).
  bool strict_fields = false;
  // LAZ: how the records are compressed (the LASzip VLR's payload).
  std::optional<laz::LaszipInfo> laz;
};

bool has_laz_extension(const fs::path& file) {
  std::string extension = file.extension().string();
  for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return extension == ".laz";
}

// Fields of LAS 1.2's formats 0-3 that hold whatever a 1.4 format would: an attribute of
// any other name (return counts, classes and scan angles, whose 1.2 fields are narrower;
// normals and other extra bytes, which 1.2 does not describe) needs LAS 1.4.
constexpr std::string_view kLegacyFields[] = {
    "intensity", "scan_direction_flag", "edge_of_flight_line", "synthetic", "key_point", "withheld",
    "user_data", "point_source_id", "gps_time", "red", "green", "blue"};

bool fits_legacy(const PointTable& table) {
  return std::all_of(table.attributes.begin(), table.attributes.end(), [](const Attribute& a) {
    return std::find(std::begin(kLegacyFields), std::end(kLegacyFields), a.name) != std::end(kLegacyFields);
  });
}

// Formats 0-3 of LAS 1.2: 1 and 3 with GPS time, 2 and 3 with colours.
int choose_legacy_format(const PointTable& table) {
  const bool gps = table.find("gps_time") != nullptr;
  const bool rgb = table.find("red") || table.find("green") || table.find("blue");
  return (gps ? 1 : 0) + (rgb ? 2 : 0);
}

int choose_format(const PointTable& table) {
  auto any = [&](std::initializer_list<std::string_view> names) {
    return std::any_of(names.begin(), names.end(), [&](std::string_view n) { return table.find(n) != nullptr; });
  };
  const bool rgb = any({"red", "green", "blue"});
  const bool nir = any({"nir"});
  const bool wave = any({"wave_packet_index", "wave_data_offset", "wave_packet_size", "return_point_location",
                         "x_t", "y_t", "z_t"});
  if (wave) return rgb || nir ? 10 : 9;
  if (nir) return 8;
  return rgb ? 7 : 6;
}

// See las_quantization_for.
PositionQuantization bounds_quantization(const std::vector<Vec3>& positions) {
  if (positions.empty()) return PositionQuantization{};
  Vec3 lo = positions[0], hi = positions[0];
  for (const Vec3& p : positions) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  return las_quantization_for(lo, hi);
}

// The grid of write_las: the options' scale and offset over the table's or the bounds'.
PositionQuantization choose_quantization(const PointTable& table, const LasWriteOptions& options) {
  PositionQuantization q = table.quantization ? *table.quantization : bounds_quantization(table.positions);
  if (options.scale) q.scale = *options.scale;
  if (options.offset) q.offset = *options.offset;
  return q;
}

}  // namespace

PositionQuantization las_quantization_for(const Vec3& lo, const Vec3& hi) {
  PositionQuantization q;
  double largest = 0.0;
  for (int a = 0; a < 3; ++a) {
    q.offset[a] = std::floor(lo[a]);
    largest = std::max(largest, hi[a] - q.offset[a]);
  }
  // A million steps or more across the largest extent, at most 1e-3 (a millimetre for
  // metres), at least 1e-9; coarser only where the extent would not fit in int32.
  int exponent = largest > 0.0 ? static_cast<int>(std::floor(std::log10(largest / 1e6))) : -3;
  exponent = std::clamp(exponent, -9, -3);
  // 0.99: leaves room for the rounding of (x - offset) / scale.
  while (largest / std::pow(10.0, exponent) > 0.99 * kInt32Max) ++exponent;
  q.scale = Vec3::Constant(std::pow(10.0, exponent));
  return q;
}

namespace {

std::uint16_t today_day_of_year(std::uint16_t& year) {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  year = static_cast<std::uint16_t>(utc.tm_year + 1900);
  return static_cast<std::uint16_t>(utc.tm_yday + 1);
}

// The extra attributes in order; reuses the source's descriptors when they still match.
void plan_extra_bytes(const fs::path& file, const LasMetadata* source, const std::vector<const Attribute*>& extras,
                      Plan& plan, std::string& descriptors) {
  const std::size_t base = point_record_size(plan.header.point_format);
  if (source != nullptr) {
    const std::size_t described = described_extra_size(file, source->extra_bytes_descriptors);
    const std::vector<ExtraColumn> described_columns = extra_columns(file, plan.header.point_format, source->extra_bytes_descriptors, described);
    if (extras.size() >= described_columns.size()) {
      const std::size_t size = described + (extras.size() - described_columns.size());
      const std::vector<ExtraColumn> kept = extra_columns(file, plan.header.point_format, source->extra_bytes_descriptors, size);
      bool same = kept.size() == extras.size();
      for (std::size_t i = 0; same && i < kept.size(); ++i) {
        same = kept[i].name == extras[i]->name && kept[i].type == extras[i]->type;
      }
      if (same) {
        for (std::size_t i = 0; i < kept.size(); ++i) {
          plan.columns.push_back({extras[i], 1, 0, kept[i].storage, base + kept[i].offset});
        }
        descriptors = source->extra_bytes_descriptors;
        if (base + size > 65535) fail(file, "point records would exceed 65535 bytes");
        plan.header.record_length = static_cast<std::uint16_t>(base + size);
        return;
      }
    }
  }
  std::size_t offset = base;
  for (const Attribute* extra : extras) {
    if (extra->name.size() > 32) {
      fail(file, "attribute name '" + extra->name + "' is longer than the 32 characters of a LAS extra bytes name");
    }
    const LasStorage storage = storage_of(extra->type);
    descriptors += extra_descriptor(extra->name, extra->type);
    plan.columns.push_back({extra, 1, 0, storage, offset});
    offset += storage_size(storage);
  }
  if (offset > 65535) fail(file, "point records would exceed 65535 bytes (too many extra attributes)");
  plan.header.record_length = static_cast<std::uint16_t>(offset);
}

// LAS 1.2 (formats 0-3) or 1.4 (6-10) as LasWriteOptions::version_minor asks.
void choose_version(const fs::path& file, const PointTable& table, int version_minor, LasHeader& h) {
  if (version_minor != 2 && version_minor != 4) {
    fail(file, "cannot write LAS 1." + std::to_string(version_minor) + " (1.2 or 1.4)");
  }
  const bool wave = table.find("wave_packet_index") != nullptr;
  if (version_minor == 2 && wave) fail(file, "wave packets need LAS 1.3 or 1.4, not 1.2");
  h.version_minor = version_minor;
  h.point_format = version_minor == 2 ? choose_legacy_format(table) : choose_format(table);
  // Bit 4 (a WKT coordinate system) is what 1.4 requires for formats 6-10 and 1.2 reserves.
  h.global_encoding = static_cast<std::uint16_t>(version_minor == 4 ? h.global_encoding | 16u : h.global_encoding & ~16u);
}

// The coordinate system records that `crs` replaces.
bool is_crs_record(const LasRecord& record) {
  if (record.user_id != "LASF_Projection") return false;
  return record.record_id == 2111 || record.record_id == 2112 ||
         (record.record_id >= 34735 && record.record_id <= 34737);
}

// `crs` as LAS stores it: OGC WKT (record 2112) where the WKT bit is set, else a GeoTIFF key
// directory (record 34735: version 1.1.0, then id, location 0, count 1, value per key).
LasRecord crs_record(const fs::path& file, const LasCoordinateSystem& crs, const LasHeader& h) {
  if ((h.global_encoding & 16u) != 0) {
    if (crs.wkt.empty()) fail(file, "the coordinate system has no WKT, which LAS 1.4 formats 6-10 need");
    return {"LASF_Projection", 2112, "OGC WKT", crs.wkt + '\0', false};
  }
  if (crs.geo_keys.empty()) fail(file, "the coordinate system has no GeoTIFF keys, which LAS formats 0-5 need");
  std::vector<std::pair<std::uint16_t, std::uint16_t>> keys = crs.geo_keys;
  std::sort(keys.begin(), keys.end());
  std::string data(8 * (keys.size() + 1), '\0');
  const double head[4] = {1, 1, 0, static_cast<double>(keys.size())};
  for (int i = 0; i < 4; ++i) store_le(LasStorage::U16, head[i], data.data() + 2 * i);
  for (std::size_t k = 0; k < keys.size(); ++k) {
    char* entry = data.data() + 8 * (k + 1);
    store_le(LasStorage::U16, keys[k].first, entry);
    store_le(LasStorage::U16, 1, entry + 4);
    store_le(LasStorage::U16, keys[k].second, entry + 6);
  }
  return {"LASF_Projection", 34735, "GeoTIFF GeoKeyDirectoryTag", data, false};
}

// `count` points (table may hold none: a streaming writer's schema).
Plan plan_file(const fs::path& file, const PointTable& table, const PositionQuantization& q, std::uint64_t count,
               const LasWriteOptions& options) {
  Plan plan;
  LasHeader& h = plan.header;
  const LasMetadata* source = table.las ? &*table.las : nullptr;
  if (source != nullptr) {
    if (source->point_format < 0 || source->point_format > kMaxPointFormat || source->version_minor < 0 ||
        source->version_minor > 4 || source->version_minor < min_version_minor(source->point_format)) {
      fail(file, "cannot write point format " + std::to_string(source->point_format) + " as LAS 1." +
                     std::to_string(source->version_minor));
    }
    h.version_minor = source->version_minor;
    h.point_format = source->point_format;
    h.file_source_id = source->file_source_id;
    // Bit 1 (waveform data inside the file) is cleared: waveform packets are not copied.
    h.global_encoding = static_cast<std::uint16_t>(source->global_encoding & ~2u);
    h.project_guid = source->project_guid;
    h.system_identifier = source->system_identifier;
  } else {
    if (fits_legacy(table)) {
      // LAS 1.2, which every reader takes (some web readers refuse 1.4).
      h.version_minor = 2;
      h.point_format = choose_legacy_format(table);
    } else {
      h.version_minor = 4;
      h.point_format = choose_format(table);
      h.global_encoding = 16;  // WKT coordinate system bit, which 1.4 requires for formats 6-10
    }
    h.system_identifier = "OTHER";
  }
  if (options.version_minor != 0) {
    plan.strict_fields = true;
    if (source == nullptr || options.version_minor != h.version_minor) choose_version(file, table, options.version_minor, h);
  }
  h.generating_software = "pointfair";
  h.creation_day = today_day_of_year(h.creation_year);
  h.header_size = static_cast<std::uint16_t>(las_header_size(h.version_minor));
  h.point_count = count;
  if (h.version_minor < 4 && h.point_count > 0xffffffffu) {
    fail(file, "LAS 1." + std::to_string(h.version_minor) + " holds at most 4294967295 points");
  }
  for (int a = 0; a < 3; ++a) {
    h.scale[a] = q.scale[a];
    h.offset[a] = q.offset[a];
  }

  // Standard fields, then the attributes left over as extra bytes.
  std::vector<const Attribute*> used;
  for (const LasField& field : las_fields(h.point_format)) {
    Column column{table.find(field.name), 1, field.fallback, field.storage, field.offset, field.shift, field.bits};
    if (column.source == nullptr && field.name == "scan_angle") {
      column.source = table.find("scan_angle_rank");
      column.factor = 1 / kScanAngleUnit;
    } else if (column.source == nullptr && field.name == "scan_angle_rank") {
      column.source = table.find("scan_angle");
      column.factor = kScanAngleUnit;
    }
    // LAS colours are 16-bit: 8-bit colours (e.g. a PLY's) are scaled from 0-255 to 0-65535.
    const bool colour = field.name == "red" || field.name == "green" || field.name == "blue" || field.name == "nir";
    if (colour && column.source != nullptr && column.source->type == ScalarType::UInt8) column.factor = 257;
    if (column.source != nullptr) used.push_back(column.source);
    plan.columns.push_back(column);
  }
  std::vector<const Attribute*> extras;
  for (const Attribute& attribute : table.attributes) {
    if (std::find(used.begin(), used.end(), &attribute) == used.end()) extras.push_back(&attribute);
  }
  std::string descriptors;
  plan_extra_bytes(file, source, extras, plan, descriptors);
  if (has_laz_extension(file)) {
    if (h.point_format == 4 || h.point_format == 5 || h.point_format > 8) {
      fail(file, "writing LAZ of point format " + std::to_string(h.point_format) +
                     " (with wave packets) is not supported (LAZ output holds point formats 0-3 and 6-8); write .las");
    }
    if (options.laz_chunk_size == 0 || options.laz_chunk_size == laz::kVariableChunkSize) {
      fail(file, "LAZ chunk size " + std::to_string(options.laz_chunk_size) + " is not usable (1 to 4294967294 points)");
    }
    plan.laz = laz::laszip_info_for(h.point_format, h.record_length, options.laz_chunk_size);
    h.format_byte = 0x80;  // the compression bit
  }

  if (!descriptors.empty()) {
    plan.vlrs.push_back({std::string(kLasSpecUserId), kExtraBytesRecordId, "Extra Bytes", descriptors, false});
  }
  if (options.crs) plan.vlrs.push_back(crs_record(file, *options.crs, h));
  if (plan.laz) {
    plan.vlrs.push_back({std::string(laz::kLaszipUserId), laz::kLaszipRecordId, "laszip compression",
                         laz::serialize_laszip_vlr(*plan.laz), false});
  }
  if (source != nullptr) {
    for (const LasRecord& record : source->records) {
      if (options.crs && is_crs_record(record)) continue;
      const bool long_record = record.data.size() > 65535;
      if ((record.extended || long_record) && h.version_minor >= 4) {
        plan.evlrs.push_back(record);
      } else if (long_record) {
        fail(file, "record '" + record.user_id + "' " + std::to_string(record.record_id) +
                       " is too long for a VLR of LAS 1." + std::to_string(h.version_minor));
      } else {
        plan.vlrs.push_back(record);
      }
    }
  }
  std::uint64_t offset = h.header_size;
  for (const LasRecord& record : plan.vlrs) offset += kVlrHeaderSize + record.data.size();
  if (offset > 0xffffffffu) fail(file, "the VLRs exceed the 4 GiB a LAS header can point past");
  h.point_data_offset = static_cast<std::uint32_t>(offset);
  h.vlr_count = static_cast<std::uint32_t>(plan.vlrs.size());
  h.evlr_count = static_cast<std::uint32_t>(plan.evlrs.size());
  // LAZ: where the compressed points end is known once they are written (RecordOutput).
  if (!plan.evlrs.empty()) h.evlr_start = offset + h.point_count * h.record_length;
  return plan;
}

// Where encoded records go: straight to the file, or through the LAZ compressor.
class RecordOutput {
 public:
  // `sink` has received the header and VLRs.
  RecordOutput(FileSink& sink, const Plan& plan) : sink_(sink), end_(plan.header.point_data_offset) {
    if (plan.laz) laz_.emplace(sink, *plan.laz, plan.header.point_data_offset, plan.header.record_length);
  }
  void write(const char* records, std::size_t count, std::size_t record_length) {
    if (laz_) {
      laz_->write(records, count);
    } else {
      sink_.write(records, count * record_length);
      end_ += count * record_length;
    }
  }
  // Ends the point data; returns the file offset after it.
  std::uint64_t finish() { return laz_ ? laz_->finish() : end_; }

 private:
  FileSink& sink_;
  std::uint64_t end_;
  std::optional<laz::LazRecordWriter> laz_;
};

// Quantized positions' bounds and points by return, checked before anything is written.
// `first` is the file index of the table's first point: bounds start from the file's first
// point and grow with every later table.
void scan_points(const fs::path& file, const PointTable& table, const PositionQuantization& q, LasHeader& h,
                 std::uint64_t first = 0) {
  const char* axes = "xyz";
  for (int a = 0; a < 3; ++a) {
    if (!std::isfinite(q.scale[a]) || q.scale[a] == 0 || !std::isfinite(q.offset[a])) {
      fail(file, std::string("unusable ") + axes[a] + " scale or offset for LAS");
    }
  }
  for (std::size_t i = 0; i < table.size(); ++i) {
    for (int a = 0; a < 3; ++a) {
      const double stored = std::round((table.positions[i][a] - q.offset[a]) / q.scale[a]);
      if (!(std::abs(stored) <= kInt32Max)) {
        fail(file, "point " + std::to_string(first + i) + " (" + axes[a] + " = " + std::to_string(table.positions[i][a]) +
                       ") lies outside the int32 range of the LAS scale and offset");
      }
      const double value = q.offset[a] + q.scale[a] * stored;
      if (first + i == 0 || value < h.min[a]) h.min[a] = value;
      if (first + i == 0 || value > h.max[a]) h.max[a] = value;
    }
  }
  const std::size_t returns = h.point_format >= 6 ? 15 : 5;
  const Attribute* number = table.find("return_number");
  for (std::size_t i = 0; i < table.size(); ++i) {
    const double r = number != nullptr ? number->values[i] : 1;
    if (r >= 1 && r <= static_cast<double>(returns)) ++h.points_by_return[static_cast<std::size_t>(r) - 1];
  }
}

// Plan::strict_fields: every value of a bit field within its bits (columns read `table`).
void check_bit_fields(const fs::path& file, const PointTable& table, const std::vector<Column>& columns,
                      const LasHeader& h, std::uint64_t first = 0) {
  for (const Column& column : columns) {
    if (column.source == nullptr || column.bits == 0) continue;
    const double top = std::ldexp(1.0, static_cast<int>(column.bits)) - 1;
    for (std::size_t i = 0; i < table.size(); ++i) {
      const double value = column.source->values[i] * column.factor;
      if (!(value >= 0 && value <= top)) {
        std::string text;
        append_number(text, value);
        fail(file, "point " + std::to_string(first + i) + ": " + column.source->name + " " + text +
                       " does not fit the " + std::to_string(column.bits) + " bits of LAS 1." +
                       std::to_string(h.version_minor) + " format " + std::to_string(h.point_format) + "'s field");
      }
    }
  }
}

void encode_block(const PointTable& table, const PositionQuantization& q, const Plan& plan, std::size_t first,
                  std::size_t records, std::vector<char>& block) {
  const std::size_t record = plan.header.record_length;
  std::fill(block.begin(), block.begin() + static_cast<std::ptrdiff_t>(records * record), '\0');
  for (std::size_t r = 0; r < records; ++r) {
    char* bytes = block.data() + r * record;
    const Vec3& p = table.positions[first + r];
    for (int a = 0; a < 3; ++a) {
      store_le(LasStorage::I32, std::round((p[a] - q.offset[a]) / q.scale[a]), bytes + 4 * a);
    }
  }
  for (const Column& column : plan.columns) {
    for (std::size_t r = 0; r < records; ++r) {
      char* bytes = block.data() + r * record + column.offset;
      double value = column.source != nullptr ? column.source->values[first + r] * column.factor : column.fallback;
      if (column.bits > 0) {
        const double top = std::ldexp(1.0, static_cast<int>(column.bits)) - 1;
        value = std::isnan(value) ? 0 : std::clamp(std::round(value), 0.0, top);
        *bytes = static_cast<char>(static_cast<unsigned char>(*bytes) | (static_cast<unsigned>(value) << column.shift));
      } else {
        store_le(column.storage, value, bytes);
      }
    }
  }
}

void write_record(FileSink& sink, const LasRecord& record, bool extended) {
  std::string head(extended ? kEvlrHeaderSize : kVlrHeaderSize, '\0');
  head.replace(2, 16, padded(record.user_id, 16));
  store_le(LasStorage::U16, record.record_id, head.data() + 18);
  if (extended) {
    store_le(LasStorage::U64, static_cast<double>(record.data.size()), head.data() + 20);
    head.replace(28, 32, padded(record.description, 32));
  } else {
    store_le(LasStorage::U16, static_cast<double>(record.data.size()), head.data() + 20);
    head.replace(22, 32, padded(record.description, 32));
  }
  sink.write(head);
  sink.write(record.data);
}

}  // namespace

void write_las(const fs::path& file, const PointTable& table, const LasWriteOptions& options) {
  check_table(file, table);
  const PositionQuantization q = choose_quantization(table, options);
  Plan plan = plan_file(file, table, q, table.size(), options);
  scan_points(file, table, q, plan.header);
  if (plan.strict_fields) check_bit_fields(file, table, plan.columns, plan.header);

  write_file_atomically(file, [&](FileSink& sink) {
    sink.write(serialize_las_header(plan.header));
    for (const LasRecord& record : plan.vlrs) write_record(sink, record, false);
    RecordOutput output(sink, plan);
    const std::size_t record = plan.header.record_length;
    const std::size_t count = table.size();
    const std::size_t block_records = std::max<std::size_t>(1, kBlockBytes / record);
    std::vector<char> block(std::min(count, block_records) * record);
    for (std::size_t first = 0; first < count; first += block_records) {
      const std::size_t records = std::min(block_records, count - first);
      encode_block(table, q, plan, first, records, block);
      output.write(block.data(), records, record);
    }
    const std::uint64_t end = output.finish();
    for (const LasRecord& evlr : plan.evlrs) write_record(sink, evlr, true);
    if (plan.laz) {
      if (!plan.evlrs.empty()) plan.header.evlr_start = end;
      sink.write_at(0, serialize_las_header(plan.header));
    }
  });
}

namespace {

class LasBufferedWriter final : public PointChunkWriter {
 public:
  LasBufferedWriter(const fs::path& file, const PointTable& schema, std::uint64_t count, const LasWriteOptions& options)
      : path_(file), count_(count), options_(options) {
    table_.position_type = schema.position_type;
    table_.quantization = schema.quantization;
    table_.las = schema.las;
    for (const Attribute& attribute : schema.attributes) table_.attributes.push_back({attribute.name, attribute.type, {}});
  }

  void write(const PointTable& chunk) override {
    require_schema(path_, table_, chunk);
    check_table(path_, chunk, points_written_);
    if (chunk.size() > count_ - points_written_) {
      fail(path_, "more points written than the " + std::to_string(count_) + " declared");
    }
    table_.positions.insert(table_.positions.end(), chunk.positions.begin(), chunk.positions.end());
    for (std::size_t a = 0; a < chunk.attributes.size(); ++a) {
      auto& to = table_.attributes[a].values;
      to.insert(to.end(), chunk.attributes[a].values.begin(), chunk.attributes[a].values.end());
    }
    points_written_ += chunk.size();
  }

  void finish() override {
    if (points_written_ != count_) {
      fail(path_, "only " + std::to_string(points_written_) + " of the " + std::to_string(count_) +
                      " declared points were written");
    }
    write_las(path_, table_, options_);
  }

 private:
  fs::path path_;
  std::uint64_t count_ = 0;
  LasWriteOptions options_;
  PointTable table_;
};

// With the schema's quantization the records stream: the header is written first with what
// is known, and again at the end with the bounds and the points by return.
class LasStreamWriter final : public PointChunkWriter {
 public:
  LasStreamWriter(const fs::path& file, const PointTable& schema, std::uint64_t count, const LasWriteOptions& options)
      : path_(file), count_(count), q_(choose_quantization(schema, options)) {
    schema_.position_type = schema.position_type;
    schema_.quantization = schema.quantization;
    schema_.las = schema.las;
    for (const Attribute& attribute : schema.attributes) schema_.attributes.push_back({attribute.name, attribute.type, {}});
    plan_ = plan_file(file, schema_, q_, count, options);
    scan_points(file, schema_, q_, plan_.header);  // checks the scale and offset
    file_.emplace(file);
    file_->sink().write(serialize_las_header(plan_.header));
    for (const LasRecord& record : plan_.vlrs) write_record(file_->sink(), record, false);
    output_.emplace(file_->sink(), plan_);
  }

  void write(const PointTable& chunk) override {
    require_schema(path_, schema_, chunk);
    check_table(path_, chunk, points_written_);
    if (chunk.size() > count_ - points_written_) {
      fail(path_, "more points written than the " + std::to_string(count_) + " declared");
    }
    scan_points(path_, chunk, q_, plan_.header, points_written_);
    // The plan's columns read the schema's attributes: here, the chunk's of the same index.
    Plan chunk_plan;
    chunk_plan.header = plan_.header;
    chunk_plan.columns = plan_.columns;
    for (Column& column : chunk_plan.columns) {
      if (column.source != nullptr) {
        column.source = &chunk.attributes[static_cast<std::size_t>(column.source - schema_.attributes.data())];
      }
    }
    if (plan_.strict_fields) check_bit_fields(path_, chunk, chunk_plan.columns, plan_.header, points_written_);
    const std::size_t record = plan_.header.record_length;
    const std::size_t block_records = std::max<std::size_t>(1, kBlockBytes / record);
    block_.resize(std::min(chunk.size(), block_records) * record);
    for (std::size_t first = 0; first < chunk.size(); first += block_records) {
      const std::size_t records = std::min(block_records, chunk.size() - first);
      encode_block(chunk, q_, chunk_plan, first, records, block_);
      output_->write(block_.data(), records, record);
    }
    points_written_ += chunk.size();
  }

  void finish() override {
    if (points_written_ != count_) {
      fail(path_, "only " + std::to_string(points_written_) + " of the " + std::to_string(count_) +
                      " declared points were written");
    }
    const std::uint64_t end = output_->finish();
    if (plan_.laz && !plan_.evlrs.empty()) plan_.header.evlr_start = end;
    for (const LasRecord& evlr : plan_.evlrs) write_record(file_->sink(), evlr, true);
    file_->sink().write_at(0, serialize_las_header(plan_.header));
    file_->commit();
  }

 private:
  fs::path path_;
  std::uint64_t count_ = 0;
  PositionQuantization q_;
  PointTable schema_;
  Plan plan_;
  std::vector<char> block_;
  std::optional<AtomicFile> file_;
  std::optional<RecordOutput> output_;  // after file_: refers to its sink
};

}  // namespace

std::unique_ptr<PointChunkWriter> open_las_writer(const fs::path& file, const PointTable& schema, std::uint64_t count,
                                                  const LasWriteOptions& options) {
  if (schema.quantization || (options.scale && options.offset)) {
    return std::make_unique<LasStreamWriter>(file, schema, count, options);
  }
  return std::make_unique<LasBufferedWriter>(file, schema, count, options);
}

}  // namespace pointfair::io
