// The quadric finish out of core (SmoothParams::finish): bit-identical to smooth()
// + finish_with_quadrics + compute_attributes in memory, for tiles of a handful of points,
// empty tiles, one or two threads; stopped during or after the finish and resumed, the same
// bits; a resume with other finish parameters is refused.
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "pointfair/common/parallel.hpp"
#include "pointfair/common/params_error.hpp"
#include "pointfair/finish/quadric_projection.hpp"
#include "pointfair/tiles/container.hpp"
#include "pointfair/tiles/tiled_smooth.hpp"
#include "tiles_test_util.hpp"

using namespace pointfair;
using namespace pointfair::tiles;

namespace {

using test::few_steps;

QuadricProjectionParams finish_params(int passes, int degree) {
  QuadricProjectionParams q;
  q.k = 30;
  q.passes = passes;
  q.degree = degree;
  q.curvature_reach = 0.0;  // every fit over all k (the test of the tiling sets it)
  return q;
}

class TiledFinishTest : public test::TempDirTest {
 protected:
  void TearDown() override {
    set_thread_count(0);
    TempDirTest::TearDown();
  }
  // The options of a run with a finish (which SmoothParams::finish carries).
  OutOfCoreOptions with_finish(const QuadricProjectionParams&) const { return {}; }
};

TEST_F(TiledFinishTest, BitIdenticalToInCoreForAnyTilingAndThreads) {
  const io::PointTable cloud = test::noisy_cube(1200, 41);
  const SmoothParams params = few_steps(2);
  struct Case {
    const char* name;
    tiles::TilingParams tiling;
  };
  const Case cases[] = {
      {"one tile", {.max_tile_points = 1u << 20}},
      {"kd 150", {.max_tile_points = 150}},
      {"kd 5 (a handful of points a tile)", {.max_tile_points = 5}},
      {"cells 0.3 (empty tiles)", {.cell_size = 0.3}},
  };
  for (const auto& [passes, degree] : {std::pair{1, 2}, std::pair{2, 3}}) {
    QuadricProjectionParams q = finish_params(passes, degree);
    if (degree == 3) {  // and fits bounded by the pilot curvature
      q.curvature_reach = 0.7;
      q.min_k = 12;
    }
    const test::InCore ref = test::run_in_core(cloud, test::finishing(params, q));
    // The finish moved the points: a run without it would not pass.
    ASSERT_NE(ref.positions, test::run_in_core(cloud, params).positions);
    for (const Case& c : cases) {
      write_container(path("in.h5"), cloud, test::tiled(c.tiling, 256));
      const TileTable tiles = read_tile_table(h5::File::open(path("in.h5"), false));
      std::size_t empty = 0;
      for (std::size_t t = 0; t < tiles.size(); ++t) empty += tiles.rows(t) == 0;
      if (c.tiling.cell_size > 0.0) {
        EXPECT_GT(empty, 0u) << "not the case this test is for";
      }
      for (const int threads : {1, 2}) {
        SCOPED_TRACE(testing::Message() << c.name << ", passes " << passes << ", degree " << degree << ", "
                                        << threads << " threads");
        set_thread_count(threads);
        const OutOfCoreReport r = smooth_out_of_core(path("in.h5"), path("run.h5"), test::finishing(params, q), with_finish(q));
        EXPECT_TRUE(r.finished);
        EXPECT_EQ(r.finish_passes, passes);
        EXPECT_EQ(r.lambda, ref.report.lambda);
        test::expect_identical(path("run.h5"), ref);
        std::filesystem::remove(path("run.h5"));
      }
    }
  }
}

// Fit sharing out of core: a tile's points read the fits of seeds in its halo, whose own
// lists reach beyond the tile's (their balls must lie inside what was gathered). Small tiles,
// wide fits and seeds of every second point put many seeds near the halo's edge: the same
// bits as in core.
TEST_F(TiledFinishTest, SharedFitsOfTheHalosSeedsGiveTheInCoreBits) {
  const io::PointTable cloud = test::noisy_cube(3000, 43);
  const SmoothParams params = few_steps(1);
  for (const int stride : {2, 4}) {
    QuadricProjectionParams q = finish_params(1, 3);
    q.k = 60;
    q.curvature_reach = 0.7;  // sharing reads the seeds' pilot curvature
    q.min_k = 12;
    q.share_stride = stride;
    q.share_turn = 1.0;
    const test::InCore ref = test::run_in_core(cloud, test::finishing(params, q));
    QuadricProjectionParams own = q;
    own.share_stride = 1;
    ASSERT_NE(ref.positions, test::run_in_core(cloud, test::finishing(params, own)).positions);
    for (const std::uint64_t tile_points : {3u, 12u, 40u, 200u}) {
      SCOPED_TRACE(testing::Message() << "stride " << stride << ", tiles of " << tile_points);
      write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = tile_points}, 256));
      EXPECT_TRUE(smooth_out_of_core(path("in.h5"), path("run.h5"), test::finishing(params, q), with_finish(q)).finished);
      test::expect_identical(path("run.h5"), ref);
      std::filesystem::remove(path("run.h5"));
    }
  }
}

