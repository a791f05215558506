// pointfair_mpi import under mpirun (import_points with MpiRanks): each rank reads its share
// of a binary PLY or LAS file (rank 0 all of a text file) and writes its points with parallel
// HDF5; the container equals pointfair import's, dataset for dataset and attribute for
// attribute (h5diff), for 1 to 4 ranks, kd tiles with cut cells, grid tiles and deflate, and a
// folder of files.
#include <sys/wait.h>

#include <cstdlib>
#include <fstream>
#include <sstream>

#include "pointfair/io/point_file.hpp"
#include "pointfair/tiles/container.hpp"
#include "tiles_test_util.hpp"

using namespace pointfair;
using namespace pointfair::tiles;

namespace {

class MpiImportTest : public test::TempDirTest {
 protected:
  // Runs `command` with its output in log_; returns its exit code.
  int shell(const std::string& command) {
    const int status = std::system((command + " > " + path("log.txt").string() + " 2>&1").c_str());
    std::ifstream in(path("log.txt"));
    std::stringstream text;
    text << in.rdbuf();
    log_ = text.str();
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }

  int import_serial(const std::string& in, const std::string& out, const std::string& options) {
    return shell(std::string(POINTFAIR_EXE) + " import " + path(in).string() + " " + path(out).string() +
                 " --quiet " + options);
  }

  int import_mpi(int ranks, const std::string& in, const std::string& out, const std::string& options) {
    std::ostringstream cmd;
    cmd << "env OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1 "
        << "OMPI_MCA_btl_vader_single_copy_mechanism=none timeout -k 5 60 " << POINTFAIR_MPIEXEC
        << " --oversubscribe -np " << ranks << " " << POINTFAIR_MPI_EXE << " import " << path(in) << " "
        << path(out) << " " << options;
    return shell(cmd.str());
  }

  // h5diff's exit code: 0 when every dataset and attribute is equal.
  int h5diff(const std::string& a, const std::string& b) {
    return shell("h5diff " + path(a).string() + " " + path(b).string());
  }

  // The single-process import and the import on each rank count, compared.
  void expect_same_import(const std::string& in, const std::string& options, std::initializer_list<int> ranks) {
    ASSERT_EQ(import_serial(in, "ref.h5", options), 0) << log_;
    for (const int r : ranks) {
      const std::string out = "mpi" + std::to_string(r) + ".h5";
      ASSERT_EQ(import_mpi(r, in, out, options), 0) << log_;
      EXPECT_EQ(h5diff("ref.h5", out), 0) << r << " ranks: " << log_;
      // The tile table and the rows, read back.
      const h5::File a = h5::File::open(path("ref.h5"), false), b = h5::File::open(path(out), false);
      for (const char* d : {"/points/original_index", "/tiles/offsets"})
        EXPECT_EQ(a.dataset(d).read_all<std::uint64_t>(), b.dataset(d).read_all<std::uint64_t>()) << d;
      for (const char* d : {"/points/positions", "/tiles/bounds"})
        EXPECT_EQ(a.dataset(d).read_all<double>(), b.dataset(d).read_all<double>()) << d;
    }
    for (const auto& entry : std::filesystem::directory_iterator(dir_))  // no temporary left
      EXPECT_NE(entry.path().filename().string().front(), '.') << entry.path();
  }

