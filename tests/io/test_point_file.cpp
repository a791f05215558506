#include <gtest/gtest.h>

#include <string>

#include "io_test_util.hpp"
#include "pointfair/io/point_file.hpp"

namespace pointfair::io {
namespace {

using testing::expect_io_error;
using testing::read_file;
using testing::TempDir;
using testing::write_file;

PointTable small_table() {
  PointTable table;
  table.position_type = ScalarType::Float32;
  table.positions = {Vec3(1, 2, 3), Vec3(-4, 0.5, 6)};
  table.set("intensity", ScalarType::Float32, {0.25, 0.75});
  return table;
}

TEST(PointFile, DispatchesOnExtensionCaseInsensitively) {
  TempDir dir;
  const PointTable table = small_table();
  const auto ply = dir / "cloud.PLY";
  write_points(ply, table);
  EXPECT_EQ(read_file(ply).substr(0, 36), "ply\nformat binary_little_endian 1.0\n");
  EXPECT_EQ(read_points(ply).positions, table.positions);

  for (const char* name : {"cloud.Xyz", "cloud.txt", "cloud.pts", "cloud.CSV"}) {
    const auto file = dir / name;
    write_points(file, table);
    const std::string text = read_file(file);
    EXPECT_EQ(text.substr(0, 15),
              std::string(name) == "cloud.CSV" ? "x,y,z,intensity" : "x y z intensity");
    const PointTable read = read_points(file);
    EXPECT_EQ(read.positions, table.positions) << name;
    EXPECT_EQ(read.find("intensity")->values, table.find("intensity")->values) << name;
  }
}

TEST(PointFile, PlyEncodingOptionIsUsed) {
  TempDir dir;
  const auto file = dir / "cloud.ply";
  WriteOptions options;
  options.ply_encoding = PlyEncoding::Ascii;
  write_points(file, small_table(), options);
  EXPECT_NE(read_file(file).find("format ascii 1.0\n"), std::string::npos);
  options.ply_encoding = PlyEncoding::BinaryBigEndian;
  write_points(file, small_table(), options);
  EXPECT_NE(read_file(file).find("format binary_big_endian 1.0\n"), std::string::npos);
  EXPECT_EQ(read_points(file).positions, small_table().positions);
}

TEST(PointFile, UnknownExtension) {
  TempDir dir;
  const auto file = dir / "cloud.foo";
  write_file(file, "1 2 3\n");
  const char* expected = "unknown file extension '.foo' (expected .ply, .las, .xyz, .txt, .pts, .csv or .asc)";
  expect_io_error([&] { read_points(file); }, file, expected);
  expect_io_error([&] { write_points(dir / "out.foo", small_table()); }, dir / "out.foo", expected);
  expect_io_error([&] { read_points(dir / "noextension"); }, dir / "noextension",
                  "unknown file extension ''");
}

TEST(PointFile, MissingFile) {
  TempDir dir;
  const auto file = dir / "missing.ply";
  expect_io_error([&] { read_points(file); }, file, "cannot open: No such file or directory");
  const auto text = dir / "missing.csv";
  expect_io_error([&] { read_points(text); }, text, "cannot open: No such file or directory");
}

TEST(PointFile, Hdf5IsNotSupportedYet) {
  TempDir dir;
  const auto file = dir / "scan.h5";
  expect_io_error([&] { read_points(file); }, file, "not supported by this build yet");
  expect_io_error([&] { write_points(file, small_table()); }, file, "not supported by this build yet");
}

TEST(PointFile, LasAndLazRoundTrip) {
  TempDir dir;
  for (const char* name : {"scan.LAS", "scan.LAZ"}) {
    const auto file = dir / name;
    write_points(file, small_table());
    const PointTable back = read_points(file);
    ASSERT_EQ(back.size(), small_table().size());
    EXPECT_TRUE(back.las.has_value());
  }
  EXPECT_EQ(dir.entries(), (std::vector<std::string>{"scan.LAS", "scan.LAZ"}));
}

TEST(PointFile, IsSupportedPointFile) {
  for (const char* name : {"a.ply", "a.PLY", "dir.d/a.xyz", "a.txt", "a.pts", "a.Csv", "a.las", "a.LAS", "a.laz", "a.LAZ"}) {
    EXPECT_TRUE(is_supported_point_file(name)) << name;
  }
  for (const char* name : {"a.h5", "a", "a.ply.gz", "ply"}) {
    EXPECT_FALSE(is_supported_point_file(name)) << name;
  }
}

TEST(PointFile, WriteRefusesToOverwriteTheInput) {
  TempDir dir;
  const auto file = dir / "cloud.ply";
  write_points(file, small_table());
  const std::string before = read_file(file);
  WriteOptions options;
  options.input = file;
  PointTable other = small_table();
  other.positions[0] = Vec3(9, 9, 9);
  expect_io_error([&] { write_points(file, other, options); }, file,
                  "output would overwrite the input");
  EXPECT_EQ(read_file(file), before);
  EXPECT_NO_THROW(write_points(dir / "smoothed.ply", other, options));
}

}  // namespace
}  // namespace pointfair::io