// The finish after the other ways of stepping: rebuilt lists (the attributes use the last
// ones), temporal blocks, compensated steps.
// A tile whose finish (the fits' k with their halo) does not fit the budget whole, though its
// steps do, is finished in parts (halved until each part with its halo fits): the same bits,
// at every budget from the one that holds the steps up.
TEST_F(TiledFinishTest, TilesTooLargeForTheBudgetAreFinishedInPartsToTheSameBits) {
  const io::PointTable cloud = test::noisy_cube(5000, 47);
  const SmoothParams params = few_steps(2);
  QuadricProjectionParams q = finish_params(2, 3);
  q.k = 120;
  const test::InCore ref = test::run_in_core(cloud, test::finishing(params, q));
  write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 500}, 256));
  set_thread_count(2);
  std::uint64_t in_parts_at_most = 0;
  int refused = 0;
  for (const std::uint64_t kib : {768u, 1024u, 1536u, 65536u}) {
    SCOPED_TRACE(testing::Message() << kib << " KiB");
    OutOfCoreOptions options = with_finish(q);
    options.memory_budget = kib << 10;
    OutOfCoreReport r;
    try {
      r = smooth_out_of_core(path("in.h5"), path("run.h5"), test::finishing(params, q), options);
    } catch (const BudgetError& e) {
      // Too small for the steps' one tile: refused before any finish pass began.
      EXPECT_EQ(in_parts_at_most, 0u) << "a larger budget was refused after a smaller one ran: " << e.what();
      ++refused;
      std::filesystem::remove(partial_name(path("run.h5")));
      continue;
    }
    EXPECT_TRUE(r.finished);
    test::expect_identical(path("run.h5"), ref);
    std::filesystem::remove(path("run.h5"));
    if (in_parts_at_most == 0) in_parts_at_most = r.finish_tiles_in_parts;
    if (kib == 65536u) {
      EXPECT_EQ(r.finish_tiles_in_parts, 0u) << "a budget that holds the whole tile";
    }
  }
  // The case this test is for: the smallest budget that ran finished tiles in parts.
  EXPECT_GT(in_parts_at_most, 0u) << refused << " budgets refused";
}

TEST_F(TiledFinishTest, AfterRebuildsBlocksAndCompensationLikeInCore) {
  const io::PointTable cloud = test::noisy_cube(1500, 46);
  write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 120}, 256));
  set_thread_count(2);
  struct Case {
    const char* name;
    int rebuild_interval;
    int temporal_block;
    double shrink_compensation;
  };
  for (const Case& c : {Case{"rebuild every 2 steps", 2, 1, 0.0}, Case{"temporal blocks of 2", 0, 2, 0.0},
                        Case{"compensated, blocks of 2", 0, 2, 1.0}, Case{"compensated", 0, 1, 1.0}}) {
    SCOPED_TRACE(c.name);
    SmoothParams params = few_steps(4);
    params.rebuild_interval = c.rebuild_interval;
    params.shrink_compensation = c.shrink_compensation;
    params.lambda_every_step = c.temporal_block == 1;
    const QuadricProjectionParams q = finish_params(1, 3);
    const test::InCore ref = test::run_in_core(cloud, test::finishing(params, q));
    OutOfCoreOptions options = with_finish(q);
    options.temporal_block = c.temporal_block;
    EXPECT_TRUE(smooth_out_of_core(path("in.h5"), path("run.h5"), test::finishing(params, q), options).finished);
    test::expect_identical(path("run.h5"), ref);
    std::filesystem::remove(path("run.h5"));
  }
}

