// `pointfair smooth IN_DIR OUT_DIR`: a folder of tiles smoothed as one cloud gives each file
// the bits of smoothing the files concatenated, in core and out of core, with each file's own
// header, records and attributes; a killed run resumes; bad folders fail with one line naming
// them (docs/tiles-folder.md).
#include <gtest/gtest.h>

#include <signal.h>

#include <string>
#include <algorithm>
#include <chrono>
#include <thread>
#include <vector>

#include "hardening/cli_child.hpp"
#include "pointfair/io/point_file.hpp"
#include "pointfair/shapes/shapes.hpp"

namespace pointfair::testing_cli {

namespace {

const std::vector<std::string> kMethod = {"--steps", "6", "--threads", "2", "--quiet"};

std::vector<std::string> with(std::vector<std::string> head, const std::vector<std::string>& tail) {
  head.insert(head.end(), tail.begin(), tail.end());
  return head;
}

class TilesFolder : public CliTest {
 protected:
  // A noisy sphere cut into three files of three formats in `in/`: a binary PLY with an
  // intensity and a comment, a LAS 1.2 file with its own grid and a VLR, and a text file with
  // normals; and the three files' points concatenated in name order as `merged.ply`.
  void write_tiles(std::size_t n = 20000) {
    std::vector<Vec3> points = sample_sphere(n, 1.0, 3).points;
    add_noise(points, 0.01, 4);
    fs::create_directories(dir_ / "in");
    const std::size_t cut[4] = {0, n / 3, 2 * n / 3, n};
    const auto part = [&](int i) {
      io::PointTable t;
      t.positions.assign(points.begin() + static_cast<std::ptrdiff_t>(cut[i]),
                         points.begin() + static_cast<std::ptrdiff_t>(cut[i + 1]));
      std::vector<double> ids(t.size());
      for (std::size_t j = 0; j < ids.size(); ++j) ids[j] = static_cast<double>((j * 7) % 1000);
      t.set("intensity", io::ScalarType::UInt16, ids);
      return t;
    };
    io::PointTable a = part(0);
    a.ply = io::PlyLayout{.encoding = io::PlyEncoding::BinaryLittleEndian,
                          .header_lines = {"comment tile a"}, .properties = {}};
    io::write_points(dir_ / "in" / "a.ply", a);
    io::PointTable b = part(1);
    b.quantization = io::PositionQuantization{.scale = Vec3::Constant(1e-5), .offset = Vec3::Constant(-2.0)};
    b.las = io::LasMetadata{};
    b.las->version_minor = 2;
    b.las->point_format = 1;
    b.las->records.push_back({.user_id = "tile_test", .record_id = 7, .description = "kept", .data = "abc",
                              .extended = false});
    io::write_points(dir_ / "in" / "b.las", b);
    io::PointTable c = part(2);
    std::vector<double> nz(c.size(), 1.0), zero(c.size(), 0.0);
    c.attributes.clear();
    c.set("nx", io::ScalarType::Float32, zero);
    c.set("ny", io::ScalarType::Float32, zero);
    c.set("nz", io::ScalarType::Float32, nz);
    io::write_points(dir_ / "in" / "c.xyz", c);
    std::ofstream(dir_ / "in" / "notes.txt") << "not a point file\n";
    io::PointTable merged;
    for (const char* name : {"a.ply", "b.las", "c.xyz"}) {
      const io::PointTable t = io::read_points(dir_ / "in" / name);
      merged.positions.insert(merged.positions.end(), t.positions.begin(), t.positions.end());
    }
    io::write_points(dir_ / "merged.ply", merged);
  }
  std::string in() const { return (dir_ / "in").string(); }
  std::string out(const std::string& name = "out") const { return (dir_ / name).string(); }
};

// The three files of `out` as the existing single-file writers write each input file with its
// slice of `smoothed` (the concatenation's result): the same bytes, normals aside (they are
// the run's, compared between runs).
void expect_files_hold_the_merged_result(const fs::path& in, const fs::path& out, const io::PointTable& smoothed) {
  std::size_t first = 0;
  for (const char* name : {"a.ply", "b.las"}) {
    io::PointTable source = io::read_points(in / name);
    const std::size_t n = source.size();
    source.positions.assign(smoothed.positions.begin() + static_cast<std::ptrdiff_t>(first),
                            smoothed.positions.begin() + static_cast<std::ptrdiff_t>(first + n));
    const fs::path expected = out.parent_path() / (std::string("expected_") + name);
    io::write_points(expected, source);
    EXPECT_EQ(slurp(out / name), slurp(expected)) << name;
    first += n;
  }
  const io::PointTable c = io::read_points(out / "c.xyz");
  ASSERT_EQ(first + c.size(), smoothed.size());
  for (std::size_t i = 0; i < c.size(); ++i) ASSERT_EQ(c.positions[i], smoothed.positions[first + i]) << i;
  ASSERT_NE(c.find("nz"), nullptr);
  EXPECT_NE(c.find("nz")->values, std::vector<double>(c.size(), 1.0));  // the run's normals
}

}  // namespace

TEST_F(TilesFolder, InCoreEachFileHoldsItsShareOfTheMergedCloudsResult) {
  write_tiles();
  const Result merged = run(with({"smooth", (dir_ / "merged.ply").string(), out("merged_out.ply")}, kMethod));
  ASSERT_EQ(merged.exit_code, 0) << merged.err;
  const Result folder = run(with({"smooth", in() + "/", out() + "/"}, kMethod));
  ASSERT_EQ(folder.exit_code, 0) << folder.err;
  const std::vector<std::string> expected_names = {"a.ply", "b.las", "c.xyz"};
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir_ / "out")) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names, expected_names);
  // Each file keeps its header and records.
  const io::PointTable b = io::read_points(dir_ / "out" / "b.las");
  ASSERT_TRUE(b.las && b.quantization);
  EXPECT_EQ(b.las->point_format, 1);
  EXPECT_EQ(b.las->version_minor, 2);
  ASSERT_EQ(b.las->records.size(), 1u);
  EXPECT_EQ(b.las->records[0].data, "abc");
  EXPECT_EQ(b.quantization->scale, Vec3::Constant(1e-5));
  EXPECT_NE(slurp(dir_ / "out" / "a.ply").find("comment tile a"), std::string::npos);
  expect_files_hold_the_merged_result(dir_ / "in", dir_ / "out", io::read_points(dir_ / "merged_out.ply"));
}

