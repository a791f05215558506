// The share-out of a run's memory budget (budget.hpp): tiles grow with the budget; a run
// whose tiles follow its budget, once taken, is taken at every larger budget with the same
// bits; the budget a refusal names is taken.
#include "pointfair/tiles/budget.hpp"

#include <algorithm>
#include <vector>

#include "pointfair/neighbors/neighborhood_size.hpp"
#include "pointfair/tiles/container.hpp"
#include "pointfair/tiles/import.hpp"
#include "pointfair/tiles/tiled_smooth.hpp"
#include "tiles_test_util.hpp"

using namespace pointfair;
using namespace pointfair::tiles;

namespace {

constexpr std::uint64_t kMiB = std::uint64_t{1} << 20;

TEST(TileBudget, TilesGrowWithTheBudget) {
  for (const int k : {16, 48, 200}) {
    SCOPED_TRACE(testing::Message() << "k " << k);
    std::uint64_t previous = 0;
    for (std::uint64_t budget = 1024; budget <= (std::uint64_t{64} << 30); budget += budget / 4) {
      const std::uint64_t points = tile_points_for_budget(budget, k);
      EXPECT_GE(points, previous) << budget;
      EXPECT_GE(points, 64u);
      previous = points;
    }
  }
  // Twice what was needed, in whole MiB.
  EXPECT_EQ(budget_to_name(1), kMiB);
  EXPECT_EQ(budget_to_name(kMiB / 2), kMiB);
  EXPECT_EQ(budget_to_name(5 * kMiB / 2 + 1), 6 * kMiB);
}

// The k a run's tiles are sized for: the flow's (the largest automatic k when it is chosen)
// and the finish's, the larger; an import sizes them for the defaults' largest.
TEST(TileBudget, TilesAreSizedForTheLargestK) {
  SmoothParams params;
  params.finish.reset();
  params.neighbors.k = 0;
  EXPECT_EQ(flow_k_bound(params), kAutoKMax);
  EXPECT_EQ(run_tile_points(kDefaultMemoryBudget, params), tile_points_for_budget(kDefaultMemoryBudget, kAutoKMax));
  params.neighbors.k = 20;
  EXPECT_EQ(flow_k_bound(params), 20);
  EXPECT_EQ(run_tile_points(kDefaultMemoryBudget, params), tile_points_for_budget(kDefaultMemoryBudget, 20));
  params.finish = QuadricProjectionParams{};
  params.finish->k = 100;
  EXPECT_EQ(run_tile_points(kDefaultMemoryBudget, params), tile_points_for_budget(kDefaultMemoryBudget, 100));
  EXPECT_EQ(import_tile_points(kDefaultMemoryBudget),
            tile_points_for_budget(kDefaultMemoryBudget, std::max(kAutoKMax, QuadricProjectionParams{}.k)));
  EXPECT_EQ(kDefaultMemoryBudget, 256 * kMiB);
  EXPECT_EQ(StreamImportOptions{}.memory_budget, kDefaultMemoryBudget);
  EXPECT_EQ(OutOfCoreOptions{}.memory_budget, kDefaultMemoryBudget);
}

class BudgetTest : public test::TempDirTest {
 protected:
  // The run of `params` on `cloud` as a point file's is run at `budget`: imported with the
  // budget's tiles (for k neighbours, the largest the run uses), then smoothed within it.
  OutOfCoreReport run_at(const io::PointTable& cloud, const SmoothParams& params, int k, std::uint64_t budget) {
    std::filesystem::remove(path("in.h5"));
    std::filesystem::remove(path("run.h5"));
    std::filesystem::remove(path("run.h5.partial"));
    write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = tile_points_for_budget(budget, k)}));
    OutOfCoreOptions options;
    options.memory_budget = budget;
    return smooth_out_of_core(path("in.h5"), path("run.h5"), params, options);
  }
};

// Budgets from 128 KiB up, a quarter more each time, on a small cloud with the finish (its
// neighbourhoods scaled down with the cloud): the smallest are refused, and every budget
// from the first one taken on is taken, with the in-core bits and within the budget. A
// refusal names a budget that is taken.
TEST_F(BudgetTest, ALargerBudgetNeverNeedsMore) {
  const io::PointTable cloud = test::noisy_cube(4000, 31);
  QuadricProjectionParams finish;
  finish.k = 40;
  SmoothParams params = test::finishing(test::few_steps(2), finish);
  params.neighbors.k = 16;
  const test::InCore ref = test::run_in_core(cloud, params);
  std::uint64_t first_taken = 0;
  int refused = 0;
  for (std::uint64_t budget = 128u << 10; budget <= 3 * kMiB; budget += budget / 4) {
    SCOPED_TRACE(testing::Message() << "budget " << budget);
    try {
      const OutOfCoreReport r = run_at(cloud, params, finish.k, budget);
      EXPECT_LE(r.peak_accounted_bytes, budget);
      test::expect_identical(path("run.h5"), ref);
      if (first_taken == 0) first_taken = budget;
    } catch (const BudgetError& e) {
      EXPECT_EQ(first_taken, 0u) << "refused after " << first_taken << " was taken: " << e.what();
      EXPECT_GT(e.needed, budget) << e.what();
      ++refused;
      if (refused > 2) continue;  // the named budgets are alike from here
      const std::uint64_t named = budget_to_name(e.needed);
      SCOPED_TRACE(testing::Message() << "named " << named);
      EXPECT_NO_THROW(run_at(cloud, params, finish.k, named));
      test::expect_identical(path("run.h5"), ref);
    }
  }
  EXPECT_GT(refused, 0) << "not the case this test is for: no budget was too small";
  EXPECT_GT(first_taken, 0u);
}

// A lambda sample larger than the room kept for it (lambda_sample_room; 50,000 points, about
// 2.2 MiB gathered) is not gathered: each lambda reads the sample from the run file in
// pieces, to the in-core bits, measured every step or once with rebuilds, from positions
// streamed a tile at a time.
TEST_F(BudgetTest, ASampleThatIsNotGatheredGivesTheSameBits) {
  const io::PointTable cloud = test::noisy_cube(50000, 37);
  write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 4000}));
  for (const bool every_step : {true, false}) {
    SCOPED_TRACE(every_step ? "lambda every step" : "lambda once, rebuilt");
    SmoothParams params = test::few_steps(3);
    params.neighbors.k = 16;
    params.lambda_every_step = every_step;
    if (!every_step) params.rebuild_interval = 2;
    const test::InCore ref = test::run_in_core(cloud, params);
    OutOfCoreOptions options;
    options.memory_budget = 6 * kMiB;
    const OutOfCoreReport r = smooth_out_of_core(path("in.h5"), path("run.h5"), params, options);
    EXPECT_FALSE(r.positions_held) << "not the case this test is for";
    EXPECT_LE(r.peak_accounted_bytes, options.memory_budget);
    EXPECT_EQ(r.lambda, ref.report.lambda);
    test::expect_identical(path("run.h5"), ref);
    std::filesystem::remove(path("run.h5"));
  }
}

}  // namespace
