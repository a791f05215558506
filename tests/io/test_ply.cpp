#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "io_test_util.hpp"
#include "pointfair/io/ply.hpp"

namespace pointfair::io {
namespace {

using testing::Bytes;
using testing::expect_io_error;
using testing::read_file;
using testing::same_bits;
using testing::TempDir;
using testing::write_file;

template <typename T>
double lowest() {
  return static_cast<double>(std::numeric_limits<T>::lowest());
}
template <typename T>
double highest() {
  return static_cast<double>(std::numeric_limits<T>::max());
}

// Values of every kind a file can hold, including each type's extremes, so a lossy
// conversion anywhere shows up as a bit difference.
PointTable make_table(ScalarType position_type, std::size_t count = 64) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> real(-1000.0, 1000.0);
  std::uniform_int_distribution<int> byte(0, 255);
  const bool single = position_type == ScalarType::Float32;
  const auto as_float = [](double v) { return static_cast<double>(static_cast<float>(v)); };

  PointTable table;
  table.position_type = position_type;
  for (std::size_t i = 0; i < count; ++i) {
    Vec3 p(real(rng), real(rng) * 1e-6, real(rng) * 1e6);
    if (single) p = p.unaryExpr(as_float);
    table.positions.push_back(p);
  }
  table.positions[0] = Vec3(0.0, -0.0, single ? 1.401298464324817e-45 : 5e-324);
  table.positions[1] = single ? Vec3(3.4028234663852886e38, -1.0, 0.1f)
                              : Vec3(1.7976931348623157e308, 0.1, 1.0 / 3.0);

  std::vector<double> red, green, blue, intensity, label, count16, weight, flag, shorts, id;
  for (std::size_t i = 0; i < count; ++i) {
    red.push_back(byte(rng));
    green.push_back(byte(rng));
    blue.push_back(byte(rng));
    intensity.push_back(as_float(real(rng)));
    label.push_back(std::round(real(rng) * 1e6));
    count16.push_back(byte(rng) * 257.0);
    weight.push_back(real(rng) / 7.0);
    flag.push_back(byte(rng) - 128.0);
    shorts.push_back((byte(rng) - 128.0) * 256.0);
    id.push_back(std::round(real(rng) * 1e6) + 2e9);
  }
  red[0] = 0;
  red[1] = 255;
  label[0] = lowest<std::int32_t>();
  label[1] = highest<std::int32_t>();
  count16[0] = highest<std::uint16_t>();
  weight[0] = 0.1;
  weight[1] = -1e-300;
  flag[0] = lowest<std::int8_t>();
  flag[1] = highest<std::int8_t>();
  shorts[0] = lowest<std::int16_t>();
  shorts[1] = highest<std::int16_t>();
  id[0] = highest<std::uint32_t>();
  id[1] = 0;
  table.set("red", ScalarType::UInt8, red);
  table.set("green", ScalarType::UInt8, green);
  table.set("blue", ScalarType::UInt8, blue);
  table.set("intensity", ScalarType::Float32, intensity);
  table.set("label", ScalarType::Int32, label);
  table.set("count", ScalarType::UInt16, count16);
  table.set("weight", ScalarType::Float64, weight);
  table.set("flag", ScalarType::Int8, flag);
  table.set("shorts", ScalarType::Int16, shorts);
  table.set("id", ScalarType::UInt32, id);
  return table;
}

void expect_same_table(const PointTable& expected, const PointTable& actual) {
  ASSERT_EQ(expected.size(), actual.size());
  EXPECT_EQ(expected.position_type, actual.position_type);
  for (std::size_t i = 0; i < expected.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      ASSERT_TRUE(same_bits(expected.positions[i][c], actual.positions[i][c]))
          << "point " << i << " coordinate " << c << ": " << expected.positions[i][c]
          << " != " << actual.positions[i][c];
    }
  }
  ASSERT_EQ(expected.attributes.size(), actual.attributes.size());
  for (std::size_t a = 0; a < expected.attributes.size(); ++a) {
    const Attribute& want = expected.attributes[a];
    const Attribute& got = actual.attributes[a];
    EXPECT_EQ(want.name, got.name);
    EXPECT_EQ(want.type, got.type) << want.name;
    ASSERT_EQ(want.values.size(), got.values.size()) << want.name;
    for (std::size_t i = 0; i < want.values.size(); ++i) {
      ASSERT_TRUE(same_bits(want.values[i], got.values[i]))
          << want.name << "[" << i << "]: " << want.values[i] << " != " << got.values[i];
    }
  }
}