TEST_F(TilesFolder, OutOfCoreGivesTheInCoreBitsWithinASmallBudget) {
  write_tiles();
  const Result core = run(with({"smooth", in(), out("core")}, kMethod));
  ASSERT_EQ(core.exit_code, 0) << core.err;
  const Result ooc = run(with({"smooth", in(), out("ooc"), "--memory-budget", "5M", "--json"}, kMethod));
  ASSERT_EQ(ooc.exit_code, 0) << ooc.err;
  EXPECT_NE(ooc.out.find("\"out_of_core\": true"), std::string::npos) << ooc.out;
  EXPECT_EQ(ooc.out.find("\"tiles\": 1,"), std::string::npos) << ooc.out;  // several tiles
  for (const char* name : {"a.ply", "b.las", "c.xyz"})
    EXPECT_EQ(slurp(dir_ / "ooc" / name), slurp(dir_ / "core" / name)) << name;
  EXPECT_FALSE(fs::exists(dir_ / ".ooc.pointfair-run"));
}

TEST_F(TilesFolder, AKilledOutOfCoreRunResumesToTheSameBits) {
  write_tiles();
  const std::vector<std::string> method = {"--steps", "12", "--threads", "2", "--quiet", "--memory-budget", "5M"};
  ASSERT_EQ(run(with({"smooth", in(), out("ref")}, method)).exit_code, 0);
  const Child c = start(with({"smooth", in(), out()}, method));
  // Killed once the run's steps are being committed (or when it is done).
  const fs::path partial = dir_ / ".out.pointfair-run" / "run.h5.partial";
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (!fs::exists(partial) && !fs::exists(dir_ / "out" / "c.xyz") && std::chrono::steady_clock::now() < deadline)
    std::this_thread::yield();
  kill(c.pid, SIGKILL);
  const Result killed = wait_for(c);
  if (killed.exit_code == -SIGKILL && fs::exists(dir_ / ".out.pointfair-run")) {
    const Result again = run(with({"smooth", in(), out()}, method));
    EXPECT_NE(again.exit_code, 0);
    EXPECT_NE(again.err.find("--resume"), std::string::npos) << again.err;
    // A folder that is no longer the one the run started from is refused, as a changed file is.
    fs::copy_file(dir_ / "in" / "a.ply", dir_ / "in" / "d.ply");
    const Result other = run(with(with({"smooth", in(), out()}, method), {"--resume"}));
    EXPECT_EQ(other.exit_code, 3);
    expect_one_line_naming(other, "was started from another input");
    fs::remove(dir_ / "in" / "d.ply");
    const Result resumed = run(with(with({"smooth", in(), out()}, method), {"--resume"}));
    ASSERT_EQ(resumed.exit_code, 0) << resumed.err;
  }
  for (const char* name : {"a.ply", "b.las", "c.xyz"})
    EXPECT_EQ(slurp(dir_ / "out" / name), slurp(dir_ / "ref" / name)) << name;
  EXPECT_FALSE(fs::exists(dir_ / ".out.pointfair-run"));
}

