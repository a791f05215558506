// The HDF5 wrapper: datasets by rows and selections, attributes, errors naming file and object.
#include "pointfair/tiles/hdf5_file.hpp"

#include <filesystem>
#include <fstream>

#include "tiles_test_util.hpp"

using namespace pointfair;
using namespace pointfair::tiles;

namespace {

class Hdf5FileTest : public test::TempDirTest {};

TEST_F(Hdf5FileTest, RowsAndSelectionsRoundTrip) {
  const auto file = path("a.h5");
  {
    h5::File f = h5::File::create(file);
    f.create_group("/g");
    h5::Dataset d = f.create_dataset("/g/xyz", h5::Type::Float64, 100, 3, {.chunk_rows = 16});
    std::vector<double> v(300);
    for (std::size_t i = 0; i < v.size(); ++i) v[i] = 0.5 * static_cast<double>(i);
    d.write_rows(0, 100, v.data());
    h5::Dataset u = f.create_dataset("/g/u16", h5::Type::UInt16, 10, 0, {.allocate_early = true});
    std::vector<std::uint16_t> w{1, 2, 3, 4, 5, 6, 7, 8, 9, 65535};
    u.write_rows(0, 10, w.data());
    f.set_attribute("/", "name", "hello");
    f.set_attribute("/g", "pi", 3.25);
    f.set_attribute("/g/xyz", "count", std::int64_t{-7});
    const std::vector<double> list{1.0, 2.0};
    f.set_attribute("/g", "list", list);
  }
  const h5::File f = h5::File::open(file, false);
  const h5::Dataset d = f.dataset("/g/xyz");
  EXPECT_EQ(d.rows(), 100u);
  EXPECT_EQ(d.width(), 3u);
  std::vector<double> some(6);
  d.read_rows(10, 2, some.data());
  EXPECT_EQ(some[0], 15.0);
  EXPECT_EQ(some[5], 0.5 * 35);
  // Few runs (hyperslabs) and many runs (point selection) give the same rows.
  for (const std::vector<std::uint64_t>& rows :
       {std::vector<std::uint64_t>{3, 4, 5, 90}, [] {
          std::vector<std::uint64_t> r;
          for (std::uint64_t i = 0; i < 100; i += 2) r.push_back(i);
          return r;
        }()}) {
    std::vector<double> got(rows.size() * 3);
    d.read_selected(rows, got.data());
    for (std::size_t i = 0; i < rows.size(); ++i)
      for (std::size_t c = 0; c < 3; ++c) EXPECT_EQ(got[3 * i + c], 0.5 * static_cast<double>(3 * rows[i] + c));
  }
  const auto u = f.dataset("/g/u16").read_all<double>();
  EXPECT_EQ(u.back(), 65535.0);
  EXPECT_EQ(f.dataset("/g/u16").type(), h5::Type::UInt16);
  EXPECT_EQ(f.string_attribute("/", "name"), "hello");
  EXPECT_EQ(f.double_attribute("/g", "pi"), 3.25);
  EXPECT_EQ(f.int_attribute("/g/xyz", "count"), -7);
  EXPECT_EQ(f.doubles_attribute("/g", "list"), (std::vector<double>{1.0, 2.0}));
  EXPECT_EQ(f.members("/g"), (std::vector<std::string>{"xyz", "u16"}));  // creation order
  EXPECT_TRUE(f.exists("/g/xyz"));
  EXPECT_FALSE(f.exists("/g/nope/deeper"));
}

// start_writeback between writes (as each tile of a step is written) changes nothing in what
// the file holds; it and flush() go through the open file, whatever its name is now.
TEST_F(Hdf5FileTest, WritebackStartedBetweenWritesKeepsEveryRow) {
  const auto file = path("w.h5");
  constexpr std::uint64_t kRows = 5000;
  {
    h5::File f = h5::File::create(file);
    h5::Dataset d = f.create_dataset("/xyz", h5::Type::Float64, kRows, 3, {.chunk_rows = 512});
    std::vector<double> v(3 * 1000);
    for (std::uint64_t first = 0; first < kRows; first += 1000) {
      for (std::size_t i = 0; i < v.size(); ++i) v[i] = static_cast<double>(3 * first + i) + 0.25;
      d.write_rows(first, 1000, v.data());
      f.start_writeback();
    }
    f.flush();
    const auto moved = path("moved.h5");
    std::filesystem::rename(file, moved);
    EXPECT_NO_THROW(f.start_writeback());  // the name opens nothing now
    EXPECT_NO_THROW(f.flush());
    std::filesystem::rename(moved, file);
  }
  const std::vector<double> all = h5::File::open(file, false).dataset("/xyz").read_all<double>();
  ASSERT_EQ(all.size(), 3 * kRows);
  for (std::size_t i = 0; i < all.size(); ++i) ASSERT_EQ(all[i], static_cast<double>(i) + 0.25) << "element " << i;
}

TEST_F(Hdf5FileTest, ManyScatteredRowsReadAsBlocksAndPoints) {
  // Rows with many runs are read as dense spans (split at a bounded block size) plus one point
  // selection for the isolated rows and small clusters: every row lands at its place, in the
  // memory type asked for.
  const auto file = path("scattered.h5");
  constexpr std::uint64_t n = 40000;
  {
    h5::File f = h5::File::create(file);
    std::vector<std::uint16_t> v(n);
    for (std::uint64_t i = 0; i < n; ++i) v[i] = static_cast<std::uint16_t>(i % 65521);
    f.create_dataset("/u16", h5::Type::UInt16, n, 0, {.chunk_rows = 4096}).write_rows(0, n, v.data());
  }
  const h5::File f = h5::File::open(file, false);
  std::vector<std::uint64_t> rows;
  for (std::uint64_t i = 0; i < 36000; i += 2) rows.push_back(i);            // longer than one block
  for (std::uint64_t i = 36500; i < 38500; i += 600) rows.push_back(i);      // isolated rows
  for (std::uint64_t i = 38500; i < 38505; ++i) rows.push_back(i);           // a small cluster
  rows.push_back(n - 1);
  std::vector<std::uint32_t> got(rows.size(), 0);
  f.dataset("/u16").read_selected(rows, got.data());
  for (std::size_t i = 0; i < rows.size(); ++i) ASSERT_EQ(got[i], rows[i] % 65521) << "row " << rows[i];
}

TEST_F(Hdf5FileTest, ErrorsNameFileAndObject) {
  const auto file = path("b.h5");
  { h5::File::create(file).create_dataset("/x", h5::Type::Float64, 4, 0); }
  const h5::File f = h5::File::open(file, false);
  try {
    f.dataset("/missing");
    FAIL();
  } catch (const io::IoError& e) {
    EXPECT_EQ(std::string(e.what()), file.string() + ": /missing: missing dataset");
  }
  try {
    double v[8];
    f.dataset("/x").read_rows(2, 4, v);
    FAIL();
  } catch (const io::IoError& e) {
    EXPECT_EQ(std::string(e.what()), file.string() + ": /x: rows out of range");
  }
  EXPECT_THROW(f.string_attribute("/", "nothing"), io::IoError);
  std::ofstream(path("text.h5")) << "not hdf5\n";
  try {
    h5::File::open(path("text.h5"), false);
    FAIL();
  } catch (const io::IoError& e) {
    EXPECT_EQ(std::string(e.what()), path("text.h5").string() + ": not an HDF5 file");
  }
  EXPECT_THROW(h5::File::open(path("none.h5"), false), io::IoError);
}

}  // namespace
