// The streaming import: a container the out-of-core run accepts and whose run is bit-identical
// to the in-core run, tiles within max_tile_points, rows in input order inside each tile,
// memory within the budget, plain HDF5 that h5ls and h5dump read.
#include "pointfair/tiles/import.hpp"

#include <cstdio>
#include <cstring>
#include <limits>
#include <set>
#include <string>

#include "pointfair/common/params_error.hpp"
#include "pointfair/io/las.hpp"
#include "pointfair/io/point_file.hpp"
#include "pointfair/tiles/tiled_smooth.hpp"
#include "tiles_test_util.hpp"

using namespace pointfair;
using namespace pointfair::tiles;

namespace {

using test::few_steps;

class ImportTest : public test::TempDirTest {
 protected:
  // The cloud as a point file; returns the table read back (the reference's input).
  io::PointTable write_cloud(const std::string& name, const io::PointTable& cloud,
                             io::PlyEncoding encoding = io::PlyEncoding::BinaryLittleEndian) {
    io::WriteOptions w;
    w.ply_encoding = encoding;
    io::write_points(path(name), cloud, w);
    return io::read_points(path(name));
  }
};

StreamImportOptions streamed(const TilingParams& tiling, std::size_t read_chunk = 100) {
  StreamImportOptions o;
  o.container = test::tiled(tiling, 512);
  o.memory_budget = std::uint64_t{16} << 20;
  o.read_chunk_points = read_chunk;
  return o;
}

// Rows grouped by tile within max_tile_points, exact bounds, original indices ascending in
// each tile and a permutation overall; and the container reads back as the input.
void expect_well_formed(const std::filesystem::path& file, const io::PointTable& input, std::uint64_t max_tile) {
  const h5::File f = h5::File::open(file, false);
  const TileTable tiles = read_tile_table(f);
  const auto order = f.dataset(layout::original_index).read_all<std::uint64_t>();
  const auto xyz = f.dataset(layout::positions).read_all<double>();
  ASSERT_EQ(order.size(), input.size());
  std::vector<char> seen(input.size(), 0);
  for (std::size_t t = 0; t < tiles.size(); ++t) {
    EXPECT_LE(tiles.rows(t), max_tile) << "tile " << t;
    Box b = bounds_of({});
    for (std::uint64_t r = tiles.offsets[t]; r < tiles.offsets[t + 1]; ++r) {
      if (r > tiles.offsets[t]) {
        EXPECT_LT(order[r - 1], order[r]) << "rows follow the input order in a tile";
      }
      ASSERT_LT(order[r], input.size());
      EXPECT_EQ(seen[order[r]]++, 0);
      const Vec3 p(xyz[3 * r], xyz[3 * r + 1], xyz[3 * r + 2]);
      EXPECT_EQ(p, input.positions[order[r]]);
      for (std::size_t c = 0; c < 3; ++c) {
        b[c] = std::min(b[c], p[static_cast<Eigen::Index>(c)]);
        b[c + 3] = std::max(b[c + 3], p[static_cast<Eigen::Index>(c)]);
      }
    }
    EXPECT_EQ(b, tiles.bounds[t]) << "tile " << t << ": bounds are exact";
  }
  const io::PointTable back = read_container(file);
  EXPECT_EQ(back.positions, input.positions);
  ASSERT_EQ(back.attributes.size(), input.attributes.size());
  for (std::size_t a = 0; a < input.attributes.size(); ++a) {
    EXPECT_EQ(back.attributes[a].name, input.attributes[a].name);
    EXPECT_EQ(back.attributes[a].type, input.attributes[a].type);
    EXPECT_EQ(back.attributes[a].values, input.attributes[a].values);
  }
}

TEST_F(ImportTest, StreamedContainerRunsBitIdenticalToInCore) {
  const io::PointTable input = write_cloud("in.ply", test::noisy_cube(3000, 31));
  const SmoothParams params = few_steps();
  const test::InCore ref = test::run_in_core(input, params);
  struct Case {
    const char* name;
    TilingParams tiling;
    std::size_t read_chunk;
  };
  const Case cases[] = {
      {"one tile", {.max_tile_points = 1u << 20}, 1u << 16},
      {"kd 400, chunks of 7", {.max_tile_points = 400}, 7},
      {"kd 15 (tiny tiles), chunks of 1", {.max_tile_points = 15}, 1},
      {"grid with empty tiles", {.cell_size = 0.3}, 100},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const StreamImportReport report = import_points(path("in.ply"), path("in.h5"), streamed(c.tiling, c.read_chunk));
    EXPECT_EQ(report.points, 3000u);
    EXPECT_EQ(report.attributes, input.attributes.size());
    expect_well_formed(path("in.h5"), input, c.tiling.cell_size > 0 ? 3000 : c.tiling.max_tile_points);
    const OutOfCoreReport r = smooth_out_of_core(path("in.h5"), path("run.h5"), params);
    EXPECT_TRUE(r.finished);
    EXPECT_EQ(r.lambda, ref.report.lambda);
    test::expect_identical(path("run.h5"), ref);
    std::filesystem::remove(path("run.h5"));
  }
}

TEST_F(ImportTest, EveryFormatGivesTheSameContainerContents) {
  const io::PointTable cloud = test::noisy_cube(800, 32);
  for (const char* name : {"a.ply", "b.xyz", "c.csv"}) {
    for (const auto encoding : {io::PlyEncoding::Ascii, io::PlyEncoding::BinaryBigEndian}) {
      SCOPED_TRACE(name);
      const io::PointTable input = write_cloud(name, cloud, encoding);
      import_points(path(name), path("c.h5"), streamed({.max_tile_points = 50}, 13));
      expect_well_formed(path("c.h5"), input, 50);
    }
  }
}

TEST_F(ImportTest, LasInputKeepsItsGridThroughImportAndExport) {
  const io::PointTable input = write_cloud("in.las", test::noisy_cube(700, 40));
  ASSERT_TRUE(input.quantization);
  import_points(path("in.las"), path("las.h5"), streamed({.max_tile_points = 100}, 64));
  expect_well_formed(path("las.h5"), input, 100);
  const io::PointTable back = read_container(path("las.h5"));
  ASSERT_TRUE(back.quantization && back.las);
  EXPECT_EQ(back.quantization->scale, input.quantization->scale);
  EXPECT_EQ(back.quantization->offset, input.quantization->offset);
  EXPECT_EQ(back.las->point_format, input.las->point_format);
}

TEST_F(ImportTest, ASelectionImportsItsPointsOnlyCountedInInputOrder) {
  io::PointTable cloud = test::noisy_cube(900, 41);
  std::vector<double> classes(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) classes[i] = i % 3 == 0 ? 6.0 : 2.0;
  cloud.set("classification", io::ScalarType::UInt8, classes);
  const io::PointTable input = write_cloud("in.las", cloud);
  StreamImportOptions options = streamed({.max_tile_points = 100}, 64);
  options.select.classes.set(6);
  const StreamImportReport report = import_points(path("in.las"), path("sel.h5"), options);
  EXPECT_EQ(report.points, 300u);
  // The container is the import of a file holding the class-6 points alone.
  io::PointTable only = input;
  only.positions.clear();
  for (auto& a : only.attributes) a.values.clear();
  for (std::size_t i = 0; i < input.size(); i += 3) {
    only.positions.push_back(input.positions[i]);
    for (std::size_t a = 0; a < input.attributes.size(); ++a) only.attributes[a].values.push_back(input.attributes[a].values[i]);
  }
  expect_well_formed(path("sel.h5"), only, 100);
  options.select.classes.reset();
  options.select.classes.set(9);  // no such point: an empty container
  EXPECT_EQ(import_points(path("in.las"), path("none.h5"), options).points, 0u);
}

TEST_F(ImportTest, ACellDenserThanATileIsCutInInputOrder) {
  // 3000 copies of one point and a sparse rest: no grid cell can separate the copies.
  io::PointTable cloud = test::noisy_cube(600, 33);
  for (int i = 0; i < 3000; ++i) cloud.positions.push_back(Vec3(0.25, 0.5, 1.0));
  for (auto& a : cloud.attributes) a.values.resize(cloud.positions.size(), 1.0);
  const io::PointTable input = write_cloud("dense.ply", cloud);
  const StreamImportReport report = import_points(path("dense.ply"), path("d.h5"), streamed({.max_tile_points = 256}));
  EXPECT_GE(report.split_cell_tiles, 3000u / 256);
  expect_well_formed(path("d.h5"), input, 256);
}

TEST_F(ImportTest, MemoryStaysWithinTheBudgetForACloudLargerThanTheBuffer) {
  // 300,000 points with two attributes: more than the scatter buffer of a 16 MiB budget
  // holds (most of the budget goes to the histogram and the reader), so it is written out
  // several times, and what the import holds stays within the budget.
  const io::PointTable input = write_cloud("big.ply", test::noisy_cube(300000, 34));
  StreamImportOptions o = streamed({.max_tile_points = 20000}, 4096);
  const StreamImportReport report = import_points(path("big.ply"), path("big.h5"), o);
  EXPECT_LE(report.peak_accounted_bytes, o.memory_budget);
  EXPECT_GT(report.peak_accounted_bytes, o.memory_budget / 2) << "the scatter buffer takes what the budget leaves";
  EXPECT_GE(report.flushes, 2u);
  expect_well_formed(path("big.h5"), input, 20000);
  // A budget below the minimum is a parameter error, before any output exists.
  o.memory_budget = std::uint64_t{8} << 20;
  EXPECT_THROW(import_points(path("big.ply"), path("big2.h5"), o), ParamError);
  EXPECT_FALSE(std::filesystem::exists(path("big2.h5")));
}

TEST_F(ImportTest, DeflateGivesTheSameRun) {
  const io::PointTable input = write_cloud("in.ply", test::noisy_cube(4000, 36));
  const SmoothParams params = few_steps(2);
  StreamImportOptions plain = streamed({.max_tile_points = 700});
  StreamImportOptions deflated = plain;
  deflated.container.deflate = 4;
  import_points(path("in.ply"), path("plain.h5"), plain);
  import_points(path("in.ply"), path("deflated.h5"), deflated);
  expect_well_formed(path("deflated.h5"), input, 700);
  // No staging file is left behind.
  std::size_t files = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir_)) ++files;
  EXPECT_EQ(files, 3u);
  smooth_out_of_core(path("plain.h5"), path("run_plain.h5"), params);
  smooth_out_of_core(path("deflated.h5"), path("run_deflated.h5"), params);
  const io::PointTable a = read_container(path("run_plain.h5"));
  const io::PointTable b = read_container(path("run_deflated.h5"));
  EXPECT_EQ(a.positions, b.positions);
  test::expect_identical(path("run_deflated.h5"), test::run_in_core(input, params));
}

