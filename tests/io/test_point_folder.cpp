// A folder of point files: which files it holds, in which order, and their positions read as
// one cloud.
#include "pointfair/io/point_folder.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "io_test_util.hpp"
#include "pointfair/io/point_file.hpp"

namespace pointfair::io {
namespace {

namespace fs = std::filesystem;
using testing::expect_io_error;
using testing::TempDir;
using testing::write_file;

PointTable cloud(std::size_t count, double base) {
  PointTable t;
  for (std::size_t i = 0; i < count; ++i) t.positions.emplace_back(base + static_cast<double>(i), 0.5, -1.0);
  t.set("intensity", ScalarType::UInt16, std::vector<double>(count, 7.0));
  return t;
}

TEST(PointFolder, TakesPointFilesDirectlyInItInByteOrderOfTheirNames) {
  TempDir dir;
  for (const char* name : {"b.xyz", "B.LAS", "a.ply", "c.laz"}) write_points(dir / name, cloud(2, 0.0));
  write_file(dir / "notes.txt", "1 2 3\n");
  write_file(dir / ".hidden.ply", "");
  write_file(dir / "a.ply.tmp-1-2", "");
  fs::create_directories(dir / "sub.ply");
  write_points(dir / "sub.ply" / "d.ply", cloud(2, 0.0));
  std::vector<std::string> names;
  for (const fs::path& p : point_files_in(dir.path())) names.push_back(p.filename().string());
  EXPECT_EQ(names, (std::vector<std::string>{"B.LAS", "a.ply", "b.xyz", "c.laz"}));
}

TEST(PointFolder, AFolderWithoutPointFilesIsAnErrorNamingIt) {
  TempDir dir;
  expect_io_error([&] { point_files_in(dir.path()); }, dir.path(), "holds no point file");
  write_file(dir / "readme.txt", "notes\n");
  expect_io_error([&] { point_files_in(dir.path()); }, dir.path(), "holds no point file");
  expect_io_error([&] { point_files_in(dir / "readme.txt"); }, dir / "readme.txt", "is not a folder");
}

TEST(PointFolder, ReaderGivesThePositionsOfEveryFileInOrderAcrossChunks) {
  TempDir dir;
  write_points(dir / "1.ply", cloud(5, 0.0));
  write_points(dir / "2.xyz", cloud(3, 100.0));
  write_points(dir / "3.ply", cloud(4, 200.0));
  const auto files = point_files_in(dir.path());
  const auto reader = open_folder_reader(files);
  EXPECT_EQ(reader->count(), std::nullopt);  // a text file declares no count
  EXPECT_TRUE(reader->schema().attributes.empty());
  std::vector<Vec3> all;
  PointTable chunk;
  while (reader->read(chunk, 4) > 0) all.insert(all.end(), chunk.positions.begin(), chunk.positions.end());
  std::vector<Vec3> expected;
  for (const fs::path& f : files) {
    const PointTable t = read_points(f);
    expected.insert(expected.end(), t.positions.begin(), t.positions.end());
  }
  EXPECT_EQ(all, expected);
  EXPECT_EQ(reader->points_read(), 12u);

  fs::remove(dir / "2.xyz");
  EXPECT_EQ(open_folder_reader(point_files_in(dir.path()))->count(), std::optional<std::uint64_t>(9));
}

TEST(PointFolder, ABadFileIsNamedByTheReader) {
  TempDir dir;
  write_points(dir / "1.ply", cloud(5, 0.0));
  write_file(dir / "2.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 3\n");
  expect_io_error([&] { open_folder_reader(point_files_in(dir.path())); }, dir / "2.ply", "");
}

TEST(PointFolder, DigestTellsChangedFilesApart) {
  TempDir dir;
  write_points(dir / "1.ply", cloud(5, 0.0));
  write_points(dir / "2.ply", cloud(5, 1.0));
  const std::string before = folder_digest(point_files_in(dir.path()));
  EXPECT_EQ(folder_digest(point_files_in(dir.path())), before);
  fs::rename(dir / "2.ply", dir / "3.ply");
  EXPECT_NE(folder_digest(point_files_in(dir.path())), before);
  write_points(dir / "3.ply", cloud(5, 2.0));
  EXPECT_NE(folder_digest(point_files_in(dir.path())), before);
}

}  // namespace
}  // namespace pointfair::io
