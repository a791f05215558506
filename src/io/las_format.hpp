#pragma once
// Internal description of the LAS 1.0-1.4 layout (ASPRS LAS 1.4 R15): the public header,
// the point data record formats 0-10 as a list of fields, and the Extra Bytes descriptors.
// All values in a LAS file are little endian.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "pointfair/io/point_table.hpp"

namespace pointfair::io::detail {

/// How a value is stored in a LAS record (LAS has 64-bit integers, ScalarType has not).
enum class LasStorage { U8, I8, U16, I16, U32, I32, U64, I64, F32, F64 };

std::size_t storage_size(LasStorage storage);
/// The little-endian value at `bytes`.
double load_le(LasStorage storage, const char* bytes);
/// Stores `value` little endian at `bytes`; integers are rounded and saturated.
void store_le(LasStorage storage, double value, char* bytes);
/// The attribute type that holds every value of `storage` (64-bit integers: Float64, exact
/// up to 2^53).
ScalarType attribute_type_of(LasStorage storage);
/// The storage of an attribute of `type` (the inverse of attribute_type_of for 8-32 bits).
LasStorage storage_of(ScalarType type);

constexpr int kMaxPointFormat = 10;
constexpr std::size_t kVlrHeaderSize = 54;
constexpr std::size_t kEvlrHeaderSize = 60;
constexpr std::size_t kExtraBytesDescriptorSize = 192;

/// Bytes of the public header of LAS 1.<minor>: 227 (1.0-1.2), 235 (1.3), 375 (1.4).
std::size_t las_header_size(int minor);
/// Bytes of one record of point data format `format` (0..10) without extra bytes.
std::size_t point_record_size(int format);
/// Smallest LAS 1.x minor version that defines `format`.
int min_version_minor(int format);
bool has_rgb(int format);
bool has_nir(int format);
bool has_wave_packet(int format);

/// One standard field of a point record, after X, Y, Z. A bit field (`bits` > 0) occupies
/// bits [shift, shift + bits) of the byte at `offset`.
struct LasField {
  std::string_view name;  // the attribute name
  ScalarType type;        // the attribute type
  LasStorage storage;
  std::size_t offset;
  unsigned shift = 0;
  unsigned bits = 0;
  double fallback = 0;  // written when the table has no attribute of this name
};

/// The standard fields of `format` in record order (X, Y, Z excluded).
const std::vector<LasField>& las_fields(int format);
/// True if `name` is x, y, z or names a standard field of `format`.
bool is_las_field_name(int format, std::string_view name);

/// The public header fields this library reads and writes.
struct LasHeader {
  std::uint16_t file_source_id = 0;
  std::uint16_t global_encoding = 0;
  std::string project_guid = std::string(16, '\0');
  int version_major = 1;
  int version_minor = 4;
  std::string system_identifier;
  std::string generating_software;
  std::uint16_t creation_day = 0;
  std::uint16_t creation_year = 0;
  std::uint16_t header_size = 0;
  std::uint32_t point_data_offset = 0;
  std::uint32_t vlr_count = 0;
  int point_format = 0;       // without the compression bits
  std::uint8_t format_byte = 0;  // as stored; serialize_las_header keeps its compression bits (6, 7)
  std::uint16_t record_length = 0;
  std::uint64_t point_count = 0;
  std::uint64_t points_by_return[15] = {};
  double scale[3] = {1, 1, 1};
  double offset[3] = {0, 0, 0};
  double max[3] = {0, 0, 0};
  double min[3] = {0, 0, 0};
  std::uint64_t waveform_start = 0;  // 1.3 and later
  std::uint64_t evlr_start = 0;      // 1.4
  std::uint32_t evlr_count = 0;      // 1.4
};

/// Parses the public header from `bytes` (at least las_header_size(1.0) bytes, more as the
/// version needs). Throws IoError "<file>: <problem>" for a wrong signature, an unsupported
/// version or a header too small for its version.
LasHeader parse_las_header(const std::filesystem::path& file, std::string_view bytes);
/// Serialises `header` as the public header of its version (header.header_size bytes).
std::string serialize_las_header(const LasHeader& header);

/// One attribute held in the extra bytes of each record.
struct ExtraColumn {
  std::string name;
  ScalarType type;
  LasStorage storage;
  std::size_t offset;  // from the start of the extra bytes
};

/// The attributes of `extra_size` extra bytes per record described by the Extra Bytes VLR
/// payload `descriptors` (may be empty), then one UInt8 "extra_byte_<k>" per undescribed
/// byte. Names are made unique and never collide with x, y, z or a field of `format`.
/// Throws IoError "<file>: ..." for a malformed payload or descriptors needing more than
/// `extra_size` bytes.
std::vector<ExtraColumn> extra_columns(const std::filesystem::path& file, int format,
                                       std::string_view descriptors, std::size_t extra_size);
/// Bytes per record the descriptors describe (without undescribed bytes).
std::size_t described_extra_size(const std::filesystem::path& file, std::string_view descriptors);
/// A descriptor of one scalar extra attribute called `name` (at most 32 characters).
std::string extra_descriptor(const std::string& name, ScalarType type);

/// The user id of the Extra Bytes VLR and its record id.
constexpr std::string_view kLasSpecUserId = "LASF_Spec";
constexpr std::uint16_t kExtraBytesRecordId = 4;

/// Reads a fixed-size, NUL-padded text field.
std::string fixed_text(std::string_view bytes);
/// `text` padded with NULs to `size` bytes (`text` must not be longer).
std::string padded(std::string_view text, std::size_t size);

}  // namespace pointfair::io::detail
