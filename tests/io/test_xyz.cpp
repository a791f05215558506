#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "io_test_util.hpp"
#include "pointfair/io/xyz.hpp"

namespace pointfair::io {
namespace {

using testing::expect_io_error;
using testing::read_file;
using testing::same_bits;
using testing::TempDir;
using testing::write_file;

std::vector<std::string> names_of(const PointTable& table) {
  std::vector<std::string> names;
  for (const Attribute& attribute : table.attributes) names.push_back(attribute.name);
  return names;
}

PointTable make_table() {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> real(-1e4, 1e4);
  PointTable table;
  std::vector<double> intensity, label, nx;
  for (int i = 0; i < 40; ++i) {
    table.positions.emplace_back(real(rng), real(rng) / 3.0, real(rng) * 1e-9);
    intensity.push_back(real(rng) / 7.0);
    label.push_back(std::round(real(rng)));
    nx.push_back(real(rng) * 1e-300);
  }
  table.positions[0] = Vec3(0.1, -0.0, 5e-324);
  table.positions[1] = Vec3(1.7976931348623157e308, 1.0 / 3.0, -2.5e-17);
  table.set("intensity", ScalarType::Float64, intensity);
  table.set("Label", ScalarType::Float64, label);
  table.set("nx", ScalarType::Float64, nx);
  return table;
}

void expect_same_table(const PointTable& expected, const PointTable& actual) {
  ASSERT_EQ(expected.size(), actual.size());
  EXPECT_EQ(actual.position_type, ScalarType::Float64);
  for (std::size_t i = 0; i < expected.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      ASSERT_TRUE(same_bits(expected.positions[i][c], actual.positions[i][c])) << i << "," << c;
    }
  }
  ASSERT_EQ(names_of(expected), names_of(actual));
  for (std::size_t a = 0; a < expected.attributes.size(); ++a) {
    EXPECT_EQ(actual.attributes[a].type, ScalarType::Float64);
    for (std::size_t i = 0; i < expected.size(); ++i) {
      ASSERT_TRUE(same_bits(expected.attributes[a].values[i], actual.attributes[a].values[i]))
          << expected.attributes[a].name << "[" << i << "]";
    }
  }
}

TEST(Xyz, RoundTripWithAttributesAndHeader) {
  TempDir dir;
  const auto file = dir / "cloud.xyz";
  const PointTable table = make_table();
  write_xyz(file, table);
  EXPECT_EQ(read_file(file).substr(0, 22), "x y z intensity Label ");
  expect_same_table(table, read_xyz(file));
}

TEST(Xyz, CsvRoundTripUsesCommas) {
  TempDir dir;
  const auto file = dir / "cloud.csv";
  const PointTable table = make_table();
  write_xyz(file, table);
  EXPECT_EQ(read_file(file).substr(0, 26), "x,y,z,intensity,Label,nx\n0");
  expect_same_table(table, read_xyz(file));
}

TEST(Xyz, WithoutAttributesThereIsNoHeader) {
  TempDir dir;
  const auto file = dir / "plain.txt";
  PointTable table;
  table.positions = {Vec3(1, 2, 3), Vec3(-0.5, 1e-3, 7)};
  write_xyz(file, table);
  EXPECT_EQ(read_file(file), "1 2 3\n-0.5 0.001 7\n");
  expect_same_table(table, read_xyz(file));
}

TEST(Xyz, ThreeColumnsWithoutHeader) {
  TempDir dir;
  const auto file = dir / "three.xyz";
  write_file(file, "1 2 3\n\t4\t5  6 \n");
  const PointTable table = read_xyz(file);
  ASSERT_EQ(table.size(), 2U);
  EXPECT_EQ(table.positions[1], Vec3(4, 5, 6));
  EXPECT_TRUE(table.attributes.empty());
  EXPECT_EQ(table.position_type, ScalarType::Float64);
}

TEST(Xyz, SixColumnsWithoutHeaderAreNormals) {
  TempDir dir;
  const auto file = dir / "six.xyz";
  write_file(file, "1 2 3 0 0 1\n4 5 6 0 1 0\n");
  const PointTable table = read_xyz(file);
  ASSERT_EQ(table.size(), 2U);
  EXPECT_EQ(names_of(table), (std::vector<std::string>{"nx", "ny", "nz"}));
  EXPECT_EQ(table.find("ny")->values, (std::vector<double>{0, 1}));
}

TEST(Xyz, OtherExtraColumnsAreNamedByIndex) {
  TempDir dir;
  const auto four = dir / "four.txt";
  write_file(four, "1 2 3 9\n");
  EXPECT_EQ(names_of(read_xyz(four)), (std::vector<std::string>{"field_3"}));
  const auto seven = dir / "seven.txt";
  write_file(seven, "1 2 3 4 5 6 7\n");
  EXPECT_EQ(names_of(read_xyz(seven)),
            (std::vector<std::string>{"field_3", "field_4", "field_5", "field_6"}));
}

TEST(Xyz, CsvHeaderInAnyCaseAndOrder) {
  TempDir dir;
  const auto file = dir / "scan.csv";
  write_file(file, "\"Intensity\", Z, Y, X\n0.5, 3, 2, 1\n0.25,6,5,4\n");
  const PointTable table = read_xyz(file);
  ASSERT_EQ(table.size(), 2U);
  EXPECT_EQ(table.positions[0], Vec3(1, 2, 3));
  EXPECT_EQ(table.positions[1], Vec3(4, 5, 6));
  EXPECT_EQ(names_of(table), (std::vector<std::string>{"Intensity"}));
  EXPECT_EQ(table.attributes[0].values, (std::vector<double>{0.5, 0.25}));
}

TEST(Xyz, SemicolonsCommentsAndBlankLines) {
  TempDir dir;
  const auto file = dir / "semi.txt";
  write_file(file, "# exported\r\n\r\n1;2;3\r\n  # note\r\n4 ; 5 ; +6\r\n\r\n");
  const PointTable table = read_xyz(file);
  ASSERT_EQ(table.size(), 2U);
  EXPECT_EQ(table.positions[1], Vec3(4, 5, 6));
}

TEST(Xyz, PointCountLineIsSkipped) {
  TempDir dir;
  const auto file = dir / "scan.pts";
  write_file(file, "3\n1 2 3 10\n4 5 6 20\n");
  std::vector<std::string> warnings;
  ReadOptions options;
  options.on_warning = [&](const std::string& message) { warnings.push_back(message); };
  const PointTable table = read_xyz(file, options);
  ASSERT_EQ(table.size(), 2U);
  EXPECT_EQ(table.find("field_3")->values, (std::vector<double>{10, 20}));
  ASSERT_EQ(warnings.size(), 1U);
  EXPECT_NE(warnings[0].find("first line declares 3 points, the file has 2"), std::string::npos);
}

// Attributes follow the coordinates' rule (docs/hostile-inputs.md): a non-finite value is a
// read error naming the line (it used to be kept).
TEST(XyzErrors, NanAttributeNamesTheLine) {
  TempDir dir;
  const auto file = dir / "nan_attr.xyz";
  write_file(file, "1 2 3 nan\n");
  expect_io_error([&] { read_xyz(file); }, file, "line 1: 'nan' (column 4) is not a finite number");
}

TEST(XyzErrors, RaggedRowNamesTheLine) {
  TempDir dir;
  const auto file = dir / "ragged.xyz";
  write_file(file, "1 2 3\n# comment\n4 5 6\n7 8\n");
  expect_io_error([&] { read_xyz(file); }, file, "line 4: expected 3 columns, found 2");
}

TEST(XyzErrors, NanCoordinateNamesTheLine) {
  TempDir dir;
  const auto file = dir / "nan.xyz";
  write_file(file, "1 2 3\n1 NaN 3\n");
  expect_io_error([&] { read_xyz(file); }, file, "line 2: non-finite coordinate (nan)");
  const auto inf = dir / "inf.csv";
  write_file(inf, "x,y,z\n1,2,-inf\n");
  expect_io_error([&] { read_xyz(inf); }, inf, "line 2: non-finite coordinate (-inf)");
}

TEST(XyzErrors, ValueThatIsNotANumber) {
  TempDir dir;
  const auto file = dir / "word.xyz";
  write_file(file, "1 2 3\n4 five 6\n");
  expect_io_error([&] { read_xyz(file); }, file, "line 2: 'five' is not a number");
  const auto empty_field = dir / "empty_field.csv";
  write_file(empty_field, "1,2,3\n4,,6\n");
  expect_io_error([&] { read_xyz(empty_field); }, empty_field, "line 2: '' is not a number");
}

TEST(XyzErrors, HeaderWithoutZ) {
  TempDir dir;
  const auto file = dir / "noz.csv";
  write_file(file, "x,y,intensity\n1,2,3\n");
  expect_io_error([&] { read_xyz(file); }, file, "line 1: header lacks column z");
}

TEST(XyzErrors, TooFewColumns) {
  TempDir dir;
  const auto file = dir / "two.xyz";
  write_file(file, "# two columns\n1 2\n");
  expect_io_error([&] { read_xyz(file); }, file, "line 2: expected at least 3 columns");
}

TEST(XyzErrors, EmptyOrCommentOnlyFile) {
  TempDir dir;
  const auto empty = dir / "empty.xyz";
  write_file(empty, "");
  expect_io_error([&] { read_xyz(empty); }, empty, "empty file");
  const auto comments = dir / "comments.xyz";
  write_file(comments, "# nothing\n\n");
  expect_io_error([&] { read_xyz(comments); }, comments, "no points");
}

TEST(XyzErrors, MissingFile) {
  TempDir dir;
  const auto file = dir / "missing.xyz";
  expect_io_error([&] { read_xyz(file); }, file, "cannot open: No such file or directory");
}

TEST(XyzErrors, WriteRefusesNamesThatWouldNotReadBack) {
  TempDir dir;
  const auto file = dir / "names.csv";
  PointTable table;
  table.positions = {Vec3(1, 2, 3)};
  table.set("a,b", ScalarType::Float64, {1});
  expect_io_error([&] { write_xyz(file, table); }, file, "attribute name 'a,b' cannot be written");
  table.attributes.clear();
  table.set("X", ScalarType::Float64, {1});
  expect_io_error([&] { write_xyz(file, table); }, file,
                  "attribute name 'X' clashes with a coordinate");
  table.attributes.clear();
  table.positions[0].z() = std::nan("");
  expect_io_error([&] { write_xyz(file, table); }, file,
                  "point 0 has a non-finite coordinate (nan)");
  EXPECT_TRUE(dir.entries().empty());
}

}  // namespace
}  // namespace pointfair::io