TEST_F(TiledFinishTest, EmptyTilesAndTinyClouds) {
  // Fewer points than the fit's k (rows shorter than k), down to none; tiles of three points.
  for (const std::size_t n : {0u, 1u, 2u, 7u, 40u}) {
    SCOPED_TRACE(n);
    const io::PointTable cloud = test::noisy_cube(n, 42);
    for (const int steps : {0, 2}) {
      const SmoothParams params = few_steps(steps);
      const QuadricProjectionParams q = finish_params(2, 2);
      const test::InCore ref = test::run_in_core(cloud, test::finishing(params, q));
      write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 3}));
      EXPECT_TRUE(smooth_out_of_core(path("in.h5"), path("run.h5"), test::finishing(params, q), with_finish(q)).finished);
      test::expect_identical(path("run.h5"), ref);
      std::filesystem::remove(path("run.h5"));
    }
  }
}

// Stopped during the steps, after the first finish pass and after the last (before the
// attributes), then resumed: the bits of the uninterrupted run, which are the in-core ones.
TEST_F(TiledFinishTest, StoppedAndResumedToTheSameBits) {
  const io::PointTable cloud = test::noisy_cube(1500, 43);
  const SmoothParams params = few_steps(3);
  const QuadricProjectionParams q = finish_params(2, 2);
  const test::InCore ref = test::run_in_core(cloud, test::finishing(params, q));
  write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 200}, 256));
  set_thread_count(2);
  for (const int stop_steps : {1, -1}) {
    for (const int stop_passes : {-1, 1, 2}) {
      if (stop_steps < 0 && stop_passes < 0) continue;
      SCOPED_TRACE(testing::Message() << "stopped after " << stop_steps << " steps, " << stop_passes << " passes");
      OutOfCoreOptions stop = with_finish(q);
      stop.stop_after_steps = stop_steps;
      stop.stop_after_finish_passes = stop_passes;
      const OutOfCoreReport first = smooth_out_of_core(path("in.h5"), path("run.h5"), test::finishing(params, q), stop);
      EXPECT_FALSE(first.finished);
      EXPECT_FALSE(std::filesystem::exists(path("run.h5")));
      if (stop_steps < 0) {
        EXPECT_EQ(first.finish_passes, stop_passes);
      }
      OutOfCoreOptions resume = with_finish(q);
      resume.resume = true;
      if (stop_steps >= 0) resume.stop_after_finish_passes = stop_passes;
      OutOfCoreReport second = smooth_out_of_core(path("in.h5"), path("run.h5"), test::finishing(params, q), resume);
      if (!second.finished) {
        resume.stop_after_finish_passes = -1;
        second = smooth_out_of_core(path("in.h5"), path("run.h5"), test::finishing(params, q), resume);
      }
      EXPECT_TRUE(second.finished);
      EXPECT_EQ(second.finish_passes, 2);
      EXPECT_EQ(second.lambda, ref.report.lambda);
      test::expect_identical(path("run.h5"), ref);
      std::filesystem::remove(path("run.h5"));
    }
  }
}

// Interrupted inside a pass (the progress callback throws, as the command line's interrupt
// does), after some of its tiles were written to the other buffer but before its commit:
// the resumed run does the pass again and ends with the same bits.
TEST_F(TiledFinishTest, InterruptedInsideAPassResumesToTheSameBits) {
  const io::PointTable cloud = test::noisy_cube(1500, 47);
  const SmoothParams params = few_steps(2);
  const QuadricProjectionParams q = finish_params(2, 2);
  const test::InCore ref = test::run_in_core(cloud, test::finishing(params, q));
  write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 200}, 256));
  const TileTable tiles = read_tile_table(h5::File::open(path("in.h5"), false));
  std::size_t filled = 0;
  for (std::size_t t = 0; t < tiles.size(); ++t) filled += tiles.rows(t) > 0;
  ASSERT_GT(filled, 3u);
  // The second tile of the first pass, the second of the second.
  for (const std::size_t interrupt_at : {std::size_t{2}, filled + 2}) {
    SCOPED_TRACE(interrupt_at);
    OutOfCoreOptions first = with_finish(q);
    std::size_t finished_tiles = 0;
    first.progress = [&](const std::string& phase, std::uint64_t, std::uint64_t) {
      if (phase == "finish" && ++finished_tiles == interrupt_at) throw std::runtime_error("interrupted");
    };
    EXPECT_THROW(smooth_out_of_core(path("in.h5"), path("run.h5"), test::finishing(params, q), first), std::runtime_error);
    ASSERT_TRUE(std::filesystem::exists(partial_name(path("run.h5"))));
    OutOfCoreOptions resume = with_finish(q);
    resume.resume = true;
    const OutOfCoreReport r = smooth_out_of_core(path("in.h5"), path("run.h5"), test::finishing(params, q), resume);
    EXPECT_TRUE(r.finished);
    EXPECT_EQ(r.finish_passes, 2);
    test::expect_identical(path("run.h5"), ref);
    std::filesystem::remove(path("run.h5"));
  }
}