struct RoundTripCase {
  PlyEncoding encoding;
  ScalarType position_type;
};

class PlyRoundTrip : public ::testing::TestWithParam<RoundTripCase> {};

TEST_P(PlyRoundTrip, PreservesValuesNamesTypesAndOrder) {
  TempDir dir;
  const PointTable table = make_table(GetParam().position_type);
  const auto file = dir / "cloud.ply";
  write_ply(file, table, GetParam().encoding);
  std::vector<std::string> warnings;
  ReadOptions options;
  options.on_warning = [&](const std::string& message) { warnings.push_back(message); };
  expect_same_table(table, read_ply(file, options));
  EXPECT_TRUE(warnings.empty());
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"cloud.ply"});
}

INSTANTIATE_TEST_SUITE_P(
    AllEncodings, PlyRoundTrip,
    ::testing::Values(RoundTripCase{PlyEncoding::Ascii, ScalarType::Float32},
                      RoundTripCase{PlyEncoding::Ascii, ScalarType::Float64},
                      RoundTripCase{PlyEncoding::BinaryLittleEndian, ScalarType::Float32},
                      RoundTripCase{PlyEncoding::BinaryLittleEndian, ScalarType::Float64},
                      RoundTripCase{PlyEncoding::BinaryBigEndian, ScalarType::Float32},
                      RoundTripCase{PlyEncoding::BinaryBigEndian, ScalarType::Float64}),
    [](const ::testing::TestParamInfo<RoundTripCase>& case_info) {
      const RoundTripCase& param = case_info.param;
      std::string name = param.encoding == PlyEncoding::Ascii                ? "Ascii"
                         : param.encoding == PlyEncoding::BinaryLittleEndian ? "BinaryLittleEndian"
                                                                             : "BinaryBigEndian";
      name += param.position_type == ScalarType::Float32 ? "Float" : "Double";
      return name;
    });

std::vector<std::string> read_collecting_warnings(const std::filesystem::path& file,
                                                  PointTable& table) {
  std::vector<std::string> warnings;
  ReadOptions options;
  options.on_warning = [&](const std::string& message) { warnings.push_back(message); };
  table = read_ply(file, options);
  return warnings;
}

TEST(PlyRead, HandWrittenAsciiWithFace) {
  TempDir dir;
  const auto file = dir / "hand.ply";
  write_file(file,
             "ply\n"
             "format ascii 1.0\n"
             "comment made by hand\n"
             "obj_info scanner 3\n"
             "element vertex 3\n"
             "property float x\n"
             "property float y\n"
             "property float z\n"
             "property uchar red\n"
             "element face 1\n"
             "property list uchar int vertex_indices\n"
             "end_header\n"
             "0 0 0 255\n"
             "1.5 0 -2 128\n"
             "\n"
             "0 +1 0.25 0\n"
             "3 0 1 2\n");
  PointTable table;
  const auto warnings = read_collecting_warnings(file, table);
  ASSERT_EQ(table.size(), 3U);
  EXPECT_EQ(table.position_type, ScalarType::Float32);
  EXPECT_EQ(table.positions[1], Vec3(1.5, 0, -2));
  EXPECT_EQ(table.positions[2], Vec3(0, 1, 0.25));
  ASSERT_EQ(table.attributes.size(), 1U);
  EXPECT_EQ(table.attributes[0].name, "red");
  EXPECT_EQ(table.attributes[0].type, ScalarType::UInt8);
  EXPECT_EQ(table.attributes[0].values, (std::vector<double>{255, 128, 0}));
  ASSERT_EQ(warnings.size(), 1U);
  EXPECT_EQ(warnings[0], file.string() + ": 1 face ignored");
}

