// Every committed fuzz input (the seed corpus and each input that once made a fuzzer fail,
// tests/fuzz/regressions) through the readers of this build, with or without libFuzzer:
// the outcome is a table with finite coordinates or an IoError.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "pointfair/io/las.hpp"
#include "pointfair/io/mesh.hpp"
#include "pointfair/io/ply.hpp"
#include "pointfair/io/xyz.hpp"

namespace fs = std::filesystem;
using namespace pointfair;

namespace {

std::vector<fs::path> inputs(const std::string& target) {
  std::vector<fs::path> files;
  for (const char* kind : {"corpus", "regressions"}) {
    const fs::path dir = fs::path(POINTFAIR_FUZZ_DIR) / kind / target;
    if (!fs::exists(dir)) continue;
    for (const auto& e : fs::directory_iterator(dir)) files.push_back(e.path());
  }
  return files;
}

template <class Read>
void table_or_io_error(const fs::path& file, Read read) {
  SCOPED_TRACE(file.string());
  try {
    const io::PointTable t = read(file);
    for (const Vec3& p : t.positions) ASSERT_TRUE(p.allFinite());
    for (const io::Attribute& a : t.attributes) ASSERT_EQ(a.values.size(), t.size());
  } catch (const io::IoError&) {
  }
}

template <class Read>
void mesh_or_io_error(const fs::path& file, Read read) {
  SCOPED_TRACE(file.string());
  try {
    const TriangleMesh m = read(file);
    for (const auto& t : m.triangles)
      for (const Index i : t) ASSERT_LT(i, m.vertices.size());
  } catch (const io::IoError&) {
  }
}

}  // namespace

TEST(FuzzInputs, PlyReadersGiveATableOrAnIoError) {
  const auto files = inputs("ply");
  EXPECT_FALSE(files.empty());
  for (const fs::path& f : files) {
    table_or_io_error(f, [](const fs::path& p) { return io::read_ply(p); });
    mesh_or_io_error(f, [](const fs::path& p) { return io::read_ply_mesh(p); });
  }
}

TEST(FuzzInputs, TextReadersGiveATableOrAnIoError) {
  const auto files = inputs("xyz");
  EXPECT_FALSE(files.empty());
  for (const fs::path& f : files) {
    table_or_io_error(f, [](const fs::path& p) { return io::read_xyz(p); });
    mesh_or_io_error(f, [](const fs::path& p) { return io::read_off_mesh(p); });
  }
}

TEST(FuzzInputs, LasReaderGivesATableOrAnIoError) {
  const auto files = inputs("las");
  EXPECT_FALSE(files.empty());
  for (const fs::path& f : files) table_or_io_error(f, [](const fs::path& p) { return io::read_las(p); });
}