  std::string log_;
};

TEST_F(MpiImportTest, BinaryPlyOnThreeAndFourRanksEqualsTheSingleProcessImport) {
  io::write_points(path("in.ply"), test::noisy_cube(6000, 5));
  expect_same_import("in.ply", "--tile-points 700", {3, 4});
}

TEST_F(MpiImportTest, BinaryPlyOnOneAndTwoRanksEqualsTheSingleProcessImport) {
  io::write_points(path("in.ply"), test::noisy_cube(6000, 5));
  expect_same_import("in.ply", "--tile-points 700", {1, 2});
  // h5diff tells containers apart: other tiles are another container.
  ASSERT_EQ(import_serial("in.ply", "other.h5", "--tile-points 2000"), 0) << log_;
  EXPECT_NE(h5diff("ref.h5", "other.h5"), 0);
}

TEST_F(MpiImportTest, LasAndTextFilesEqualTheSingleProcessImport) {
  io::write_points(path("in.las"), test::noisy_cube(3000, 6));
  expect_same_import("in.las", "--tile-points 500", {3});
  io::write_points(path("in.xyz"), test::noisy_cube(2000, 7));
  expect_same_import("in.xyz", "--tile-points 500", {2});  // rank 0 reads the text alone
}

// A folder of tiles, read as one cloud of the files' positions in name order (each rank skips
// through the files to its share; rank 0 reads everything once a text file declares no count),
// equals the single-process import of the folder.
TEST_F(MpiImportTest, AFolderOfFilesEqualsTheSingleProcessImport) {
  std::filesystem::create_directories(path("tiles"));
  io::write_points(path("tiles") / "a.ply", test::noisy_cube(2000, 9));
  io::write_points(path("tiles") / "b.las", test::noisy_cube(2500, 10));
  expect_same_import("tiles", "--tile-points 600", {2, 3});
  io::write_points(path("tiles") / "c.xyz", test::noisy_cube(1000, 11));
  expect_same_import("tiles", "--tile-points 600", {2});
}

// A LAS 1.4 file's EVLRs (after the points) are read by every rank, not only by the last
// rank's share: the container's LAS records equal the single-process import's.
TEST_F(MpiImportTest, LasEvlrsReachEveryRank) {
  io::PointTable cloud = test::noisy_cube(3000, 8);
  io::LasMetadata las;
  las.version_minor = 4;
  las.point_format = 6;
  las.records.push_back({"LASF_Projection", 2112, "OGC WKT", "PROJCS[\"x\"]", false});
  las.records.push_back({"pointfair", 7, "an extended record", std::string(70000, 'Z'), true});
  cloud.las = las;
  io::write_points(path("evlr.las"), cloud);
  expect_same_import("evlr.las", "--tile-points 500", {3});
  const io::PointTable back = read_container(path("mpi3.h5"));
  ASSERT_TRUE(back.las);
  ASSERT_EQ(back.las->records.size(), 2u);
  EXPECT_TRUE(back.las->records[1].extended);
  EXPECT_EQ(back.las->records[1].data, std::string(70000, 'Z'));
}

TEST_F(MpiImportTest, CellsCutIntoTilesGridTilesAndDeflateEqualTheSingleProcessImport) {
  // 1500 copies of one point: a histogram cell cut into tiles of consecutive input points,
  // whose points the ranks share.
  io::PointTable t = test::noisy_cube(3000, 8);
  for (std::size_t i = 0; i < 1500; ++i) t.positions[2 * i] = Vec3(0.25, 0.25, 0.0);
  io::write_points(path("dup.ply"), t);
  expect_same_import("dup.ply", "--tile-points 200", {3});
  expect_same_import("dup.ply", "--tile-size 0.3", {2});
  expect_same_import("dup.ply", "--tile-points 400 --deflate 3 --chunk-rows 256", {2});
}

TEST_F(MpiImportTest, UnreadableInputEndsEveryRankWithTheFileNamed) {
  std::ofstream(path("bad.ply")) << "ply\nformat binary_little_endian 1.0\nelement vertex 1000\nproperty float x\n"
                                    "property float y\nproperty float z\nend_header\n";
  EXPECT_NE(import_mpi(2, "bad.ply", "out.h5", ""), 0);
  EXPECT_NE(log_.find("bad.ply"), std::string::npos) << log_;
  EXPECT_NE(log_.find("pointfair_mpi: rank"), std::string::npos) << log_;
  EXPECT_FALSE(std::filesystem::exists(path("out.h5")));
}

}  // namespace
