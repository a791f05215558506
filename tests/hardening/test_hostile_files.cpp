// Hostile files through the readers: non-finite coordinates, absurd counts (no allocation
// before the data proves them), and files that grow or shrink while they are read.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "pointfair/io/ply.hpp"
#include "pointfair/io/point_file.hpp"
#include "scratch_folder.hpp"
#include "pointfair/common/params_error.hpp"
#include "pointfair/io/xyz.hpp"
#include "pointfair/shapes/shapes.hpp"
#include "pointfair/tiles/container.hpp"
#include "pointfair/tiles/hdf5_file.hpp"
#include "pointfair/tiles/tiled_smooth.hpp"

namespace fs = std::filesystem;
using namespace pointfair;

namespace {

class HostileFiles : public testing_hardening::ScratchFolder {
 protected:
};

// The reader throws IoError whose message names the file and contains `problem`.
template <class Read>
void expect_io_error(Read read, const fs::path& file, const std::string& problem) {
  try {
    read();
    ADD_FAILURE() << file << ": no error";
  } catch (const io::IoError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(file.filename().string()), std::string::npos) << what;
    EXPECT_NE(what.find(problem), std::string::npos) << what;
  }
}

std::string ply_header(const std::string& format, std::uint64_t count, const char* type = "float") {
  return "ply\nformat " + format + " 1.0\nelement vertex " + std::to_string(count) +
         "\nproperty " + type + " x\nproperty " + type + " y\nproperty " + type + " z\nend_header\n";
}

template <class T>
std::string binary_values(std::initializer_list<T> values) {
  std::string bytes;
  for (const T v : values) bytes.append(reinterpret_cast<const char*>(&v), sizeof v);
  return bytes;
}

}  // namespace

TEST_F(HostileFiles, NonFiniteCoordinatesAreReadErrorsInEveryFormat) {
  const double inf = std::numeric_limits<double>::infinity(), nan = std::numeric_limits<double>::quiet_NaN();
  struct Case {
    std::string name, bytes;
  };
  const std::vector<Case> cases = {
      {"nan.ply", ply_header("ascii", 2) + "0 0 0\n1 nan 2\n"},
      {"inf.ply", ply_header("ascii", 2) + "0 0 0\n1 2 -inf\n"},
      {"huge.ply", ply_header("ascii", 1) + "1e39 0 0\n"},  // beyond float: not a valid float
      {"nan_le.ply", ply_header("binary_little_endian", 2, "double") + binary_values<double>({0, 0, 0, nan, 1, 2})},
      {"inf_le.ply", ply_header("binary_little_endian", 1) + binary_values<float>({0, static_cast<float>(inf), 0})},
      {"nan.xyz", "0 0 0\n1 nan 2\n"},
      {"inf.csv", "x,y,z\n0,0,0\n1,2,inf\n"},
      {"overflow.xyz", "0 0 0\n1e400 0 0\n"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const fs::path p = write_bytes(c.name, c.bytes);
    try {
      io::read_points(p);
      ADD_FAILURE() << "no error";
    } catch (const io::IoError& e) {
      EXPECT_NE(std::string(e.what()).find(c.name), std::string::npos) << e.what();
    }
  }
}

TEST_F(HostileFiles, HeaderCountOf1e15FailsBeforeAllocating) {
  const std::uint64_t count = 1'000'000'000'000'000;
  const std::string three = binary_values<float>({0, 0, 0});
  const fs::path le = write_bytes("le.ply", ply_header("binary_little_endian", count) + three);
  expect_io_error([&] { io::read_ply(le); }, le, "truncated binary body");
  const fs::path be = write_bytes("be.ply", ply_header("binary_big_endian", count) + three);
  expect_io_error([&] { io::read_ply(be); }, be, "truncated binary body");
  const fs::path ascii = write_bytes("ascii.ply", ply_header("ascii", count) + "0 0 0\n");
  expect_io_error([&] { io::read_ply(ascii); }, ascii, "bytes follow the header");
  // A .pts count line is only a hint: the points that are there are read, with a warning.
  const fs::path pts = write_bytes("count.pts", std::to_string(count) + "\n0 0 0\n1 1 1\n");
  std::vector<std::string> warnings;
  io::ReadOptions options;
  options.on_warning = [&](const std::string& w) { warnings.push_back(w); };
  const io::PointTable t = io::read_points(pts, options);
  EXPECT_EQ(t.size(), 2u);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("declares 1000000000000000 points"), std::string::npos) << warnings[0];
}

