// LasWriteOptions: the version, the integer grid and the coordinate system of a LAS output.
#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

#include "io_test_util.hpp"
#include "pointfair/io/las.hpp"

namespace pointfair::io {
namespace {

using testing::expect_io_error;
using testing::read_file;
using testing::TempDir;

// Four points with the fields of LAS 1.4's format 7 (classes above 31 only where asked).
PointTable scan_table(double top_class = 6) {
  PointTable t;
  t.positions = {Vec3(600000.125, 200000.5, 410.25), Vec3(600001.5, 200001.25, 411), Vec3(600002, 200000, 409.5),
                 Vec3(600003.75, 200002.5, 410)};
  t.set("intensity", ScalarType::UInt16, {10, 20, 30, 40});
  t.set("return_number", ScalarType::UInt8, {1, 2, 1, 3});
  t.set("number_of_returns", ScalarType::UInt8, {2, 2, 1, 3});
  t.set("classification", ScalarType::UInt8, {2, top_class, 2, 6});
  t.set("overlap", ScalarType::UInt8, {0, 1, 0, 0});
  t.set("gps_time", ScalarType::Float64, {1.5, 2.5, 3.5, 4.5});
  t.set("red", ScalarType::UInt16, {256, 512, 0, 65535});
  t.set("green", ScalarType::UInt16, {1, 2, 3, 4});
  t.set("blue", ScalarType::UInt16, {5, 6, 7, 8});
  return t;
}

// The 16-bit words of a record's payload.
std::vector<int> words(const std::string& data) {
  std::vector<int> out;
  for (std::size_t i = 0; i + 1 < data.size(); i += 2) {
    out.push_back(static_cast<unsigned char>(data[i]) | (static_cast<unsigned char>(data[i + 1]) << 8));
  }
  return out;
}

const LasRecord* find_record(const PointTable& t, std::uint16_t id) {
  for (const LasRecord& r : t.las->records) {
    if (r.user_id == "LASF_Projection" && r.record_id == id) return &r;
  }
  return nullptr;
}

TEST(LasWriteOptions, ScaleAndOffsetSetTheStoredIntegers) {
  TempDir dir;
  const PointTable t = scan_table();
  write_las(dir / "a.las", t, {.scale = Vec3(0.01, 0.01, 0.001), .offset = Vec3(600000, 200000, 0)});
  const PointTable back = read_las(dir / "a.las");
  ASSERT_TRUE(back.quantization);
  EXPECT_EQ(back.quantization->scale, Vec3(0.01, 0.01, 0.001));
  EXPECT_EQ(back.quantization->offset, Vec3(600000, 200000, 0));
  for (std::size_t i = 0; i < t.size(); ++i) {
    EXPECT_NEAR(back.positions[i].x(), t.positions[i].x(), 0.005 + 1e-9) << i;
    EXPECT_NEAR(back.positions[i].z(), t.positions[i].z(), 0.0005 + 1e-9) << i;
  }
  // The first x, 600000.125, is 12.5 hundredths above the offset: stored as 13.
  EXPECT_DOUBLE_EQ(back.positions[0].x(), 600000.13);
  // A grid on which a point lies beyond int32 is an error naming it.
  expect_io_error([&] { write_las(dir / "b.las", t, {.scale = Vec3::Constant(1e-6), .offset = Vec3::Zero()}); },
                  dir / "b.las", "outside the int32 range");
  EXPECT_FALSE(std::filesystem::exists(dir / "b.las"));
}

TEST(LasWriteOptions, ConvertsLas14IntoLas12FieldByField) {
  TempDir dir;
  write_las(dir / "a14.las", scan_table(), {.version_minor = 4});
  const PointTable source = read_las(dir / "a14.las");
  ASSERT_EQ(source.las->version_minor, 4);
  ASSERT_EQ(source.las->point_format, 7);
  write_las(dir / "a12.las", source, {.version_minor = 2});
  const PointTable back = read_las(dir / "a12.las");
  EXPECT_EQ(back.las->version_minor, 2);
  EXPECT_EQ(back.las->point_format, 3);  // gps_time and colours
  EXPECT_EQ(back.las->global_encoding & 16, 0);  // the WKT bit is 1.4's
  EXPECT_EQ(back.positions, source.positions);
  for (const char* name : {"intensity", "return_number", "number_of_returns", "classification", "gps_time", "red",
                           "blue", "overlap", "scanner_channel"}) {
    ASSERT_NE(back.find(name), nullptr) << name;
    EXPECT_EQ(back.find(name)->values, source.find(name)->values) << name;
  }
  // And back into 1.4: the same fields again.
  write_las(dir / "b14.las", back, {.version_minor = 4});
  const PointTable again = read_las(dir / "b14.las");
  EXPECT_EQ(again.las->point_format, 7);
  EXPECT_EQ(again.find("classification")->values, source.find("classification")->values);
  EXPECT_EQ(again.find("return_number")->values, source.find("return_number")->values);
}

TEST(LasWriteOptions, AValueBeyondANarrowerFieldIsAnErrorNotClipped) {
  TempDir dir;
  const PointTable t = scan_table(40);  // class 40: 1.4 holds it, 1.2's 5 bits do not
  expect_io_error([&] { write_las(dir / "a.las", t, {.version_minor = 2}); }, dir / "a.las",
                  "point 1: classification 40 does not fit the 5 bits");
  EXPECT_FALSE(std::filesystem::exists(dir / "a.las"));
  write_las(dir / "b.las", t, {.version_minor = 4});
  EXPECT_EQ(read_las(dir / "b.las").find("classification")->values[1], 40);
  // The streaming writer checks each chunk as it comes.
  PointTable schema = t;
  schema.positions.clear();
  for (Attribute& a : schema.attributes) a.values.clear();
  auto writer = open_las_writer(dir / "c.las", schema, t.size(),
                                {.version_minor = 2, .scale = Vec3::Constant(0.01), .offset = Vec3::Zero()});
  expect_io_error([&] { writer->write(t); }, dir / "c.las", "classification 40");
  writer.reset();
  EXPECT_FALSE(std::filesystem::exists(dir / "c.las"));
  // Wave packets have no 1.2 format.
  PointTable wave = scan_table();
  wave.set("wave_packet_index", ScalarType::UInt8, {0, 0, 0, 0});
  expect_io_error([&] { write_las(dir / "d.las", wave, {.version_minor = 2}); }, dir / "d.las", "wave packets");
}

TEST(LasWriteOptions, StreamsWithAGivenGridAsWriteLasWrites) {
  TempDir dir;
  const PointTable t = scan_table();
  const LasWriteOptions options{.version_minor = 2, .scale = Vec3::Constant(0.001), .offset = Vec3(600000, 200000, 400)};
  write_las(dir / "whole.las", t, options);
  PointTable schema = t;
  schema.positions.clear();
  for (Attribute& a : schema.attributes) a.values.clear();
  auto writer = open_las_writer(dir / "chunks.las", schema, t.size(), options);
  for (std::size_t first = 0; first < t.size(); first += 3) {
    PointTable chunk = schema;
    for (std::size_t i = first; i < std::min(t.size(), first + 3); ++i) {
      chunk.positions.push_back(t.positions[i]);
      for (std::size_t a = 0; a < t.attributes.size(); ++a) chunk.attributes[a].values.push_back(t.attributes[a].values[i]);
    }
    writer->write(chunk);
  }
  writer->finish();
  EXPECT_EQ(read_file(dir / "chunks.las"), read_file(dir / "whole.las"));
}

TEST(LasWriteOptions, CoordinateSystemAsWktInLas14AndGeoKeysInLas12) {
  TempDir dir;
  const LasCoordinateSystem crs{.wkt = "PROJCS[\"CH1903+ / LV95\",AUTHORITY[\"EPSG\",\"2056\"]]",
                                .geo_keys = {{3072, 2056}, {1024, 1}, {1025, 1}}};
  write_las(dir / "a14.las", scan_table(), {.version_minor = 4, .crs = crs});
  const PointTable a14 = read_las(dir / "a14.las");
  EXPECT_NE(a14.las->global_encoding & 16, 0);
  ASSERT_NE(find_record(a14, 2112), nullptr);
  EXPECT_EQ(find_record(a14, 2112)->data, crs.wkt + '\0');
  EXPECT_EQ(find_record(a14, 34735), nullptr);

  write_las(dir / "a12.las", scan_table(), {.version_minor = 2, .crs = crs});
  const PointTable a12 = read_las(dir / "a12.las");
  ASSERT_NE(find_record(a12, 34735), nullptr);
  EXPECT_EQ(find_record(a12, 2112), nullptr);
  // Version 1.1.0, 3 keys, sorted by id, each at location 0 with count 1.
  EXPECT_EQ(words(find_record(a12, 34735)->data),
            (std::vector<int>{1, 1, 0, 3, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, 2056}));

  // A source's coordinate system records are replaced; its other records are kept.
  PointTable source = a12;
  source.las->records.push_back({"LASF_Projection", 34736, "doubles", std::string(8, '\0'), false});
  source.las->records.push_back({"survey", 7, "notes", "kept as it is", false});
  const LasCoordinateSystem utm{.wkt = {}, .geo_keys = {{1024, 1}, {3072, 32633}}};
  write_las(dir / "b12.las", source, {.crs = utm});
  const PointTable b12 = read_las(dir / "b12.las");
  EXPECT_EQ(find_record(b12, 34736), nullptr);
  ASSERT_NE(find_record(b12, 34735), nullptr);
  EXPECT_EQ(words(find_record(b12, 34735)->data), (std::vector<int>{1, 1, 0, 2, 1024, 0, 1, 1, 3072, 0, 1, 32633}));
  ASSERT_EQ(b12.las->records.size(), 2u);
  EXPECT_EQ(b12.las->records[1].data, "kept as it is");
  // Without WKT, a 1.4 file of formats 6-10 cannot hold it.
  expect_io_error([&] { write_las(dir / "c14.las", source, {.version_minor = 4, .crs = utm}); }, dir / "c14.las",
                  "no WKT");
}

}  // namespace
}  // namespace pointfair::io
