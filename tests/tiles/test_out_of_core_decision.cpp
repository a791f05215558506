// Whether a smooth runs out of core (out_of_core_decision.hpp): the in-core estimate, exact on
// tiny cases, and the rule: containers and resumes always, a point file when its in-core run
// does not fit the budget.
#include "pointfair/tiles/out_of_core_decision.hpp"

#include "pointfair/io/point_file.hpp"
#include "pointfair/neighbors/neighborhood_size.hpp"
#include "pointfair/tiles/budget.hpp"
#include "tiles_test_util.hpp"

using namespace pointfair;
using namespace pointfair::tiles;

namespace {

TEST(InCoreEstimate, TinyCases) {
  EXPECT_EQ(in_core_bytes(0, 16), 0u);
  EXPECT_EQ(in_core_bytes(10, 16), 10u * (4 * 24 + 8 * 16 + 64));
  EXPECT_EQ(in_core_bytes(10, 16, true), 10u * (5 * 24 + 8 * 16 + 64));
  QuadricProjectionParams finish;
  finish.k = 100;
  finish.normal_neighbors = 20;
  finish.share_stride = 1;
  EXPECT_EQ(in_core_finish_bytes(10, finish), 10u * (4 * 24 + 8 + 50) + 10u * (4 * 100 + 2));
  // Fit sharing: an index a point, a fit and its index a seed, and the short lists' grid.
  finish.share_stride = 4;
  EXPECT_EQ(in_core_finish_bytes(10, finish),
            10u * (4 * 24 + 8 + 50 + 4 + (sizeof(QuadricFit) + 4) / 4 + 1 + 50) + 10u * (4 * 100 + 2));
}

TEST(InCoreEstimate, TheAutomaticKIsSizedForItsLargest) {
  SmoothParams params;
  params.finish.reset();
  params.neighbors.k = 0;
  const std::uint64_t points = 1000;
  const std::uint64_t need = in_core_bytes(points, kAutoKMax, params.shrink_compensation > 0.0);
  EXPECT_TRUE(fits_in_core(points, params, need));
  EXPECT_FALSE(fits_in_core(points, params, need - 1));
}

TEST(ContainerPath, ByExtension) {
  EXPECT_TRUE(is_container_path("a.h5"));
  EXPECT_TRUE(is_container_path("dir/a.HDF5"));
  EXPECT_FALSE(is_container_path("a.ply"));
  EXPECT_FALSE(is_container_path("h5"));
}

class OutOfCoreDecision : public test::TempDirTest {};

TEST_F(OutOfCoreDecision, ContainersAndResumesAlwaysAPointFileWhenItDoesNotFit) {
  // A container input is not read to decide.
  EXPECT_TRUE(runs_out_of_core(path("missing.h5"), path("out.ply"), {}, std::nullopt));
  io::PointTable cloud = test::noisy_cube(500, 1);
  const auto ply = path("cloud.ply");
  io::write_points(ply, cloud);
  EXPECT_EQ(io::count_points(ply), 500u);
  SmoothParams params;
  EXPECT_FALSE(runs_out_of_core(ply, path("out.ply"), params, std::nullopt));
  EXPECT_TRUE(runs_out_of_core(ply, path("out.h5"), params, std::nullopt));
  EXPECT_TRUE(runs_out_of_core(ply, path("out.ply"), params, std::nullopt, true));
  EXPECT_FALSE(runs_out_of_core(ply, path("out.ply"), params, kDefaultMemoryBudget));
  EXPECT_TRUE(runs_out_of_core(ply, path("out.ply"), params, 1024));
}

}  // namespace