// A container whose datasets claim 10^15 rows (HDF5 allocates chunks lazily, so the file is
// a few kilobytes): opening it must fail with an IoError, not try to allocate petabytes.
TEST_F(HostileFiles, ContainerClaiming1e15PointsIsRefused) {
  const std::uint64_t n = 1'000'000'000'000'000;
  const fs::path file = dir_ / "huge.h5";
  {
    tiles::h5::File f = tiles::h5::File::create(file);
    f.set_attribute("/", "pointfair_format", std::string_view(tiles::layout::format_name));
    f.set_attribute("/", "format_version", tiles::layout::format_version);
    f.set_attribute("/", "point_count", static_cast<std::int64_t>(n));
    f.set_attribute("/", "tile_count", std::int64_t{1});
    f.create_group(tiles::layout::points);
    f.create_group(tiles::layout::tiles);
    f.create_dataset(tiles::layout::positions, tiles::h5::Type::Float64, n, 3, {.chunk_rows = 1024});
    f.create_dataset(tiles::layout::original_index, tiles::h5::Type::UInt64, n, 0, {.chunk_rows = 1024});
    tiles::h5::Dataset offsets = f.create_dataset(tiles::layout::tile_offsets, tiles::h5::Type::UInt64, 2, 0);
    const std::uint64_t off[2] = {0, n};
    offsets.write_rows(0, 2, off);
    tiles::h5::Dataset bounds = f.create_dataset(tiles::layout::tile_bounds, tiles::h5::Type::Float64, 1, 6);
    const double box[6] = {0, 0, 0, 1, 1, 1};
    bounds.write_rows(0, 1, box);
    f.flush();
  }
  ASSERT_LT(fs::file_size(file), 1u << 20);
  expect_io_error([&] { tiles::read_container(file); }, file, "");
  try {
    tiles::smooth_out_of_core(file, dir_ / "run.h5", SmoothParams{});
    ADD_FAILURE() << "no error";
  } catch (const io::IoError& e) {
    EXPECT_NE(std::string(e.what()).find("huge.h5"), std::string::npos) << e.what();
  } catch (const ParamError& e) {
    SUCCEED() << e.what();  // e.g. a tile that does not fit the budget
  }
  EXPECT_FALSE(fs::exists(dir_ / "run.h5"));
}

// A file that changes while it is read. Defined outcome: a PLY file is read as its header
// says (bytes appended after the body are ignored with a warning; a body cut short is a
// "truncated" IoError); a text file is read as far as it is when the reader reaches its end,
// but one that ends before the size it had when it was opened is an IoError ("shrank"). The
// writer thread races the reader, so each outcome is checked against every allowed one.
TEST_F(HostileFiles, FileThatShrinksWhileReadIsAnErrorOrTheWholeFile) {
  io::PointTable table;
  table.positions = sample_sphere(400000, 1.0, 1).points;
  const fs::path ply = dir_ / "big.ply", xyz = dir_ / "big.xyz";
  io::write_points(ply, table);
  io::write_points(xyz, table);
  for (const fs::path& file : {ply, xyz}) {
    const std::uintmax_t size = fs::file_size(file);
    for (int round = 0; round < 3; ++round) {
      SCOPED_TRACE(file.filename().string() + " round " + std::to_string(round));
      std::atomic<bool> started{false};
      std::thread cutter([&] {
        while (!started.load()) std::this_thread::yield();
        fs::resize_file(file, size / 2);
      });
      started = true;
      std::size_t read = 0;
      bool failed = false;
      try {
        read = io::read_points(file).size();
      } catch (const io::IoError& e) {
        failed = true;
        const std::string what = e.what();
        EXPECT_NE(what.find(file.filename().string()), std::string::npos) << what;
      }
      cutter.join();
      // Once cut, it is a shorter PLY file (an error) or a text file of fewer lines.
      if (file == ply) {
        // Read before the cut: the whole file.
        if (!failed) {
          EXPECT_EQ(read, table.size());
        }
        EXPECT_THROW(io::read_points(file), io::IoError);
        io::write_points(ply, table);
      } else {
        // Read before the cut: the whole file; opened after it: the shorter file it then was.
        if (!failed) {
          const std::size_t after_cut = io::read_points(file).size();
          EXPECT_TRUE(read == table.size() || read == after_cut) << read << " points";
        }
        io::write_points(xyz, table);
      }
    }
  }
}