TEST_F(TilesFolder, ImportMakesOneContainerOfEveryFile) {
  write_tiles();
  const Result r = run({"import", in(), out("scan.h5"), "--json", "--quiet"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("\"points\": 20000"), std::string::npos) << r.out;
}

// The cluster's way: the folder imported into a container, the container smoothed, the run
// exported back into the folder's files: the bits of `smooth IN_DIR OUT_DIR`.
TEST_F(TilesFolder, AContainerRunIsExportedBackIntoTheFolderFiles) {
  write_tiles(3000);
  ASSERT_EQ(run(with({"smooth", in(), out("direct")}, kMethod)).exit_code, 0);
  ASSERT_EQ(run({"import", in(), out("scan.h5"), "--quiet"}).exit_code, 0);
  const Result smoothed = run(with({"smooth", out("scan.h5"), out("run.h5")}, kMethod));
  ASSERT_EQ(smoothed.exit_code, 0) << smoothed.err;
  const Result exported = run({"export", out("run.h5"), out(), "--files", in(), "--quiet"});
  ASSERT_EQ(exported.exit_code, 0) << exported.err;
  for (const char* name : {"a.ply", "b.las", "c.xyz"})
    EXPECT_EQ(slurp(dir_ / "out" / name), slurp(dir_ / "direct" / name)) << name;
  // Files that are not those the container was imported from.
  fs::remove(dir_ / "in" / "c.xyz");
  const Result fewer = run({"export", out("run.h5"), out("fewer"), "--files", in(), "--quiet"});
  EXPECT_EQ(fewer.exit_code, 3);
  expect_one_line_naming(fewer, "they are not the files it was imported from");
  EXPECT_FALSE(fs::exists(dir_ / "fewer" / "a.ply"));
}

TEST_F(TilesFolder, CurvatureOfAFolderIsTheMergedClouds) {
  write_tiles(3000);
  ASSERT_EQ(run({"curvature", (dir_ / "merged.ply").string(), out("merged_curv.ply"), "--quiet"}).exit_code, 0);
  const Result r = run({"curvature", in(), out(), "--quiet"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const io::PointTable merged = io::read_points(dir_ / "merged_curv.ply");
  const io::PointTable a = io::read_points(dir_ / "out" / "a.ply");
  ASSERT_NE(a.find("scalar_k1"), nullptr);
  const std::vector<double>& all = merged.find("scalar_k1")->values;
  EXPECT_EQ(a.find("scalar_k1")->values,
            std::vector<double>(all.begin(), all.begin() + static_cast<std::ptrdiff_t>(a.size())));
  EXPECT_EQ(a.find("red")->values,
            std::vector<double>(merged.find("red")->values.begin(),
                                merged.find("red")->values.begin() + static_cast<std::ptrdiff_t>(a.size())));
  EXPECT_EQ(io::read_points(dir_ / "out" / "b.las").las->records.size(), 1u);
}

TEST_F(TilesFolder, BadFoldersFailWithOneLineNamingThem) {
  fs::create_directories(dir_ / "empty");
  Result r = run({"smooth", (dir_ / "empty").string(), out(), "--quiet"});
  EXPECT_EQ(r.exit_code, 3);
  expect_one_line_naming(r, "empty: holds no point file");
  std::ofstream(dir_ / "empty" / "readme.txt") << "notes\n";
  r = run({"smooth", (dir_ / "empty").string(), out(), "--memory-budget", "5M", "--quiet"});
  EXPECT_EQ(r.exit_code, 3);
  expect_one_line_naming(r, "empty: holds no point file");

  write_tiles();
  r = run(with({"smooth", in(), in()}, kMethod));
  EXPECT_EQ(r.exit_code, 3);
  expect_one_line_naming(r, "the output folder is the input folder");
  r = run(with({"smooth", in(), out(), "--classes", "2"}, kMethod));
  EXPECT_EQ(r.exit_code, 2);
  expect_one_line_naming(r, "--classes");

  std::ofstream(dir_ / "in" / "b2.ply", std::ios::binary) << "ply\nformat binary_little_endian 1.0\nelement vertex 5\n";
  for (const std::vector<std::string>& extra : {std::vector<std::string>{}, {"--memory-budget", "5M"}}) {
    r = run(with(with({"smooth", in(), out("bad")}, kMethod), extra));
    EXPECT_EQ(r.exit_code, 3);
    expect_one_line_naming(r, "b2.ply");
    EXPECT_FALSE(fs::exists(dir_ / "bad" / "c.xyz"));
  }
}

}  // namespace pointfair::testing_cli
