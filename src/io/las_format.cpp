// LAS point data record formats 0-10 as field lists, and little-endian value coding.
#include "las_format.hpp"

#include <algorithm>
#include <array>
#include <cstring>

#include "scalar_codec.hpp"

namespace pointfair::io::detail {

namespace {

template <typename F>
void visit_storage(LasStorage storage, F&& f) {
  switch (storage) {
    case LasStorage::U8: return f(std::uint8_t{});
    case LasStorage::I8: return f(std::int8_t{});
    case LasStorage::U16: return f(std::uint16_t{});
    case LasStorage::I16: return f(std::int16_t{});
    case LasStorage::U32: return f(std::uint32_t{});
    case LasStorage::I32: return f(std::int32_t{});
    case LasStorage::U64: return f(std::uint64_t{});
    case LasStorage::I64: return f(std::int64_t{});
    case LasStorage::F32: return f(float{});
    case LasStorage::F64: return f(double{});
  }
}

constexpr bool kSwap = needs_swap(false);

using S = ScalarType;
using L = LasStorage;

// Fields shared by formats 0-5 after X, Y, Z (offsets 12-19).
std::vector<LasField> legacy_core() {
  return {
      {"intensity", S::UInt16, L::U16, 12},
      {"return_number", S::UInt8, L::U8, 14, 0, 3, 1},
      {"number_of_returns", S::UInt8, L::U8, 14, 3, 3, 1},
      {"scan_direction_flag", S::UInt8, L::U8, 14, 6, 1},
      {"edge_of_flight_line", S::UInt8, L::U8, 14, 7, 1},
      {"classification", S::UInt8, L::U8, 15, 0, 5},
      {"synthetic", S::UInt8, L::U8, 15, 5, 1},
      {"key_point", S::UInt8, L::U8, 15, 6, 1},
      {"withheld", S::UInt8, L::U8, 15, 7, 1},
      // The scan angle rank: whole degrees, -90..90, as stored.
      {"scan_angle_rank", S::Int8, L::I8, 16},
      {"user_data", S::UInt8, L::U8, 17},
      {"point_source_id", S::UInt16, L::U16, 18},
  };
}

// Fields shared by formats 6-10 after X, Y, Z (offsets 12-29).
std::vector<LasField> extended_core() {
  return {
      {"intensity", S::UInt16, L::U16, 12},
      {"return_number", S::UInt8, L::U8, 14, 0, 4, 1},
      {"number_of_returns", S::UInt8, L::U8, 14, 4, 4, 1},
      {"synthetic", S::UInt8, L::U8, 15, 0, 1},
      {"key_point", S::UInt8, L::U8, 15, 1, 1},
      {"withheld", S::UInt8, L::U8, 15, 2, 1},
      {"overlap", S::UInt8, L::U8, 15, 3, 1},
      {"scanner_channel", S::UInt8, L::U8, 15, 4, 2},
      {"scan_direction_flag", S::UInt8, L::U8, 15, 6, 1},
      {"edge_of_flight_line", S::UInt8, L::U8, 15, 7, 1},
      {"classification", S::UInt8, L::U8, 16},
      {"user_data", S::UInt8, L::U8, 17},
      // The scan angle as stored: units of 0.006 degrees (-30000..30000 is -180..180).
      {"scan_angle", S::Int16, L::I16, 18},
      {"point_source_id", S::UInt16, L::U16, 20},
      {"gps_time", S::Float64, L::F64, 22},
  };
}

void add_gps(std::vector<LasField>& fields, std::size_t at) {
  fields.push_back({"gps_time", S::Float64, L::F64, at});
}
void add_rgb(std::vector<LasField>& fields, std::size_t at) {
  fields.push_back({"red", S::UInt16, L::U16, at});
  fields.push_back({"green", S::UInt16, L::U16, at + 2});
  fields.push_back({"blue", S::UInt16, L::U16, at + 4});
}
void add_wave(std::vector<LasField>& fields, std::size_t at) {
  fields.push_back({"wave_packet_index", S::UInt8, L::U8, at});
  // A uint64 byte offset, held exactly as a double up to 2^53 bytes.
  fields.push_back({"wave_data_offset", S::Float64, L::U64, at + 1});
  fields.push_back({"wave_packet_size", S::UInt32, L::U32, at + 9});
  fields.push_back({"return_point_location", S::Float32, L::F32, at + 13});
  fields.push_back({"x_t", S::Float32, L::F32, at + 17});
  fields.push_back({"y_t", S::Float32, L::F32, at + 21});
  fields.push_back({"z_t", S::Float32, L::F32, at + 25});
}

std::array<std::vector<LasField>, kMaxPointFormat + 1> make_tables() {
  std::array<std::vector<LasField>, kMaxPointFormat + 1> t;
  t[0] = legacy_core();
  t[1] = legacy_core();
  add_gps(t[1], 20);
  t[2] = legacy_core();
  add_rgb(t[2], 20);
  t[3] = t[1];
  add_rgb(t[3], 28);
  t[4] = t[1];
  add_wave(t[4], 28);
  t[5] = t[3];
  add_wave(t[5], 34);
  t[6] = extended_core();
  t[7] = t[6];
  add_rgb(t[7], 30);
  t[8] = t[7];
  t[8].push_back({"nir", S::UInt16, L::U16, 36});
  t[9] = t[6];
  add_wave(t[9], 30);
  t[10] = t[8];
  add_wave(t[10], 38);
  return t;
}

}  // namespace

std::size_t storage_size(LasStorage storage) {
  std::size_t size = 0;
  visit_storage(storage, [&](auto tag) { size = sizeof(tag); });
  return size;
}

double load_le(LasStorage storage, const char* bytes) {
  double value = 0;
  visit_storage(storage, [&](auto tag) {
    value = static_cast<double>(load_scalar<decltype(tag), kSwap>(bytes));
  });
  return value;
}

void store_le(LasStorage storage, double value, char* bytes) {
  visit_storage(storage, [&](auto tag) {
    using T = decltype(tag);
    store_scalar<T, kSwap>(to_stored<T>(value), bytes);
  });
}

ScalarType attribute_type_of(LasStorage storage) {
  switch (storage) {
    case L::U8: return S::UInt8;
    case L::I8: return S::Int8;
    case L::U16: return S::UInt16;
    case L::I16: return S::Int16;
    case L::U32: return S::UInt32;
    case L::I32: return S::Int32;
    case L::F32: return S::Float32;
    case L::U64:
    case L::I64:
    case L::F64: return S::Float64;
  }
  return S::Float64;
}

LasStorage storage_of(ScalarType type) {
  switch (type) {
    case S::UInt8: return L::U8;
    case S::Int8: return L::I8;
    case S::UInt16: return L::U16;
    case S::Int16: return L::I16;
    case S::UInt32: return L::U32;
    case S::Int32: return L::I32;
    case S::Float32: return L::F32;
    case S::Float64: return L::F64;
  }
  return L::F64;
}

std::size_t las_header_size(int minor) { return minor >= 4 ? 375 : minor == 3 ? 235 : 227; }

std::size_t point_record_size(int format) {
  static constexpr std::size_t sizes[] = {20, 28, 26, 34, 57, 63, 30, 36, 38, 59, 67};
  return sizes[format];
}

int min_version_minor(int format) { return format >= 6 ? 4 : format >= 4 ? 3 : format >= 2 ? 2 : 0; }
bool has_rgb(int format) { return format == 2 || format == 3 || format == 5 || format == 7 || format == 8 || format == 10; }
bool has_nir(int format) { return format == 8 || format == 10; }
bool has_wave_packet(int format) { return format == 4 || format == 5 || format == 9 || format == 10; }

const std::vector<LasField>& las_fields(int format) {
  static const auto tables = make_tables();
  return tables[static_cast<std::size_t>(format)];
}

bool is_las_field_name(int format, std::string_view name) {
  if (name == "x" || name == "y" || name == "z") return true;
  const auto& fields = las_fields(format);
  return std::any_of(fields.begin(), fields.end(), [&](const LasField& f) { return f.name == name; });
}

std::string fixed_text(std::string_view bytes) {
  const std::size_t end = bytes.find('\0');
  return std::string(bytes.substr(0, end));
}

std::string padded(std::string_view text, std::size_t size) {
  std::string out(text.substr(0, size));
  out.resize(size, '\0');
  return out;
}

}  // namespace pointfair::io::detail