TEST_F(ImportTest, EmptyAndTinyClouds) {
  for (const std::size_t n : {0u, 1u, 3u}) {
    SCOPED_TRACE(n);
    const io::PointTable input = write_cloud("t.ply", test::noisy_cube(n, 37));
    import_points(path("t.ply"), path("t.h5"), streamed({.max_tile_points = 2}));
    expect_well_formed(path("t.h5"), input, 2);
    const test::InCore ref = test::run_in_core(input, few_steps(1));
    smooth_out_of_core(path("t.h5"), path("run.h5"), few_steps(1));
    test::expect_identical(path("run.h5"), ref);
    std::filesystem::remove(path("run.h5"));
  }
}

TEST_F(ImportTest, BadInputLeavesNoOutput) {
  EXPECT_THROW(import_points(path("missing.ply"), path("m.h5"), streamed({})), io::IoError);
  std::FILE* f = std::fopen(path("bad.xyz").c_str(), "w");
  std::fputs("1 2 3\n4 5 6\n7 8\n", f);
  std::fclose(f);
  try {
    import_points(path("bad.xyz"), path("b.h5"), streamed({}));
    FAIL() << "expected an IoError";
  } catch (const io::IoError& e) {
    EXPECT_NE(std::string(e.what()).find("line 3"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(path("m.h5")));
  EXPECT_FALSE(std::filesystem::exists(path("b.h5")));
}

// Runs a command; returns its exit code and standard output.
int run_tool(const std::string& command, std::string& out) {
  out.clear();
  std::FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return -1;
  char buffer[4096];
  for (std::size_t got; (got = std::fread(buffer, 1, sizeof buffer, pipe)) > 0;) out.append(buffer, got);
  return ::pclose(pipe);
}

TEST_F(ImportTest, H5lsAndH5dumpListTheDocumentedLayout) {
  std::string out;
  if (run_tool("h5ls --version", out) != 0) GTEST_SKIP() << "h5ls not installed (Debian: hdf5-tools)";
  write_cloud("in.ply", test::noisy_cube(500, 38));
  import_points(path("in.ply"), path("in.h5"), streamed({.max_tile_points = 100}));
  ASSERT_EQ(run_tool("h5ls -r '" + path("in.h5").string() + "'", out), 0) << out;
  for (const char* object : {"/points ", "/points/positions ", "/points/original_index ", "/points/attributes ",
                             "/points/attributes/intensity ", "/points/attributes/label ", "/tiles ",
                             "/tiles/offsets ", "/tiles/bounds "}) {
    EXPECT_NE(out.find(object), std::string::npos) << object << " missing from:\n" << out;
  }
  const std::size_t line = out.find("/points/positions ");
  ASSERT_NE(line, std::string::npos);
  EXPECT_NE(out.substr(line, out.find('\n', line) - line).find("Dataset {500, 3}"), std::string::npos) << out;
  ASSERT_EQ(run_tool("h5dump -H '" + path("in.h5").string() + "'", out), 0) << out;
  for (const char* text : {"pointfair_format", "format_version", "point_count", "tile_count", "row_order",
                           "H5T_STD_U64LE", "H5T_IEEE_F64LE"}) {
    EXPECT_NE(out.find(text), std::string::npos) << text << " missing from:\n" << out;
  }
}

std::string slurp(const std::filesystem::path& file) {
  std::string bytes;
  std::FILE* f = std::fopen(file.c_str(), "rb");
  if (f == nullptr) return bytes;
  char buffer[4096];
  for (std::size_t got; (got = std::fread(buffer, 1, sizeof buffer, f)) > 0;) bytes.append(buffer, got);
  std::fclose(f);
  return bytes;
}

// The command-line tool end to end: import (with and without deflate), smooth the container,
// export in small chunks: the same bytes as the in-core smooth, colours and attributes included;
// and export of the imported container gives back the input file.
TEST_F(ImportTest, CommandLineRoundTripsMatchInCoreBytes) {
  const std::string exe = POINTFAIR_EXE;
  write_cloud("in.ply", test::noisy_cube(3000, 39));
  std::string out;
  // Appended rather than "'" + ...: GCC 12 warns wrongly (-Wrestrict) on that at -O3.
  const auto q = [](const std::filesystem::path& p) { return std::string(1, '\'').append(p.string()).append(1, '\''); };
  ASSERT_EQ(run_tool(exe + " smooth " + q(path("in.ply")) + " " + q(path("ref.ply")) + " --steps 2 --attributes --quiet", out), 0) << out;
  for (const char* deflate : {"0", "4"}) {
    SCOPED_TRACE(std::string("deflate ") + deflate);
    ASSERT_EQ(run_tool(exe + " import " + q(path("in.ply")) + " " + q(path("in.h5")) + " --tile-points 300 --deflate " +
                           deflate + " --quiet", out), 0) << out;
    ASSERT_EQ(run_tool(exe + " export " + q(path("in.h5")) + " " + q(path("back.ply")) + " --memory-budget 1K --quiet", out), 0) << out;
    EXPECT_EQ(slurp(path("back.ply")), slurp(path("in.ply")));
    ASSERT_EQ(run_tool(exe + " smooth " + q(path("in.h5")) + " " + q(path("run.h5")) + " --steps 2 --quiet", out), 0) << out;
    ASSERT_EQ(run_tool(exe + " export " + q(path("run.h5")) + " " + q(path("out.ply")) + " --attributes --memory-budget 1K --quiet", out), 0) << out;
    EXPECT_EQ(slurp(path("out.ply")), slurp(path("ref.ply")));
    std::filesystem::remove(path("run.h5"));
  }
}

// A LAS source's VLRs (e.g. its coordinate system) and EVLRs are kept in the container and
// written back by export: the record bytes of the exported file are the input's.
TEST_F(ImportTest, LasRecordsSurviveImportAndExport) {
  io::PointTable cloud = test::noisy_cube(500, 41);
  io::LasMetadata las;
  las.version_minor = 4;
  las.point_format = 6;
  las.project_guid = std::string("0123456789abcdef");
  las.system_identifier = std::string("pointfair test");
  las.records.push_back({"LASF_Projection", 2112, "OGC WKT", std::string("PROJCS[\"x\"]\0\x01\xff", 14), false});
  las.records.push_back({"pointfair", 7, "a long record", std::string(70000, 'Z'), true});
  cloud.las = las;
  const io::PointTable input = write_cloud("crs.las", cloud);
  ASSERT_TRUE(input.las);
  ASSERT_EQ(input.las->records.size(), 2u);
  import_points(path("crs.las"), path("crs.h5"), streamed({.max_tile_points = 100}, 64));
  const io::PointTable back = read_container(path("crs.h5"));
  ASSERT_TRUE(back.las);
  ASSERT_EQ(back.las->records.size(), input.las->records.size());
  for (std::size_t i = 0; i < back.las->records.size(); ++i) {
    const io::LasRecord &a = back.las->records[i], &b = input.las->records[i];
    EXPECT_EQ(a.user_id, b.user_id);
    EXPECT_EQ(a.record_id, b.record_id);
    EXPECT_EQ(a.description, b.description);
    EXPECT_EQ(a.data, b.data);
    EXPECT_EQ(a.extended, b.extended);
  }
  EXPECT_EQ(back.las->project_guid, input.las->project_guid);
  EXPECT_EQ(back.las->system_identifier, input.las->system_identifier);
  EXPECT_EQ(back.las->extra_bytes_descriptors, input.las->extra_bytes_descriptors);

  std::string out;
  ASSERT_EQ(run_tool(std::string(POINTFAIR_EXE) + " export '" + path("crs.h5").string() + "' '" +
                         path("out.las").string() + "'",
                     out),
            0)
      << out;
  const std::string in_bytes = slurp(path("crs.las")), out_bytes = slurp(path("out.las"));
  ASSERT_GT(in_bytes.size(), 375u);
  ASSERT_EQ(out_bytes.size(), in_bytes.size());
  // LAS 1.4: header size at byte 94, offset to the points at 96, first EVLR at 235.
  const auto field = [](const std::string& bytes, std::size_t at, std::size_t size) {
    std::uint64_t v = 0;
    std::memcpy(&v, bytes.data() + at, size);  // little-endian host, as the tests' other byte checks
    return static_cast<std::size_t>(v);
  };
  const std::size_t header = field(in_bytes, 94, 2), points = field(in_bytes, 96, 4), evlr = field(in_bytes, 235, 8);
  ASSERT_EQ(field(out_bytes, 94, 2), header);
  ASSERT_EQ(field(out_bytes, 96, 4), points);
  ASSERT_LT(evlr, in_bytes.size());
  EXPECT_TRUE(out_bytes.compare(header, points - header, in_bytes, header, points - header) == 0)
      << "the VLRs differ";
  EXPECT_TRUE(out_bytes.compare(evlr, std::string::npos, in_bytes, evlr, std::string::npos) == 0)
      << "the EVLRs differ";
}

// Export to LAS from a float source (PLY) measures the bounds in a first pass and streams:
// the same bytes as write_las of the whole cloud.
TEST_F(ImportTest, ExportToLasFromPlyStreamsTheSameBytes) {
  write_cloud("in.ply", test::noisy_cube(3000, 42));
  import_points(path("in.ply"), path("ply.h5"), streamed({.max_tile_points = 300}, 64));
  std::string out;
  ASSERT_EQ(run_tool(std::string(POINTFAIR_EXE) + " export '" + path("ply.h5").string() + "' '" +
                         path("out.las").string() + "' --memory-budget 16M",
                     out),
            0)
      << out;
  io::write_las(path("whole.las"), read_container(path("ply.h5")));
  const std::string whole = slurp(path("whole.las"));
  ASSERT_GT(whole.size(), 375u);
  EXPECT_TRUE(slurp(path("out.las")) == whole) << "streamed LAS differs from write_las";
}

}  // namespace