TEST(PlyRead, CrlfHeaderAndBody) {
  TempDir dir;
  const auto file = dir / "crlf.ply";
  write_file(file,
             "ply\r\nformat ascii 1.0\r\nelement vertex 2\r\nproperty double x\r\n"
             "property double y\r\nproperty double z\r\nend_header\r\n1 2 3\r\n4 5 6\r\n");
  const PointTable table = read_ply(file);
  ASSERT_EQ(table.size(), 2U);
  EXPECT_EQ(table.position_type, ScalarType::Float64);
  EXPECT_EQ(table.positions[1], Vec3(4, 5, 6));
}

// Big-endian, sized type names, coordinates out of order and mixed float/double, and two
// skipped elements (one with a list, one fixed-size) around the vertices.
TEST(PlyRead, HandWrittenBigEndianWithFacesAndEdges) {
  TempDir dir;
  const auto file = dir / "big.ply";
  Bytes bytes(/*big_endian=*/true);
  bytes.text(
      "ply\n"
      "format binary_big_endian 1.0\n"
      "comment sized type names\n"
      "element face 2\n"
      "property list uint8 int32 vertex_indices\n"
      "property int16 tag\n"
      "element vertex 2\n"
      "property float64 z\n"
      "property int16 temperature\n"
      "property float32 x\n"
      "property float32 y\n"
      "property uint8 quality\n"
      "element edge 1\n"
      "property int32 vertex1\n"
      "property int32 vertex2\n"
      "end_header\n");
  bytes.put<std::uint8_t>(3).put<std::int32_t>(0).put<std::int32_t>(1).put<std::int32_t>(1);
  bytes.put<std::int16_t>(-7);
  bytes.put<std::uint8_t>(0).put<std::int16_t>(9);
  bytes.put(0.125).put<std::int16_t>(-300).put(1.5f).put(-2.25f).put<std::uint8_t>(200);
  bytes.put(-1e10).put<std::int16_t>(32767).put(3.0f).put(4.0f).put<std::uint8_t>(0);
  bytes.put<std::int32_t>(0).put<std::int32_t>(1);
  write_file(file, bytes.str());

  PointTable table;
  const auto warnings = read_collecting_warnings(file, table);
  ASSERT_EQ(table.size(), 2U);
  EXPECT_EQ(table.position_type, ScalarType::Float64);
  EXPECT_EQ(table.positions[0], Vec3(1.5, -2.25, 0.125));
  EXPECT_EQ(table.positions[1], Vec3(3.0, 4.0, -1e10));
  ASSERT_EQ(table.attributes.size(), 2U);
  EXPECT_EQ(table.attributes[0].name, "temperature");
  EXPECT_EQ(table.attributes[0].type, ScalarType::Int16);
  EXPECT_EQ(table.attributes[0].values, (std::vector<double>{-300, 32767}));
  EXPECT_EQ(table.attributes[1].name, "quality");
  EXPECT_EQ(table.attributes[1].type, ScalarType::UInt8);
  EXPECT_EQ(table.attributes[1].values, (std::vector<double>{200, 0}));
  EXPECT_EQ(warnings, (std::vector<std::string>{file.string() + ": 2 faces ignored",
                                                file.string() + ": 1 edge ignored"}));
}

TEST(PlyRead, ExtraBinaryDataIsAWarning) {
  TempDir dir;
  const auto file = dir / "extra.ply";
  Bytes bytes(/*big_endian=*/false);
  bytes.text(
      "ply\nformat binary_little_endian 1.0\nelement vertex 1\n"
      "property float x\nproperty float y\nproperty float z\nend_header\n");
  bytes.put(1.0f).put(2.0f).put(3.0f).text("abc");
  write_file(file, bytes.str());
  PointTable table;
  const auto warnings = read_collecting_warnings(file, table);
  ASSERT_EQ(table.size(), 1U);
  ASSERT_EQ(warnings.size(), 1U);
  EXPECT_NE(warnings[0].find("3 bytes of extra data"), std::string::npos) << warnings[0];
}