TEST_F(HostileFiles, FileThatGrowsWhileReadIsReadAsItsHeaderSays) {
  io::PointTable table;
  table.positions = sample_sphere(400000, 1.0, 2).points;
  const fs::path ply = dir_ / "big.ply";
  io::write_points(ply, table);
  for (int round = 0; round < 3; ++round) {
    SCOPED_TRACE(round);
    std::atomic<bool> started{false};
    std::thread grower([&] {
      while (!started.load()) std::this_thread::yield();
      std::ofstream(ply, std::ios::binary | std::ios::app) << std::string(1 << 20, '\x7f');
    });
    started = true;
    const io::PointTable t = io::read_points(ply);  // never an error, never more points
    grower.join();
    ASSERT_EQ(t.size(), table.size());
    EXPECT_EQ(t.positions[12345], table.positions[12345]);
    io::write_points(ply, table);
  }
  // Text: lines appended while reading are read if the reader gets there; the file's points
  // at the time it was opened are always there.
  const fs::path xyz = dir_ / "big.xyz";
  io::write_points(xyz, table);
  std::atomic<bool> started{false};
  std::thread grower([&] {
    while (!started.load()) std::this_thread::yield();
    std::ofstream(xyz, std::ios::app) << "0.5 0.5 0.5\n";
  });
  started = true;
  const io::PointTable t = io::read_points(xyz);
  grower.join();
  EXPECT_GE(t.size(), table.size());
  EXPECT_LE(t.size(), table.size() + 1);
}

// A container that contradicts itself: a tile's bounds that do not contain its points (the
// halos of the other tiles are found through them, so the result would silently change).
// The run checks every point against its tile's bounds while it builds the neighbourhoods.
TEST_F(HostileFiles, TileBoundsThatDoNotContainTheirPointsAreRefused) {
  io::PointTable t;
  t.positions = sample_sphere(3000, 1.0, 9).points;
  const fs::path file = dir_ / "scan.h5";
  tiles::ImportOptions options;
  options.tiling.max_tile_points = 500;
  tiles::write_container(file, t, options);
  for (const int side : {0, 3}) {  // a minimum raised, a maximum lowered
    SCOPED_TRACE(side);
    const fs::path copy = dir_ / ("bad" + std::to_string(side) + ".h5");
    fs::copy_file(file, copy);
    {
      tiles::h5::File f = tiles::h5::File::open(copy, true);
      tiles::h5::Dataset bounds = f.dataset(tiles::layout::tile_bounds);
      double box[6];
      bounds.read_rows(2, 1, box);
      const double shrink = 0.25 * (box[3] - box[0]);
      box[0 + side] += side == 0 ? shrink : -shrink;
      bounds.write_rows(2, 1, box);
      f.flush();
    }
    SmoothParams params;
    params.steps = 1;
    params.finish.reset();
    try {
      tiles::smooth_out_of_core(copy, dir_ / "run.h5", params);
      ADD_FAILURE() << "no error";
    } catch (const io::IoError& e) {
      EXPECT_NE(std::string(e.what()).find(copy.filename().string() + ": /tiles/bounds: row "), std::string::npos)
          << e.what();
      EXPECT_NE(std::string(e.what()).find("lies outside the bounds of its tile 2"), std::string::npos) << e.what();
    }
    EXPECT_FALSE(fs::exists(dir_ / "run.h5"));
    fs::remove(tiles::partial_name(dir_ / "run.h5"));
  }
  // The container as written runs.
  SmoothParams params;
  params.steps = 1;
  params.finish.reset();
  EXPECT_NO_THROW(tiles::smooth_out_of_core(file, dir_ / "run.h5", params));
}