// An automatic stop: the attributes use the lambda measured on the flow's final positions,
// which the finish overwrites; a run stopped after a finish pass and resumed keeps it.
TEST_F(TiledFinishTest, AutomaticStopThenFinishResumesWithTheStopsLambda) {
  const io::PointTable cloud = test::noisy_cube(3000, 44);
  SmoothParams params;  // defaults: stop when lambda falls to stop_lambda_ratio of the input's
  params.steps = 60;
  const QuadricProjectionParams q = finish_params(2, 2);
  const test::InCore ref = test::run_in_core(cloud, test::finishing(params, q));
  ASSERT_TRUE(ref.report.stopped_early);
  write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 500}));
  OutOfCoreOptions stop = with_finish(q);
  stop.stop_after_finish_passes = 1;
  EXPECT_FALSE(smooth_out_of_core(path("in.h5"), path("run.h5"), test::finishing(params, q), stop).finished);
  OutOfCoreOptions resume = with_finish(q);
  resume.resume = true;
  const OutOfCoreReport r = smooth_out_of_core(path("in.h5"), path("run.h5"), test::finishing(params, q), resume);
  EXPECT_TRUE(r.finished);
  EXPECT_EQ(r.steps, ref.report.steps);
  EXPECT_EQ(r.lambda, ref.report.lambda);
  test::expect_identical(path("run.h5"), ref);
}

TEST_F(TiledFinishTest, ResumeWithOtherFinishParametersIsRefused) {
  const io::PointTable cloud = test::noisy_cube(800, 45);
  const SmoothParams params = few_steps(2);
  const QuadricProjectionParams q = finish_params(2, 2);
  write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 200}));
  OutOfCoreOptions stop = with_finish(q);
  stop.stop_after_finish_passes = 1;
  EXPECT_FALSE(smooth_out_of_core(path("in.h5"), path("run.h5"), test::finishing(params, q), stop).finished);
  OutOfCoreOptions resume;
  resume.resume = true;
  EXPECT_THROW(smooth_out_of_core(path("in.h5"), path("run.h5"), params, resume), ParamError) << "no finish";
  QuadricProjectionParams other_k = q, other_passes = q, other_degree = q, other_angle = q, other_reach = q,
                          other_min_k = q;
  other_k.k = 31;
  other_passes.passes = 3;
  other_degree.degree = 5 - q.degree;
  other_angle.normal_angle = 20.0;
  other_reach.curvature_reach = q.curvature_reach + 0.2;
  other_min_k.min_k = 20;
  for (const QuadricProjectionParams& other :
       {other_k, other_passes, other_degree, other_angle, other_reach, other_min_k}) {
    EXPECT_THROW(smooth_out_of_core(path("in.h5"), path("run.h5"), test::finishing(params, other), resume), ParamError);
  }
  // The refusal names what differs, with the run's value and this run's.
  try {
    smooth_out_of_core(path("in.h5"), path("run.h5"), test::finishing(params, other_k), resume);
    ADD_FAILURE() << "resumed with another quadric k";
  } catch (const ParamError& e) {
    EXPECT_NE(std::string(e.what()).find("quadric_k: " + std::to_string(q.k) + " in the run, 31 now"),
              std::string::npos)
        << e.what();
  }
  SmoothParams free_placement = test::finishing(params, q);
  free_placement.placement = Placement::Free;
  EXPECT_THROW(smooth_out_of_core(path("in.h5"), path("run.h5"), free_placement, resume), ParamError)
      << "other placement";
  // The run itself still resumes with its own.
  EXPECT_TRUE(smooth_out_of_core(path("in.h5"), path("run.h5"), test::finishing(params, q), resume).finished);
  test::expect_identical(path("run.h5"), test::run_in_core(cloud, test::finishing(params, q)));
}

}  // namespace