const char* const kXyzFloatHeader =
    "element vertex 1000\nproperty float x\nproperty float y\nproperty float z\nend_header\n";

std::string binary_header(const std::string& count) {
  return "ply\nformat binary_little_endian 1.0\nelement vertex " + count +
         "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
}

TEST(PlyRead, ShortestPossibleAsciiBody) {
  TempDir dir;
  const auto file = dir / "tight.ply";
  write_file(file,
             "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
             "property float z\nend_header\n1 2 3\n4 5 6");
  EXPECT_EQ(read_ply(file).positions[1], Vec3(4, 5, 6));
}

TEST(PlyReadErrors, EmptyFile) {
  TempDir dir;
  const auto file = dir / "empty.ply";
  write_file(file, "");
  expect_io_error([&] { read_ply(file); }, file, "empty file");
}

TEST(PlyReadErrors, MissingMagic) {
  TempDir dir;
  const auto file = dir / "magic.ply";
  write_file(file, "OFF\n3 1 0\n");
  expect_io_error([&] { read_ply(file); }, file, "not a PLY file (missing 'ply' magic)");
}

TEST(PlyReadErrors, BadFormatLine) {
  TempDir dir;
  const auto file = dir / "format.ply";
  write_file(file, std::string("ply\nformat binary_middle_endian 1.0\n") + kXyzFloatHeader);
  expect_io_error([&] { read_ply(file); }, file,
                  "bad format line 'format binary_middle_endian 1.0' in line 2");
}

TEST(PlyReadErrors, HeaderWithoutEndHeader) {
  TempDir dir;
  const auto file = dir / "noend.ply";
  write_file(file, "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n");
  expect_io_error([&] { read_ply(file); }, file, "header ends without end_header");
}

TEST(PlyReadErrors, NoVertexElement) {
  TempDir dir;
  const auto file = dir / "novertex.ply";
  write_file(file,
             "ply\nformat ascii 1.0\nelement face 0\nproperty list uchar int v\nend_header\n");
  expect_io_error([&] { read_ply(file); }, file, "no vertex element");
}

TEST(PlyReadErrors, VertexWithoutZ) {
  TempDir dir;
  const auto file = dir / "noz.ply";
  write_file(file,
             "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
             "end_header\n1 2\n");
  expect_io_error([&] { read_ply(file); }, file, "vertex element lacks property z");
}

TEST(PlyReadErrors, IntegerCoordinate) {
  TempDir dir;
  const auto file = dir / "intx.ply";
  write_file(file,
             "ply\nformat ascii 1.0\nelement vertex 1\nproperty int x\nproperty float y\n"
             "property float z\nend_header\n1 2 3\n");
  expect_io_error([&] { read_ply(file); }, file, "vertex property x has type int");
}

TEST(PlyReadErrors, UnknownPropertyType) {
  TempDir dir;
  const auto file = dir / "float16.ply";
  write_file(file,
             "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float16 y\n"
             "property float z\nend_header\n1 2 3\n");
  expect_io_error([&] { read_ply(file); }, file, "unknown property type 'float16' in line 5");
}

TEST(PlyReadErrors, ListInVertex) {
  TempDir dir;
  const auto file = dir / "list.ply";
  write_file(file,
             "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
             "property float z\nproperty list uchar float extra\nend_header\n1 2 3 1 4\n");
  expect_io_error([&] { read_ply(file); }, file, "vertex property 'extra' is a list");
}

TEST(PlyReadErrors, TruncatedBinaryBody) {
  TempDir dir;
  const auto file = dir / "truncated.ply";
  Bytes bytes(/*big_endian=*/false);
  bytes.text(binary_header("1000"));
  for (int i = 0; i < 412 * 3; ++i) bytes.put(1.0f);
  bytes.put(1.0f).put(2.0f);  // half a record
  write_file(file, bytes.str());
  expect_io_error([&] { read_ply(file); }, file,
                  "truncated binary body: expected 1000 vertices, file ends after 412");
}