// ---- The source's layout comes back: read_xyz then write_xyz reproduces the text. ----

namespace pointfair::io {
namespace {

std::string round_trip(const TempDir& dir, const std::string& name, const std::string& text) {
  write_file(dir / name, text);
  write_xyz(dir / ("out-" + name), read_xyz(dir / name));
  return read_file(dir / ("out-" + name));
}

TEST(XyzLayout, HeaderlessThreeColumnsStayHeaderless) {
  TempDir dir;
  const std::string text = "500100.125 4200000.500 12.000\n500100.250 4200000.750 12.125\n";
  EXPECT_EQ(round_trip(dir, "scan.xyz", text), text);
}

TEST(XyzLayout, CommaCsvWithHeaderKeepsNamesOrderAndSpelling) {
  TempDir dir;
  const std::string text =
      "X,Y,Z,Red,Green,Blue,Intensity,Classification\n"
      "500100.125,4200000.500,12.000,255,128,0,0.50,2\n"
      "500100.250,4200000.750,12.125,0,64,255,1.25,6\n";
  EXPECT_EQ(round_trip(dir, "scan.csv", text), text);
}

TEST(XyzLayout, TabSemicolonQuotedHeaderCountLineAndCrlfAreKept) {
  TempDir dir;
  const std::string tabs = "x\ty\tz\tintensity\n1.0\t2.0\t3.0\t17\n4.0\t5.0\t6.0\t18\n";
  EXPECT_EQ(round_trip(dir, "tabs.txt", tabs), tabs);
  const std::string semicolons = "\"x\"; \"y\"; \"z\"; \"Point Source\"\r\n1.5; 2.5; 3.5; 7\r\n";
  EXPECT_EQ(round_trip(dir, "semi.csv", semicolons), semicolons);
  const std::string pts = "2\n1 2 3 100 10 20 30\n4 5 6 -200 40 50 60\n";
  EXPECT_EQ(round_trip(dir, "scan.pts", pts), pts);
}

TEST(XyzLayout, HeaderlessSixColumnsAreNotMistakenForNormals) {
  TempDir dir;
  // Six columns without a header read as x y z nx ny nz, but nothing says they are normals.
  const std::string text = "1 2 3 255 0 128\n4 5 6 0 255 64\n";
  EXPECT_EQ(round_trip(dir, "rgb.xyz", text), text);
}

TEST(XyzLayout, MovedValuesStayExactAndOtherSpellingsComeBackShortest) {
  TempDir dir;
  write_file(dir / "in.xyz", "x y z a b\n1.50 2 3 1e3 0.10\n1.25 2 3 7 0.1\n");
  PointTable table = read_xyz(dir / "in.xyz");
  table.positions[0].x() = 1.0 / 3.0;  // moved: needs every digit
  write_xyz(dir / "out.xyz", table);
  // "1e3" is not fixed notation: shortest; "0.1" under a 2-decimal column: "0.10" (same value).
  EXPECT_EQ(read_file(dir / "out.xyz"),
            "x y z a b\n0.3333333333333333 2 3 1000 0.10\n1.25 2 3 7 0.10\n");
}

TEST(XyzLayout, ColumnsAddedToAHeaderlessFileFollowWithoutAHeader) {
  TempDir dir;
  write_file(dir / "in.xyz", "1 2 3\n4 5 6\n");
  PointTable table = read_xyz(dir / "in.xyz");
  table.set("k1", ScalarType::Float32, {0.5, -0.25});
  write_xyz(dir / "out.xyz", table);
  EXPECT_EQ(read_file(dir / "out.xyz"), "1 2 3 0.5\n4 5 6 -0.25\n");
}

TEST(XyzLayout, ColumnsAddedToAFileWithHeaderAreNamedAfterItsOwn) {
  TempDir dir;
  write_file(dir / "in.csv", "x;y;z;i\n1;2;3;9\n");
  PointTable table = read_xyz(dir / "in.csv");
  table.set("red", ScalarType::UInt8, {255});
  write_xyz(dir / "out.csv", table);
  EXPECT_EQ(read_file(dir / "out.csv"), "x;y;z;i;red\n1;2;3;9;255\n");
}

TEST(XyzCloudCompare, AsciiExportIsReadWithItsColoursNormalsAndScalarFields) {
  TempDir dir;
  // As CloudCompare 2.11 writes it (-C_EXPORT_FMT ASC -ADD_HEADER; with -SEP COMMA as well).
  const std::string text =
      "//X Y Z R G B k2 Nx Ny Nz\n"
      "0.000000 0.000000 0.000000 255 0 10 2.500000 0.000978 0.000978 0.999999\n"
      "1.000000 0.000000 0.000000 0 255 20 2.500000 0.000978 0.000978 0.999999\n";
  for (const char* name : {"cloud.asc", "cloud.txt"}) {
    write_file(dir / name, text);
    const PointTable table = read_xyz(dir / name);
    ASSERT_EQ(table.size(), 2U);
    EXPECT_EQ(table.positions[1], Vec3(1, 0, 0));
    EXPECT_EQ(names_of(table), (std::vector<std::string>{"red", "green", "blue", "k2", "nx", "ny", "nz"}));
    EXPECT_EQ(table.find("green")->values, (std::vector<double>{0, 255}));
    EXPECT_EQ(table.find("nz")->values[0], 0.999999);
    // Written back: the same text, header included.
    EXPECT_EQ(round_trip(dir, name, text), text);
  }
  write_file(dir / "comma.asc", "//X,Y,Z,R,G,B\n1,2,3,4,5,6\n");
  EXPECT_EQ(names_of(read_xyz(dir / "comma.asc")), (std::vector<std::string>{"red", "green", "blue"}));
}

TEST(XyzCloudCompare, AscOutputGetsCloudComparesHeader) {
  TempDir dir;
  PointTable table;
  table.positions = {Vec3(1, 2, 3), Vec3(4, 5, 6)};
  table.set("nx", ScalarType::Float32, {0, 1});
  table.set("ny", ScalarType::Float32, {0, 0});
  table.set("nz", ScalarType::Float32, {1, 0});
  table.set("red", ScalarType::UInt8, {255, 0});
  table.set("k1", ScalarType::Float32, {0.5, -0.25});
  write_xyz(dir / "out.asc", table);
  EXPECT_EQ(read_file(dir / "out.asc"), "//X Y Z Nx Ny Nz R k1\n1 2 3 0 0 1 255 0.5\n4 5 6 1 0 0 0 -0.25\n");
  // Read back under our names.
  EXPECT_EQ(names_of(read_xyz(dir / "out.asc")), (std::vector<std::string>{"nx", "ny", "nz", "red", "k1"}));
  // Other text files keep our names.
  write_xyz(dir / "out.xyz", table);
  EXPECT_EQ(read_file(dir / "out.xyz").substr(0, 19), "x y z nx ny nz red ");
}

}  // namespace
}  // namespace pointfair::io
