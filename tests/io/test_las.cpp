// LAS reader and writer: hand-made files of formats 0, 3, 6 and 10 read field by field,
// round trips of every format with extra bytes, conversion from PLY, and every error path.
#include "pointfair/io/las.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "io_test_util.hpp"
#include "pointfair/io/ply.hpp"
#include "pointfair/io/point_file.hpp"

namespace pointfair::io {
namespace {

namespace fs = std::filesystem;
using testing::Bytes;
using testing::expect_io_error;
using testing::read_file;
using testing::TempDir;
using testing::write_file;

constexpr std::size_t kRecordSize[] = {20, 28, 26, 34, 57, 63, 30, 36, 38, 59, 67};

// The fields of a hand-made public header; the byte layout is written out in header_bytes.
struct HeaderSpec {
  int minor = 2;
  int format = 0;
  std::uint16_t header_size = 0;  // 0: the size of the version
  std::uint32_t vlr_count = 0;
  std::uint32_t vlr_bytes = 0;  // total size of the VLRs, headers included
  std::uint16_t record_length = 0;  // 0: the size of the format
  std::uint64_t count = 1;
  double scale[3] = {0.01, 0.01, 0.01};
  double offset[3] = {100, 200, 300};
  std::uint8_t format_byte_bits = 0;  // or-ed into the format byte (compression bits)
  std::uint32_t point_offset_delta = 0;  // added to the offset to point data
};

std::size_t header_size_of(int minor) { return minor == 4 ? 375 : minor == 3 ? 235 : 227; }

std::string header_bytes(const HeaderSpec& s) {
  const std::size_t size = s.header_size != 0 ? s.header_size : header_size_of(s.minor);
  const std::uint16_t length = s.record_length != 0 ? s.record_length : static_cast<std::uint16_t>(kRecordSize[s.format]);
  Bytes b(false);
  b.text("LASF").put<std::uint16_t>(7).put<std::uint16_t>(0);
  b.text(std::string(16, '\0'));
  b.put<std::uint8_t>(1).put<std::uint8_t>(static_cast<std::uint8_t>(s.minor));
  b.text(std::string(32, '\0')).text(std::string(32, '\0'));
  b.put<std::uint16_t>(100).put<std::uint16_t>(2024);
  b.put<std::uint16_t>(static_cast<std::uint16_t>(size));
  b.put<std::uint32_t>(static_cast<std::uint32_t>(size) + s.vlr_bytes + s.point_offset_delta);
  b.put<std::uint32_t>(s.vlr_count);
  b.put<std::uint8_t>(static_cast<std::uint8_t>(s.format | s.format_byte_bits));
  b.put<std::uint16_t>(length);
  b.put<std::uint32_t>(s.minor < 4 ? static_cast<std::uint32_t>(s.count) : 0);
  for (int r = 0; r < 5; ++r) b.put<std::uint32_t>(0);
  for (double v : s.scale) b.put<double>(v);
  for (double v : s.offset) b.put<double>(v);
  for (int i = 0; i < 6; ++i) b.put<double>(0);  // bounds: not checked by the reader
  if (s.minor >= 3) b.put<std::uint64_t>(0);
  if (s.minor >= 4) {
    b.put<std::uint64_t>(0).put<std::uint32_t>(0).put<std::uint64_t>(s.count);
    for (int r = 0; r < 15; ++r) b.put<std::uint64_t>(0);
  }
  std::string out = b.str();
  // A header_size below the version's size is a lie of the field only: the bytes are there.
  out.resize(std::max(out.size(), size), '\0');
  return out;
}

// A VLR: 54-byte header and payload.
std::string vlr_bytes(std::string_view user, std::uint16_t id, const std::string& payload,
                      std::string_view description = {}) {
  Bytes b(false);
  b.put<std::uint16_t>(0);
  std::string u(user);
  u.resize(16, '\0');
  b.text(u).put<std::uint16_t>(id).put<std::uint16_t>(static_cast<std::uint16_t>(payload.size()));
  std::string d(description);
  d.resize(32, '\0');
  b.text(d).text(payload);
  return b.str();
}

// One 192-byte Extra Bytes descriptor.
std::string descriptor(std::string_view name, std::uint8_t type, std::uint8_t options = 0) {
  std::string d(192, '\0');
  d[2] = static_cast<char>(type);
  d[3] = static_cast<char>(options);
  std::copy(name.begin(), name.end(), d.begin() + 4);
  return d;
}

void xyz(Bytes& b, std::int32_t x, std::int32_t y, std::int32_t z) { b.put(x).put(y).put(z); }

double attr(const PointTable& t, std::string_view name, std::size_t i = 0) {
  const Attribute* a = t.find(name);
  if (a == nullptr) {
    ADD_FAILURE() << "no attribute " << name;
    return std::numeric_limits<double>::quiet_NaN();
  }
  return a->values.at(i);
}

LasMetadata las_metadata(int minor, int format) {
  LasMetadata m;
  m.version_minor = minor;
  m.point_format = format;
  return m;
}

ScalarType type_of(const PointTable& t, std::string_view name) {
  const Attribute* a = t.find(name);
  return a != nullptr ? a->type : ScalarType::Float64;
}

TEST(Las, ReadsFormat0OfLas12FieldByField) {
  TempDir dir;
  Bytes b(false);
  b.text(header_bytes({.minor = 2, .format = 0, .count = 2}));
  xyz(b, 1000, -2000, 30);
  b.put<std::uint16_t>(513);
  b.put<std::uint8_t>(2 | (3 << 3) | (1 << 6));     // return 2 of 3, scan direction 1, edge 0
  b.put<std::uint8_t>(6 | (1 << 5) | (1 << 7));     // class 6, synthetic, withheld
  b.put<std::int8_t>(-12).put<std::uint8_t>(7).put<std::uint16_t>(4242);
  xyz(b, 0, 0, 0);
  b.put<std::uint16_t>(0).put<std::uint8_t>(1 | (1 << 3) | (1 << 7)).put<std::uint8_t>(31 | (1 << 6));
  b.put<std::int8_t>(90).put<std::uint8_t>(255).put<std::uint16_t>(65535);
  write_file(dir / "f0.las", b.str());

  const PointTable t = read_las(dir / "f0.las");
  ASSERT_EQ(t.size(), 2u);
  EXPECT_DOUBLE_EQ(t.positions[0].x(), 110.0);
  EXPECT_DOUBLE_EQ(t.positions[0].y(), 180.0);
  EXPECT_DOUBLE_EQ(t.positions[0].z(), 300.3);
  EXPECT_EQ(t.positions[1], Vec3(100, 200, 300));
  EXPECT_EQ(attr(t, "intensity"), 513);
  EXPECT_EQ(attr(t, "return_number"), 2);
  EXPECT_EQ(attr(t, "number_of_returns"), 3);
  EXPECT_EQ(attr(t, "scan_direction_flag"), 1);
  EXPECT_EQ(attr(t, "edge_of_flight_line"), 0);
  EXPECT_EQ(attr(t, "classification"), 6);
  EXPECT_EQ(attr(t, "synthetic"), 1);
  EXPECT_EQ(attr(t, "key_point"), 0);
  EXPECT_EQ(attr(t, "withheld"), 1);
  EXPECT_EQ(attr(t, "scan_angle_rank"), -12);
  EXPECT_EQ(attr(t, "user_data"), 7);
  EXPECT_EQ(attr(t, "point_source_id"), 4242);
  EXPECT_EQ(attr(t, "return_number", 1), 1);
  EXPECT_EQ(attr(t, "number_of_returns", 1), 1);
  EXPECT_EQ(attr(t, "edge_of_flight_line", 1), 1);
  EXPECT_EQ(attr(t, "classification", 1), 31);
  EXPECT_EQ(attr(t, "key_point", 1), 1);
  EXPECT_EQ(attr(t, "scan_angle_rank", 1), 90);
  EXPECT_EQ(attr(t, "point_source_id", 1), 65535);
  EXPECT_EQ(type_of(t, "intensity"), ScalarType::UInt16);
  EXPECT_EQ(type_of(t, "scan_angle_rank"), ScalarType::Int8);
  EXPECT_EQ(type_of(t, "classification"), ScalarType::UInt8);
  EXPECT_EQ(t.find("gps_time"), nullptr);
  EXPECT_EQ(t.find("overlap"), nullptr);
  EXPECT_EQ(t.attributes.size(), 12u);
  ASSERT_TRUE(t.quantization.has_value());
  EXPECT_EQ(t.quantization->scale, Vec3(0.01, 0.01, 0.01));
  EXPECT_EQ(t.quantization->offset, Vec3(100, 200, 300));
  ASSERT_TRUE(t.las.has_value());
  EXPECT_EQ(t.las->version_minor, 2);
  EXPECT_EQ(t.las->point_format, 0);
  EXPECT_EQ(t.las->file_source_id, 7);
}

TEST(Las, ReadsFormat3WithGpsTimeAndColour) {
  TempDir dir;
  Bytes b(false);
  b.text(header_bytes({.minor = 2, .format = 3}));
  xyz(b, -5, 6, 7);
  b.put<std::uint16_t>(10).put<std::uint8_t>(5 | (5 << 3)).put<std::uint8_t>(2 | (1 << 6));
  b.put<std::int8_t>(-90).put<std::uint8_t>(1).put<std::uint16_t>(2);
  b.put<double>(123456.789);
  b.put<std::uint16_t>(65535).put<std::uint16_t>(256).put<std::uint16_t>(3);
  write_file(dir / "f3.las", b.str());

  const PointTable t = read_las(dir / "f3.las");
  ASSERT_EQ(t.size(), 1u);
  EXPECT_DOUBLE_EQ(t.positions[0].x(), 99.95);
  EXPECT_EQ(attr(t, "return_number"), 5);
  EXPECT_EQ(attr(t, "number_of_returns"), 5);
  EXPECT_EQ(attr(t, "classification"), 2);
  EXPECT_EQ(attr(t, "key_point"), 1);
  EXPECT_EQ(attr(t, "scan_angle_rank"), -90);
  EXPECT_EQ(attr(t, "gps_time"), 123456.789);
  EXPECT_EQ(attr(t, "red"), 65535);
  EXPECT_EQ(attr(t, "green"), 256);
  EXPECT_EQ(attr(t, "blue"), 3);
  EXPECT_EQ(type_of(t, "gps_time"), ScalarType::Float64);
  EXPECT_EQ(type_of(t, "red"), ScalarType::UInt16);
  EXPECT_EQ(t.attributes.size(), 16u);
}

TEST(Las, ReadsFormat6OfLas14FieldByField) {
  TempDir dir;
  Bytes b(false);
  b.text(header_bytes({.minor = 4, .format = 6}));
  xyz(b, 1, 2, 3);
  b.put<std::uint16_t>(40000);
  b.put<std::uint8_t>(12 | (15 << 4));                           // return 12 of 15
  b.put<std::uint8_t>(1 | (0 << 1) | (1 << 2) | (1 << 3) | (2 << 4) | (0 << 6) | (1 << 7));
  b.put<std::uint8_t>(200).put<std::uint8_t>(9).put<std::int16_t>(-15000).put<std::uint16_t>(77);
  b.put<double>(-1.5e9);
  write_file(dir / "f6.las", b.str());

  const PointTable t = read_las(dir / "f6.las");
  ASSERT_EQ(t.size(), 1u);
  EXPECT_DOUBLE_EQ(t.positions[0].z(), 300.03);
  EXPECT_EQ(attr(t, "intensity"), 40000);
  EXPECT_EQ(attr(t, "return_number"), 12);
  EXPECT_EQ(attr(t, "number_of_returns"), 15);
  EXPECT_EQ(attr(t, "synthetic"), 1);
  EXPECT_EQ(attr(t, "key_point"), 0);
  EXPECT_EQ(attr(t, "withheld"), 1);
  EXPECT_EQ(attr(t, "overlap"), 1);
  EXPECT_EQ(attr(t, "scanner_channel"), 2);
  EXPECT_EQ(attr(t, "scan_direction_flag"), 0);
  EXPECT_EQ(attr(t, "edge_of_flight_line"), 1);
  EXPECT_EQ(attr(t, "classification"), 200);
  EXPECT_EQ(attr(t, "user_data"), 9);
  EXPECT_EQ(attr(t, "scan_angle"), -15000);  // stored units of 0.006 degrees: -90 degrees
  EXPECT_EQ(attr(t, "point_source_id"), 77);
  EXPECT_EQ(attr(t, "gps_time"), -1.5e9);
  EXPECT_EQ(type_of(t, "scan_angle"), ScalarType::Int16);
  EXPECT_EQ(t.find("scan_angle_rank"), nullptr);
  EXPECT_EQ(t.attributes.size(), 15u);
}

TEST(Las, ReadsFormat10WithWavePacketsAndExtraBytes) {
  TempDir dir;
  const std::string descriptors = descriptor("amplitude", 9) + descriptor("range id", 4) + descriptor("flags", 0, 2);
  const std::string vlr = vlr_bytes("LASF_Spec", 4, descriptors, "Extra Bytes");
  const std::string other = vlr_bytes("LASF_Projection", 2112, "GEOGCS[\"WGS 84\"]");
  const std::uint16_t length = 67 + 4 + 2 + 2 + 1;  // one undescribed byte
  Bytes b(false);
  b.text(header_bytes({.minor = 4, .format = 10, .vlr_count = 2,
                       .vlr_bytes = static_cast<std::uint32_t>(vlr.size() + other.size()), .record_length = length}));
  b.text(vlr).text(other);
  xyz(b, 0, 0, 0);
  b.put<std::uint16_t>(1).put<std::uint8_t>(1 | (1 << 4)).put<std::uint8_t>(3 << 4);
  b.put<std::uint8_t>(18).put<std::uint8_t>(0).put<std::int16_t>(30000).put<std::uint16_t>(5);
  b.put<double>(42.25);
  b.put<std::uint16_t>(1).put<std::uint16_t>(2).put<std::uint16_t>(3).put<std::uint16_t>(4);  // RGB, NIR
  b.put<std::uint8_t>(3).put<std::uint64_t>(std::uint64_t{1} << 40).put<std::uint32_t>(256);
  b.put<float>(1.5f).put<float>(-0.25f).put<float>(0.5f).put<float>(0.125f);
  b.put<float>(3.25f).put<std::int16_t>(-7).put<std::uint8_t>(0xab).put<std::uint8_t>(0xcd).put<std::uint8_t>(9);
  write_file(dir / "f10.las", b.str());

  const PointTable t = read_las(dir / "f10.las");
  ASSERT_EQ(t.size(), 1u);
  EXPECT_EQ(attr(t, "scanner_channel"), 3);
  EXPECT_EQ(attr(t, "classification"), 18);
  EXPECT_EQ(attr(t, "scan_angle"), 30000);
  EXPECT_EQ(attr(t, "red"), 1);
  EXPECT_EQ(attr(t, "green"), 2);
  EXPECT_EQ(attr(t, "blue"), 3);
  EXPECT_EQ(attr(t, "nir"), 4);
  EXPECT_EQ(attr(t, "wave_packet_index"), 3);
  EXPECT_EQ(attr(t, "wave_data_offset"), std::ldexp(1.0, 40));
  EXPECT_EQ(attr(t, "wave_packet_size"), 256);
  EXPECT_EQ(attr(t, "return_point_location"), 1.5);
  EXPECT_EQ(attr(t, "x_t"), -0.25);
  EXPECT_EQ(attr(t, "y_t"), 0.5);
  EXPECT_EQ(attr(t, "z_t"), 0.125);
  EXPECT_EQ(type_of(t, "wave_packet_size"), ScalarType::UInt32);
  EXPECT_EQ(type_of(t, "x_t"), ScalarType::Float32);
  // Extra bytes: described (name cleaned: "range id" -> "range_id"), undocumented, undescribed.
  EXPECT_EQ(attr(t, "amplitude"), 3.25);
  EXPECT_EQ(type_of(t, "amplitude"), ScalarType::Float32);
  EXPECT_EQ(attr(t, "range_id"), -7);
  EXPECT_EQ(type_of(t, "range_id"), ScalarType::Int16);
  EXPECT_EQ(attr(t, "flags_0"), 0xab);
  EXPECT_EQ(attr(t, "flags_1"), 0xcd);
  EXPECT_EQ(attr(t, "extra_byte_0"), 9);
  EXPECT_EQ(t.attributes.size(), 26u + 5u);
  ASSERT_TRUE(t.las.has_value());
  ASSERT_EQ(t.las->records.size(), 1u);
  EXPECT_EQ(t.las->records[0].user_id, "LASF_Projection");
  EXPECT_EQ(t.las->records[0].record_id, 2112);
  EXPECT_EQ(t.las->records[0].data, "GEOGCS[\"WGS 84\"]");

  // Written back: the same bytes apart from the header's software name and date.
  write_las(dir / "back.las", t);
  const std::string original = read_file(dir / "f10.las");
  const std::string back = read_file(dir / "back.las");
  ASSERT_EQ(back.size(), original.size());
  EXPECT_EQ(back.substr(375), original.substr(375));
  const PointTable again = read_las(dir / "back.las");
  for (const Attribute& a : t.attributes) EXPECT_EQ(again.find(a.name)->values, a.values) << a.name;
}

// The longest record LAS allows: 65,515 undescribed bytes after format 0, each an attribute.
TEST(Las, KeepsTheUndescribedBytesOfTheLongestRecord) {
  TempDir dir;
  Bytes b(false);
  b.text(header_bytes({.minor = 2, .format = 0, .record_length = 65535}));
  xyz(b, 1, 2, 3);
  b.put<std::uint16_t>(0).put<std::uint8_t>(9).put<std::uint8_t>(2).put<std::uint32_t>(0);
  std::string extra(65515, '\0');
  for (std::size_t k = 0; k < extra.size(); ++k) extra[k] = static_cast<char>(k * 31 % 251);
  b.text(extra);
  write_file(dir / "wide.las", b.str());
  const PointTable t = read_las(dir / "wide.las");
  ASSERT_EQ(t.attributes.size(), 12u + 65515u);
  EXPECT_EQ(t.attributes.back().name, "extra_byte_65514");
  EXPECT_EQ(attr(t, "extra_byte_1000"), 1000 * 31 % 251);
  write_las(dir / "back.las", t);
  EXPECT_EQ(read_file(dir / "back.las").substr(227), b.str().substr(227));
}

TEST(Las, ExtraByteNamesNeverCollide) {
  TempDir dir;
  const std::string vlr =
      vlr_bytes("LASF_Spec", 4, descriptor("classification", 1) + descriptor("extra_byte_0", 1) + descriptor("a b", 1) + descriptor("a_b", 1));
  Bytes b(false);
  b.text(header_bytes({.minor = 2, .format = 0, .vlr_count = 1, .vlr_bytes = static_cast<std::uint32_t>(vlr.size()),
                       .record_length = 20 + 4 + 2}));
  b.text(vlr);
  xyz(b, 1, 2, 3);
  b.put<std::uint16_t>(0).put<std::uint8_t>(9).put<std::uint8_t>(2).put<std::uint32_t>(0);
  for (int k = 1; k <= 6; ++k) b.put<std::uint8_t>(static_cast<std::uint8_t>(k));
  write_file(dir / "names.las", b.str());
  const PointTable t = read_las(dir / "names.las");
  ASSERT_EQ(t.attributes.size(), 12u + 6u);
  const char* names[] = {"classification_2", "extra_byte_0", "a_b", "a_b_2", "extra_byte_0_2", "extra_byte_1"};
  for (int k = 0; k < 6; ++k) {
    EXPECT_EQ(t.attributes[12 + static_cast<std::size_t>(k)].name, names[k]);
    EXPECT_EQ(t.attributes[12 + static_cast<std::size_t>(k)].values[0], k + 1);
  }
  EXPECT_EQ(attr(t, "classification"), 2);
}

// Upper bound of a standard field's values in `format`, for the random round trips.
double field_max(int format, const Attribute& a) {
  const bool extended = format >= 6;
  if (a.name == "return_number" || a.name == "number_of_returns") return extended ? 15 : 7;
  if (a.name == "classification") return extended ? 255 : 31;
  if (a.name == "scanner_channel") return 3;
  if (a.name == "synthetic" || a.name == "key_point" || a.name == "withheld" || a.name == "overlap" ||
      a.name == "scan_direction_flag" || a.name == "edge_of_flight_line")
    return 1;
  return -1;  // the type's range
}

double random_value(ScalarType type, double max, std::mt19937_64& rng) {
  auto uniform = [&](double lo, double hi) { return std::floor(std::uniform_real_distribution<double>(lo, hi + 1)(rng)); };
  if (max >= 0) return uniform(0, max);
  switch (type) {
    case ScalarType::Int8: return uniform(-128, 127);
    case ScalarType::UInt8: return uniform(0, 255);
    case ScalarType::Int16: return uniform(-32768, 32767);
    case ScalarType::UInt16: return uniform(0, 65535);
    case ScalarType::Int32: return uniform(-2147483648.0, 2147483647.0);
    case ScalarType::UInt32: return uniform(0, 4294967295.0);
    case ScalarType::Float32: return static_cast<float>(std::normal_distribution<double>(0, 100)(rng));
    case ScalarType::Float64: return std::normal_distribution<double>(0, 1e6)(rng);
  }
  return 0;
}

class LasFormats : public ::testing::TestWithParam<int> {};

TEST_P(LasFormats, RoundTripsEveryFieldAndExtraBytesExactly) {
  const int format = GetParam();
  TempDir dir;
  std::mt19937_64 rng(static_cast<std::uint64_t>(format) + 11);
  const std::size_t n = 300;
  // Learn the format's fields by writing and reading a table with positions only.
  PointTable t;
  t.las = las_metadata(format >= 6 ? 4 : format >= 4 ? 3 : 2, format);
  t.quantization = PositionQuantization{Vec3(0.001, 0.002, 0.0005), Vec3(500000, 4000000, -20)};
  for (std::size_t i = 0; i < n; ++i) {
    t.positions.push_back(t.quantization->offset +
                          t.quantization->scale.cwiseProduct(Vec3(random_value(ScalarType::Int32, -1, rng),
                                                                  random_value(ScalarType::Int32, -1, rng),
                                                                  random_value(ScalarType::Int16, -1, rng))));
  }
  write_las(dir / "fields.las", t);
  PointTable full = read_las(dir / "fields.las");
  ASSERT_EQ(full.size(), n);
  const std::size_t field_count[] = {12, 13, 15, 16, 20, 23, 15, 18, 19, 22, 26};
  EXPECT_EQ(full.attributes.size(), field_count[format]);
  EXPECT_EQ(attr(full, "return_number"), 1);  // the default of a missing field
  for (Attribute& a : full.attributes) {
    const double max = a.name == "wave_data_offset" ? std::ldexp(1.0, 50) : field_max(format, a);
    for (double& v : a.values) v = random_value(a.type, max, rng);
  }
  full.set("amplitude", ScalarType::Float32, std::vector<double>(n, 0.0));
  full.set("sensor_id", ScalarType::UInt16, std::vector<double>(n, 0.0));
  full.set("height_above_ground", ScalarType::Float64, std::vector<double>(n, 0.0));
  for (std::size_t e = full.attributes.size() - 3; e < full.attributes.size(); ++e)
    for (double& v : full.attributes[e].values) v = random_value(full.attributes[e].type, -1, rng);

  write_las(dir / "a.las", full);
  const PointTable back = read_las(dir / "a.las");
  ASSERT_EQ(back.size(), n);
  for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(back.positions[i], full.positions[i]) << i;
  ASSERT_EQ(back.attributes.size(), full.attributes.size());
  for (std::size_t k = 0; k < full.attributes.size(); ++k) {
    EXPECT_EQ(back.attributes[k].name, full.attributes[k].name);
    EXPECT_EQ(back.attributes[k].type, full.attributes[k].type) << full.attributes[k].name;
    EXPECT_EQ(back.attributes[k].values, full.attributes[k].values) << full.attributes[k].name;
  }
  EXPECT_EQ(back.las->point_format, format);
  EXPECT_EQ(back.las->version_minor, t.las->version_minor);
  // Writing what was read reproduces the file byte for byte (same day, same software).
  write_las(dir / "b.las", back);
  EXPECT_EQ(read_file(dir / "b.las"), read_file(dir / "a.las"));
}

INSTANTIATE_TEST_SUITE_P(AllFormats, LasFormats, ::testing::Range(0, 11));

TEST(Las, PlyToLasToPlyKeepsPositionsWithinTheChosenScale) {
  TempDir dir;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0, 1);
  PointTable t;
  t.positions.push_back(Vec3(512345.678, 5400000.25, 0.125));  // the minimum: offsets 512345, 5.4e6, 0
  for (int i = 0; i < 500; ++i) t.positions.push_back(Vec3(512345.678 + 900 * u(rng), 5.4e6 + 900 * u(rng), 40 * u(rng)));
  std::vector<double> red(t.size()), label(t.size());
  for (std::size_t i = 0; i < t.size(); ++i) {
    red[i] = static_cast<double>(i % 256);
    label[i] = static_cast<double>(i % 7) - 3;
  }
  t.set("red", ScalarType::UInt8, red);
  t.set("label", ScalarType::Int32, label);
  write_points(dir / "in.ply", t);
  write_points(dir / "mid.las", read_points(dir / "in.ply"));
  const PointTable las = read_points(dir / "mid.las");
  ASSERT_TRUE(las.quantization.has_value());
  EXPECT_EQ(las.las->version_minor, 4);
  EXPECT_EQ(las.las->point_format, 7);  // red present
  const Vec3 scale = las.quantization->scale;
  for (int a = 0; a < 3; ++a) {
    EXPECT_LE(scale[a], 1e-4);  // sub-0.1 mm for metres
    EXPECT_GT(scale[a], 0);
  }
  EXPECT_EQ(las.quantization->offset, Vec3(512345, 5.4e6, 0));
  write_points(dir / "out.ply", las);
  const PointTable out = read_points(dir / "out.ply");
  ASSERT_EQ(out.size(), t.size());
  for (std::size_t i = 0; i < t.size(); ++i) {
    for (int a = 0; a < 3; ++a) ASSERT_LE(std::abs(out.positions[i][a] - t.positions[i][a]), 0.5 * scale[a] * (1 + 1e-6));
  }
  std::vector<double> red16 = red;
  for (double& v : red16) v *= 257;  // uint8 colours scaled to LAS's 16 bits
  EXPECT_EQ(out.find("red")->values, red16);
  EXPECT_EQ(out.find("label")->values, label);
  EXPECT_EQ(out.find("label")->type, ScalarType::Int32);
  EXPECT_EQ(out.find("return_number")->values, std::vector<double>(t.size(), 1.0));
}

TEST(Las, ChoosesTheFormatFromTheAttributes) {
  TempDir dir;
  PointTable t;
  t.positions = {Vec3(0, 0, 0), Vec3(1, 2, 3)};
  // Attributes that LAS 1.2 holds: 1.2, formats 0-3 (every reader takes them).
  write_las(dir / "plain.las", t);
  EXPECT_EQ(read_las(dir / "plain.las").las->version_minor, 2);
  EXPECT_EQ(read_las(dir / "plain.las").las->point_format, 0);
  t.set("intensity", ScalarType::UInt16, {7, 8});
  t.set("red", ScalarType::UInt8, {1, 2});
  write_las(dir / "rgb.las", t);
  EXPECT_EQ(read_las(dir / "rgb.las").las->version_minor, 2);
  EXPECT_EQ(read_las(dir / "rgb.las").las->point_format, 2);
  EXPECT_EQ(read_las(dir / "rgb.las").find("intensity")->values, (std::vector<double>{7, 8}));
  t.set("gps_time", ScalarType::Float64, {1.5, 2.5});
  write_las(dir / "rgb_gps.las", t);
  EXPECT_EQ(read_las(dir / "rgb_gps.las").las->point_format, 3);
  // Anything else (a class, normals as extra bytes): LAS 1.4, formats 6-10.
  t.attributes.clear();
  t.set("classification", ScalarType::UInt8, {2, 40});
  write_las(dir / "classes.las", t);
  EXPECT_EQ(read_las(dir / "classes.las").las->version_minor, 4);
  EXPECT_EQ(read_las(dir / "classes.las").las->point_format, 6);
  EXPECT_EQ(read_las(dir / "classes.las").find("classification")->values, (std::vector<double>{2, 40}));
  t.attributes.clear();
  t.set("nx", ScalarType::Float32, {0, 1});
  write_las(dir / "normals.las", t);
  EXPECT_EQ(read_las(dir / "normals.las").las->version_minor, 4);
  t.attributes.clear();
  t.set("nir", ScalarType::UInt16, {1, 2});
  write_las(dir / "nir.las", t);
  EXPECT_EQ(read_las(dir / "nir.las").las->point_format, 8);
  t.set("x_t", ScalarType::Float32, {1, 2});
  write_las(dir / "wave.las", t);
  EXPECT_EQ(read_las(dir / "wave.las").las->point_format, 10);
}

TEST(Las, ScaleFromTheExtentAtMostAMillimetre) {
  // A million steps or more across the largest extent, at most 1e-3, one scale for all axes.
  const auto scale = [](double extent) {
    return las_quantization_for(Vec3(10.25, -3.5, 0), Vec3(10.25 + extent, -3.5 + extent / 2, 1)).scale;
  };
  EXPECT_EQ(scale(3.0), Vec3::Constant(1e-6));      // a unit object
  EXPECT_EQ(scale(150.0), Vec3::Constant(1e-4));    // a building
  EXPECT_EQ(scale(2000.0), Vec3::Constant(1e-3));   // an airborne tile
  EXPECT_EQ(scale(5e6), Vec3::Constant(1e-2));      // beyond int32 at 1e-3
  EXPECT_EQ(las_quantization_for(Vec3(10.25, -3.5, 0), Vec3(11, 0, 1)).offset, Vec3(10, -4, 0));
}

TEST(Las, ConvertsTheScanAngleRankToTheScanAngle) {
  TempDir dir;
  PointTable t;
  t.positions = {Vec3(0, 0, 0), Vec3(1, 1, 1)};
  t.set("scan_angle_rank", ScalarType::Int8, {-90, 30});
  t.set("classification", ScalarType::UInt8, {1, 2});  // LAS 1.4
  write_las(dir / "a.las", t);  // format 6: units of 0.006 degrees
  const PointTable back = read_las(dir / "a.las");
  EXPECT_EQ(back.find("scan_angle_rank"), nullptr);
  EXPECT_EQ(back.find("scan_angle")->values, (std::vector<double>{-15000, 5000}));
}

TEST(Las, SaturatesValuesToTheFieldWidth) {
  TempDir dir;
  PointTable t;
  t.positions = {Vec3(0, 0, 0)};
  t.las = las_metadata(2, 0);
  t.set("classification", ScalarType::UInt8, {200});  // 5 bits in format 0
  t.set("intensity", ScalarType::Float32, {70000.4});
  write_las(dir / "a.las", t);
  const PointTable back = read_las(dir / "a.las");
  EXPECT_EQ(attr(back, "classification"), 31);
  EXPECT_EQ(attr(back, "intensity"), 65535);
  EXPECT_EQ(attr(back, "synthetic"), 0);  // the neighbouring bits stay clear
}

TEST(Las, WriteRefusesUnrepresentableTables) {
  TempDir dir;
  PointTable t;
  t.positions = {Vec3(0, 0, 0), Vec3(1, 1, 1)};
  t.quantization = PositionQuantization{Vec3(1e-9, 1e-9, 1e-9), Vec3(0, 0, 0)};
  t.positions[1].x() = 10;  // 1e10 units: beyond int32
  expect_io_error([&] { write_las(dir / "a.las", t); }, dir / "a.las", "outside the int32 range");
  t.quantization.reset();
  t.set(std::string(33, 'n'), ScalarType::UInt8, {0, 0});
  expect_io_error([&] { write_las(dir / "b.las", t); }, dir / "b.las", "32 characters");
  t.attributes.clear();
  t.las = las_metadata(2, 6);
  expect_io_error([&] { write_las(dir / "c.las", t); }, dir / "c.las", "cannot write point format 6 as LAS 1.2");
  EXPECT_TRUE(dir.entries().empty());
}

// A valid one-point format 0 file to break in the tests below.
std::string valid_format0(HeaderSpec spec = {}) {
  Bytes b(false);
  b.text(header_bytes(spec));
  for (std::uint64_t i = 0; i < std::min<std::uint64_t>(spec.count, 4); ++i) {
    xyz(b, 1, 2, 3);
    b.put<std::uint16_t>(0).put<std::uint8_t>(9).put<std::uint8_t>(2).put<std::uint32_t>(0);
  }
  return b.str();
}

class LasErrors : public ::testing::Test {
 protected:
  void expect(const std::string& bytes, std::string_view phrase, std::string_view name = "bad.las") {
    const fs::path file = dir_ / name;
    write_file(file, bytes);
    expect_io_error([&] { read_las(file); }, file, phrase);
    expect_io_error([&] { read_points(file); }, file, phrase);
  }
  TempDir dir_;
};

TEST_F(LasErrors, SignatureAndHeader) {
  EXPECT_EQ(read_las([&] { write_file(dir_ / "ok.las", valid_format0()); return dir_ / "ok.las"; }()).size(), 1u);
  std::string bytes = valid_format0();
  bytes[0] = 'X';
  expect(bytes, "signature LASF");
  expect("", "signature LASF");
  expect(valid_format0().substr(0, 100), "truncated header");
  expect(valid_format0({.minor = 4}).substr(0, 300), "truncated header");
  expect(valid_format0({.header_size = 200}), "header size 200 is smaller than the 227 bytes");
  expect(valid_format0({.header_size = 60000}).substr(0, 1000), "truncated header: header size 60000 exceeds the file size");
  expect(valid_format0({.minor = 4, .header_size = 300}), "header size 300 is smaller than the 375 bytes");
  bytes = valid_format0();
  bytes[25] = 9;
  expect(bytes, "unsupported LAS version 1.9");
}

TEST_F(LasErrors, PointFormatAndRecordLength) {
  std::string bytes = valid_format0();
  bytes[104] = 11;
  expect(bytes, "unknown point data format 11");
  expect(valid_format0({.record_length = 10}), "point record length 10 is smaller than the 20 bytes of point format 0");
  expect(valid_format0({.format_byte_bits = 0x80}), "the point format has the compression bit (LAZ) but there is no LASzip VLR");
}

TEST_F(LasErrors, CountsAndOffsets) {
  // 10^15 points in a 1.4 header: refused from the file size, without allocating them.
  expect(valid_format0({.minor = 4, .count = 1000000000000000}), "header declares 1000000000000000 points but the file holds only 4");
  std::string bytes = valid_format0({.count = 3});
  expect(bytes.substr(0, bytes.size() - 7), "header declares 3 points but the file holds only 2");
  expect(valid_format0({.point_offset_delta = 100000}), "beyond the end of the file");
  expect(valid_format0({.vlr_count = 1}), "1 VLRs do not fit");
  bytes = valid_format0({.vlr_count = 1, .vlr_bytes = 60});
  bytes.insert(227, vlr_bytes("x", 1, std::string(200, 'a')).substr(0, 60));
  expect(bytes, "VLR 0 (200 bytes) runs past the start of the point data");
}

TEST_F(LasErrors, ScalesAndExtraBytes) {
  expect(valid_format0({.scale = {0, 1, 1}}), "x scale factor 0");
  expect(valid_format0({.scale = {1, NAN, 1}}), "y scale factor");
  expect(valid_format0({.scale = {1e308, 1, 1}, .offset = {1e308, 0, 0}}), "non-finite coordinate");
  const std::string bad_size = vlr_bytes("LASF_Spec", 4, std::string(100, '\0'));
  std::string bytes = valid_format0({.vlr_count = 1, .vlr_bytes = static_cast<std::uint32_t>(bad_size.size())});
  bytes.insert(227, bad_size);
  expect(bytes, "not a whole number of 192-byte descriptors");
  const std::string too_many = vlr_bytes("LASF_Spec", 4, descriptor("big", 10));
  bytes = valid_format0({.vlr_count = 1, .vlr_bytes = static_cast<std::uint32_t>(too_many.size())});
  bytes.insert(227, too_many);
  expect(bytes, "describes more bytes than the 0 extra bytes");
  const std::string unknown = vlr_bytes("LASF_Spec", 4, descriptor("odd", 77));
  bytes = valid_format0({.vlr_count = 1, .vlr_bytes = static_cast<std::uint32_t>(unknown.size())});
  bytes.insert(227, unknown);
  expect(bytes, "unknown data type 77");
}

}  // namespace
}  // namespace pointfair::io