TEST(PlyReadErrors, BinaryHeaderCountLargerThanBody) {
  TempDir dir;
  const auto file = dir / "short.ply";
  Bytes bytes(/*big_endian=*/true);
  bytes.text(
      "ply\nformat binary_big_endian 1.0\nelement vertex 10\nproperty double x\n"
      "property double y\nproperty double z\nend_header\n");
  for (int i = 0; i < 4 * 3; ++i) bytes.put(1.0);
  write_file(file, bytes.str());
  expect_io_error([&] { read_ply(file); }, file, "expected 10 vertices, file ends after 4");
}

TEST(PlyReadErrors, AsciiHeaderCountLargerThanBody) {
  TempDir dir;
  const auto file = dir / "short_ascii.ply";
  write_file(file,
             "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\n"
             "property float z\nend_header\n0.000 1.000 2.000\n3.000 4.000 5.000\n"
             "6.000 7.000 8.000\n");
  expect_io_error([&] { read_ply(file); }, file,
                  "truncated ascii body: expected 5 vertices, file ends after 3");
}

TEST(PlyReadErrors, TruncatedFaceList) {
  TempDir dir;
  const auto file = dir / "faces.ply";
  Bytes bytes(/*big_endian=*/false);
  bytes.text(
      "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\n"
      "property float y\nproperty float z\nelement face 2\n"
      "property list uchar int vertex_indices\nend_header\n");
  bytes.put(1.0f).put(2.0f).put(3.0f);
  bytes.put<std::uint8_t>(3).put(0).put(0).put(0);
  bytes.put<std::uint8_t>(3).put(0);
  write_file(file, bytes.str());
  expect_io_error([&] { read_ply(file); }, file, "expected 2 faces, file ends after 1");
}

TEST(PlyReadErrors, AsciiNanCoordinate) {
  TempDir dir;
  const auto file = dir / "nan.ply";
  write_file(file,
             "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
             "property float z\nend_header\n0 0 0\nnan 0 0\n");
  expect_io_error([&] { read_ply(file); }, file,
                  "vertex 1 has a non-finite coordinate (nan) in line 9");
}

TEST(PlyReadErrors, BinaryNanCoordinate) {
  TempDir dir;
  const auto file = dir / "nan_binary.ply";
  Bytes bytes(/*big_endian=*/false);
  bytes.text(binary_header("3"));
  bytes.put(0.0f).put(0.0f).put(0.0f);
  bytes.put(0.0f).put(0.0f).put(0.0f);
  bytes.put(0.0f).put(std::numeric_limits<float>::quiet_NaN()).put(0.0f);
  write_file(file, bytes.str());
  expect_io_error([&] { read_ply(file); }, file, "vertex 2 has a non-finite coordinate (nan)");
}

TEST(PlyReadErrors, BinaryInfiniteCoordinate) {
  TempDir dir;
  const auto file = dir / "inf_binary.ply";
  Bytes bytes(/*big_endian=*/false);
  bytes.text(binary_header("1"));
  bytes.put(-std::numeric_limits<float>::infinity()).put(0.0f).put(0.0f);
  write_file(file, bytes.str());
  expect_io_error([&] { read_ply(file); }, file, "vertex 0 has a non-finite coordinate (-inf)");
}

TEST(PlyReadErrors, AsciiValueNotANumber) {
  TempDir dir;
  const auto file = dir / "word.ply";
  write_file(file,
             "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
             "property float z\nend_header\n1 two 3\n");
  expect_io_error([&] { read_ply(file); }, file, "line 8: 'two' is not a valid float");
}

TEST(PlyReadErrors, AsciiValueOutOfRangeForType) {
  TempDir dir;
  const auto file = dir / "range.ply";
  write_file(file,
             "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
             "property float z\nproperty uchar red\nend_header\n1 2 3 300\n");
  expect_io_error([&] { read_ply(file); }, file, "'300' is not a valid uchar (property 'red')");
}

TEST(PlyReadErrors, AsciiRowWithTooFewValues) {
  TempDir dir;
  const auto file = dir / "few.ply";
  write_file(file,
             "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
             "property float z\nend_header\n1.0 2.0 3.0\n4.0 5.0\n");
  expect_io_error([&] { read_ply(file); }, file, "line 9: vertex 1 has fewer than 3 values");
}

// A corrupt count must be rejected by comparing it with the file size, not by trying to
// allocate for it.
// The count is checked against the file size before anything is allocated: a 10^15 count
// must give the truncation error, not std::bad_alloc.
TEST(PlyReadErrors, AbsurdVertexCountFailsBeforeAllocating) {
  TempDir dir;
  const auto binary = dir / "huge.ply";
  Bytes bytes(/*big_endian=*/false);
  bytes.text(binary_header("1000000000000000"));
  for (int i = 0; i < 30; ++i) bytes.put(1.0f);
  write_file(binary, bytes.str());
  const auto ascii = dir / "huge_ascii.ply";
  write_file(ascii,
             "ply\nformat ascii 1.0\nelement vertex 1000000000000000\nproperty float x\n"
             "property float y\nproperty float z\nend_header\n1 2 3\n");

  expect_io_error([&] { read_ply(binary); }, binary,
                  "expected 1000000000000000 vertices, file ends after 10");
  expect_io_error([&] { read_ply(ascii); }, ascii, "header declares 1000000000000000 vertices");
}

TEST(PlyReadErrors, MissingFile) {
  TempDir dir;
  const auto file = dir / "missing.ply";
  expect_io_error([&] { read_ply(file); }, file, "cannot open: No such file or directory");
}

TEST(PlyWrite, HeaderNamesEveryPropertyWithItsType) {
  TempDir dir;
  const auto file = dir / "header.ply";
  PointTable table;
  table.position_type = ScalarType::Float32;
  table.positions = {Vec3(1, 2, 3)};
  table.set("red", ScalarType::UInt8, {7});
  table.set("confidence", ScalarType::Float64, {0.5});
  write_ply(file, table, PlyEncoding::Ascii);
  EXPECT_EQ(read_file(file),
            "ply\n"
            "format ascii 1.0\n"
            "comment generated by pointfair\n"
            "element vertex 1\n"
            "property float x\n"
            "property float y\n"
            "property float z\n"
            "property uchar red\n"
            "property double confidence\n"
            "end_header\n"
            "1 2 3 7 0.5\n");
}

TEST(PlyWrite, IntegerAttributesAreRoundedAndSaturated) {
  for (const PlyEncoding encoding :
       {PlyEncoding::Ascii, PlyEncoding::BinaryLittleEndian, PlyEncoding::BinaryBigEndian}) {
    TempDir dir;
    const auto file = dir / "round.ply";
    PointTable table;
    table.positions.assign(5, Vec3::Zero());
    table.set("red", ScalarType::UInt8, {300.7, -5, 2.5, 127.4, std::nan("")});
    table.set("small", ScalarType::Int8, {-3.6, -200, 1e300, -0.4, 0.5});
    table.set("id", ScalarType::UInt32, {4294967295.6, 1e12, -1, 1.5, 4e9});
    write_ply(file, table, encoding);
    const PointTable read = read_ply(file);
    EXPECT_EQ(read.find("red")->values, (std::vector<double>{255, 0, 3, 127, 0}));
    EXPECT_EQ(read.find("small")->values, (std::vector<double>{-4, -128, 127, 0, 1}));
    EXPECT_EQ(read.find("id")->values, (std::vector<double>{4294967295, 4294967295, 0, 2, 4e9}));
  }
}

TEST(PlyWrite, RefusesTablesItCouldNotReadBack) {
  TempDir dir;
  const auto file = dir / "bad.ply";
  PointTable table;
  table.positions = {Vec3(0, 0, 0), Vec3(0, std::numeric_limits<double>::infinity(), 0)};
  expect_io_error([&] { write_ply(file, table); }, file,
                  "point 1 has a non-finite coordinate (inf)");

  table.positions[1] = Vec3(1, 1, 1);
  table.set("short", ScalarType::Float32, {1.0});
  expect_io_error([&] { write_ply(file, table); }, file,
                  "attribute 'short' has 1 values for 2 points");

  table.attributes.clear();
  table.set("two words", ScalarType::Float32, {1.0, 2.0});
  expect_io_error([&] { write_ply(file, table); }, file,
                  "attribute name 'two words' cannot be written");

  table.attributes.clear();
  table.position_type = ScalarType::Float32;
  table.positions[1] = Vec3(1e300, 0, 0);
  expect_io_error([&] { write_ply(file, table); }, file, "beyond the range of float");
  EXPECT_TRUE(dir.entries().empty());
}

// A million points through the block reader and writer (speed is measured in bench/, not here).
TEST(PlyWrite, MillionPointBinaryRoundTrip) {
  TempDir dir;
  const auto file = dir / "million.ply";
  PointTable table;
  table.position_type = ScalarType::Float32;
  const std::size_t count = 1'000'000;
  table.positions.resize(count);
  std::vector<double> intensity(count);
  for (std::size_t i = 0; i < count; ++i) {
    const auto v = static_cast<double>(static_cast<float>(static_cast<double>(i) * 0.001));
    table.positions[i] = Vec3(v, -v, 0.5 * v);
    intensity[i] = static_cast<double>(i % 4096);
  }
  table.set("intensity", ScalarType::Float32, std::move(intensity));

  write_ply(file, table);
  const PointTable read = read_ply(file);
  ASSERT_EQ(read.size(), count);
  EXPECT_EQ(read.positions[count - 1], table.positions[count - 1]);
  EXPECT_EQ(read.attributes[0].values[4097], 1.0);
}

}  // namespace
}  // namespace pointfair::io

// ---- The source's layout comes back: encoding, comments, property types and order. ----

namespace pointfair::io {
namespace {

TEST(PlyLayout, AsciiWithCommentsAndInterleavedPropertiesComesBackAsItWas) {
  TempDir dir;
  const std::string text =
      "ply\n"
      "format ascii 1.0\n"
      "comment scanner: T-1000\n"
      "obj_info site 12\n"
      "element vertex 2\n"
      "property uchar red\n"
      "property float x\n"
      "property float y\n"
      "property float z\n"
      "property ushort intensity\n"
      "property uchar green\n"
      "property uchar blue\n"
      "end_header\n"
      "255 1.5 2 3 40000 0 7\n"
      "0 -1 0.25 8 12 255 9\n";
  write_file(dir / "in.ply", text);
  write_ply(dir / "out.ply", read_ply(dir / "in.ply"));
  EXPECT_EQ(read_file(dir / "out.ply"), text);
}

TEST(PlyLayout, BinaryBigEndianStaysSoUnlessAnEncodingIsGiven) {
  TempDir dir;
  PointTable table;
  table.positions = {Vec3(1, 2, 3)};
  table.position_type = ScalarType::Float32;
  table.set("red", ScalarType::UInt8, {200});
  write_ply(dir / "be.ply", table, PlyEncoding::BinaryBigEndian);
  const PointTable read = read_ply(dir / "be.ply");
  ASSERT_TRUE(read.ply.has_value());
  EXPECT_EQ(read.ply->encoding, PlyEncoding::BinaryBigEndian);
  write_ply(dir / "kept.ply", read);
  EXPECT_EQ(read_file(dir / "kept.ply"), read_file(dir / "be.ply"));
  write_ply(dir / "ascii.ply", read, PlyEncoding::Ascii);
  EXPECT_NE(read_file(dir / "ascii.ply").find("format ascii 1.0\n"), std::string::npos);
}

TEST(PlyLayout, AttributesAddedAfterTheSourceOnesAndWithoutOurComment) {
  TempDir dir;
  write_file(dir / "in.ply",
             "ply\nformat ascii 1.0\nelement vertex 1\nproperty double x\nproperty double y\n"
             "property double z\nproperty float nx\nend_header\n1 2 3 0.5\n");
  PointTable table = read_ply(dir / "in.ply");
  table.set("k1", ScalarType::Float32, {-2});
  write_ply(dir / "out.ply", table);
  EXPECT_EQ(read_file(dir / "out.ply"),
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty double x\nproperty double y\n"
            "property double z\nproperty float nx\nproperty float k1\nend_header\n1 2 3 0.5 -2\n");
}

}  // namespace
}  // namespace pointfair::io
