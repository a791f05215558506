// Out-of-core runs are bit-identical to smooth() + compute_attributes(), for any tiling,
// eps and lambda policy and thread count; they resume to the same bits; they account memory.
#include "pointfair/tiles/tiled_smooth.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include "pointfair/common/parallel.hpp"
#include "pointfair/common/params_error.hpp"
#include "pointfair/io/point_file.hpp"
#include "pointfair/tiles/container.hpp"
#include "tiles_test_util.hpp"

using namespace pointfair;
using namespace pointfair::tiles;

namespace {

using test::expect_identical;
using test::few_steps;
using test::InCore;
using test::run_in_core;

// A plateau that stops the compensated flow on the noisy cube well before 60 steps.
constexpr double kPlateau = 0.03;

class TiledSmoothTest : public test::ThreadsTempDirTest {
 protected:
  // The run of `options` stopped after its first step (block), then resumed with temporal
  // blocks of `resumed_block`: the same bits as `ref`. Removes the run file.
  void expect_stopped_and_resumed_identical(const SmoothParams& params, OutOfCoreOptions options,
                                            int resumed_block, const InCore& ref) {
    options.stop_after_steps = 1;
    EXPECT_FALSE(smooth_out_of_core(path("in.h5"), path("run.h5"), params, options).finished);
    OutOfCoreOptions resume;
    resume.resume = true;
    resume.temporal_block = resumed_block;
    EXPECT_TRUE(smooth_out_of_core(path("in.h5"), path("run.h5"), params, resume).finished);
    expect_identical(path("run.h5"), ref);
    std::filesystem::remove(path("run.h5"));
  }
  // The run stopped in resumed.h5, resumed: finished at `ref`'s step count, with its bits.
  void expect_resumes_to(const SmoothParams& params, const InCore& ref) {
    OutOfCoreOptions resume;
    resume.resume = true;
    const OutOfCoreReport resumed = smooth_out_of_core(path("in.h5"), path("resumed.h5"), params, resume);
    EXPECT_TRUE(resumed.finished);
    EXPECT_EQ(resumed.steps, ref.report.steps);
    expect_identical(path("resumed.h5"), ref);
  }
};

struct Case {
  const char* name;
  TilingParams tiling;
  double eps;  // 0 auto
  double lambda;
  bool every_step;
};

TEST_F(TiledSmoothTest, BitIdenticalToInCoreForAnyTiling) {
  const io::PointTable cloud = test::noisy_cube(3000, 11);
  const double inf = std::numeric_limits<double>::infinity();
  const Case cases[] = {
      {"one tile", {.max_tile_points = 1u << 20}, 0.0, 0.0, true},
      {"kd 400", {.max_tile_points = 400}, 0.0, 0.0, true},
      {"kd 7 (a handful of points a tile)", {.max_tile_points = 7}, 0.0, 0.0, true},
      {"grid with empty tiles", {.cell_size = 0.3}, 0.0, 0.0, true},
      {"kd 300, eps inf", {.max_tile_points = 300}, inf, 0.0, true},
      {"grid, eps inf", {.cell_size = 0.5}, inf, 0.0, false},
      {"kd 500, fixed eps and lambda", {.max_tile_points = 500}, 0.08, 12.0, true},
      {"kd 250, lambda once", {.max_tile_points = 250}, 0.0, 0.0, false},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    SmoothParams params = few_steps();
    params.neighbors.eps = c.eps;
    params.flow.lambda = c.lambda;
    params.lambda_every_step = c.every_step;
    const InCore ref = run_in_core(cloud, params);
    const auto container = path("in.h5"), run = path("run.h5");
    write_container(container, cloud, test::tiled(c.tiling, 512));
    const OutOfCoreReport r = smooth_out_of_core(container, run, params);
    EXPECT_TRUE(r.finished);
    EXPECT_EQ(r.steps, 3);
    EXPECT_EQ(r.k, ref.report.k);
    EXPECT_EQ(r.eps, ref.report.eps);
    EXPECT_EQ(r.lambda, ref.report.lambda);
    expect_identical(run, ref);
    std::filesystem::remove(run);
  }
}

TEST_F(TiledSmoothTest, AutomaticKLikeInCore) {
  // Noise of about a sample spacing: the automatic k is above 16, measured from tiles with
  // their halos (grown until the 129 nearest points of each sample are inside).
  const io::PointTable cloud = test::noisy_cube(2500, 21, 0.08);
  const TilingParams tilings[] = {{.max_tile_points = 1u << 20}, {.max_tile_points = 90}, {.cell_size = 0.4}};
  SmoothParams params = few_steps(2);
  const InCore ref = run_in_core(cloud, params);
  EXPECT_GT(ref.report.k, 16);
  for (const TilingParams& tiling : tilings) {
    write_container(path("in.h5"), cloud, test::tiled(tiling, 512));
    const OutOfCoreReport r = smooth_out_of_core(path("in.h5"), path("run.h5"), params);
    EXPECT_TRUE(r.finished);
    EXPECT_EQ(r.k, ref.report.k);
    expect_identical(path("run.h5"), ref);
    std::filesystem::remove(path("run.h5"));
  }
  // Resumed after a stop: the same k again (measured again from the input's positions).
  expect_stopped_and_resumed_identical(params, {}, 1, ref);
}

// The automatic k and eps measure each sample's nearest points (itself included) through the
// cell grid (nearest_points, checked row by row against the k-d tree in its own tests). With
// 200 copies of one point (more than the 129 nearest points k measures): the same k, eps and
// bits as in core, in one tile and in many. A non-finite coordinate in a container (which no
// reader lets in) is an error naming the file.
TEST_F(TiledSmoothTest, AutomaticKAndEpsWithManyDuplicatesLikeInCore) {
  io::PointTable cloud = test::noisy_cube(2000, 27, 0.03);
  const Vec3 copied = cloud.positions[17];
  cloud.positions.insert(cloud.positions.begin() + 1000, 200, copied);
  for (io::Attribute& a : cloud.attributes) a.values.insert(a.values.begin() + 1000, 200, 1.0);
  SmoothParams params = few_steps(2);
  const InCore ref = run_in_core(cloud, params);
  for (const TilingParams& tiling : {TilingParams{.max_tile_points = 1u << 20}, TilingParams{.max_tile_points = 150}}) {
    write_container(path("in.h5"), cloud, test::tiled(tiling, 512));
    const OutOfCoreReport r = smooth_out_of_core(path("in.h5"), path("run.h5"), params);
    EXPECT_EQ(r.k, ref.report.k);
    EXPECT_EQ(r.eps, ref.report.eps);
    expect_identical(path("run.h5"), ref);
    std::filesystem::remove(path("run.h5"));
  }
  cloud.positions[1500].y() = std::numeric_limits<double>::quiet_NaN();
  write_container(path("nan.h5"), cloud, test::tiled({.max_tile_points = 150}, 512));
  try {
    smooth_out_of_core(path("nan.h5"), path("run.h5"), params);
    ADD_FAILURE() << "no error";
  } catch (const io::IoError& e) {
    EXPECT_NE(std::string(e.what()).find("non-finite"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("nan.h5"), std::string::npos) << e.what();
  }
}

TEST_F(TiledSmoothTest, IsotropicConstrainedAndGatedFlowsToo) {
  const io::PointTable cloud = test::noisy_cube(4000, 12);
  for (int variant = 0; variant < 5; ++variant) {
    SmoothParams params = few_steps(variant == 4 ? 5 : 2);
    // 5 isotropic steps: only the first and the last measure the threshold.
    if (variant == 0 || variant == 4) params.flow.flow = Flow::Isotropic;
    if (variant == 1) params.flow.constrain_normal = true, params.flow.cutoff = Cutoff::Continuous;
    if (variant == 2) params.flow.feature_gated = true, params.flow.features.mode = FeatureMode::MaxCurvature;
    if (variant == 3) params.flow.normal_estimator = NormalEstimator::Pca;  // the defaults: robust
    const InCore ref = run_in_core(cloud, params);
    write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 333}));
    smooth_out_of_core(path("in.h5"), path("run.h5"), params);
    expect_identical(path("run.h5"), ref);
    std::filesystem::remove(path("run.h5"));
  }
}

TEST_F(TiledSmoothTest, OneAndTwoThreadsGiveTheSameBits) {
  const io::PointTable cloud = test::noisy_cube(5000, 13);
  const SmoothParams params = few_steps();
  set_thread_count(2);
  const InCore ref = run_in_core(cloud, params);
  write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 600}));
  for (const int threads : {1, 2}) {
    set_thread_count(threads);
    smooth_out_of_core(path("in.h5"), path("run.h5"), params);
    expect_identical(path("run.h5"), ref);
    std::filesystem::remove(path("run.h5"));
  }
}

// The step pipeline (read tile i+1, compute tile i, write tile i-1) with tiny tiles and
// several compute threads: the same bits for any number of tiles in flight, with the
// neighbour lists cached or re-read every step.
TEST_F(TiledSmoothTest, PipelinedStepsGiveTheSameBits) {
  const io::PointTable cloud = test::noisy_cube(3000, 18);
  // Plain steps (compensated ones: ShrinkCompensationLikeInCore).
  SmoothParams params = few_steps(3);
  params.shrink_compensation = 0.0;
  set_thread_count(3);
  const InCore ref = run_in_core(cloud, params);
  write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 25}, 64));
  for (const std::uint64_t budget : {std::uint64_t{64} << 20, std::uint64_t{600} << 10}) {
    for (const int in_flight : budget > (1u << 20) ? std::vector{1, 3} : std::vector{2, 5}) {
      SCOPED_TRACE(testing::Message() << in_flight << " tiles in flight, budget " << budget);
      OutOfCoreOptions options;
      options.tiles_in_flight = in_flight;
      options.memory_budget = budget;
      // Streamed: single steps with 2 in flight, blocks of one step with 5.
      options.step_blocks = in_flight == 5;
      const OutOfCoreReport r = smooth_out_of_core(path("in.h5"), path("run.h5"), params, options);
      EXPECT_GT(r.tiles, 100u);
      // Positions held: the steps but the last write list order, with every tile in flight.
      EXPECT_EQ(r.tiles_in_flight, r.positions_held ? static_cast<int>(r.tiles) : in_flight);
      EXPECT_EQ(r.neighbors_cached, budget > (1u << 20)) << "not the case this test is for";
      EXPECT_EQ(r.positions_held, budget > (1u << 20)) << "not the case this test is for";
      EXPECT_EQ(r.step_blocks, !r.positions_held && in_flight == 5) << "not the case this test is for";
      EXPECT_LE(r.peak_accounted_bytes, budget);
      expect_identical(path("run.h5"), ref);
      std::filesystem::remove(path("run.h5"));
    }
  }
}

// Streamed steps read each tile's halo from the halo scratch the step before wrote (not on
// the first step of a call, nor after a rebuild), or go through blocks of one step (their
// lists and rings from the block scratch): the same bits either way and with halos from the
// run file, through rebuilds, a stop and a resume; the scratch leaves no file behind. With
// a lambda of every step (the sample gathered between steps) and rebuilds, and with a fixed
// lambda (the steps but the last then write each tile in its lists' order).
TEST_F(TiledSmoothTest, StreamedHalosFromTheScratchGiveTheSameBits) {
  const io::PointTable cloud = test::noisy_cube(3000, 23);
  write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 40}, 64));
  for (const bool fixed : {false, true}) {
    SCOPED_TRACE(fixed ? "fixed lambda" : "lambda of every step, rebuilds");
    SmoothParams params = few_steps(5);
    params.shrink_compensation = 0.0;
    params.rebuild_interval = fixed ? 0 : 3;
    params.flow.lambda = fixed ? 12.0 : 0.0;
    const InCore ref = run_in_core(cloud, params);
    for (const auto& [scratch, step_blocks] :
         {std::pair{true, true}, std::pair{true, false}, std::pair{false, true}}) {
      SCOPED_TRACE(!scratch ? "halos from the run file" : step_blocks ? "blocks of one step" : "halo scratch");
      OutOfCoreOptions options;
      options.memory_budget = std::uint64_t{600} << 10;
      options.halo_scratch = scratch;
      options.step_blocks = step_blocks;
      const OutOfCoreReport r = smooth_out_of_core(path("in.h5"), path("run.h5"), params, options);
      EXPECT_FALSE(r.positions_held) << "not the case this test is for";
      EXPECT_FALSE(r.neighbors_cached) << "not the case this test is for";
      EXPECT_EQ(r.halo_scratch, scratch);
      EXPECT_EQ(r.step_blocks, scratch && step_blocks);
      EXPECT_EQ(r.rebuilds, fixed ? 0 : 1);
      expect_identical(path("run.h5"), ref);
      std::filesystem::remove(path("run.h5"));
      // Stopped after two steps, resumed the other way (blocks of one step or halo scratch,
      // whose tiles are each in their own order in the run file): the resumed call's first
      // step reads the run file.
      options.stop_after_steps = 2;
      EXPECT_FALSE(smooth_out_of_core(path("in.h5"), path("run.h5"), params, options).finished);
      options.stop_after_steps = -1;
      options.resume = true;
      options.step_blocks = !step_blocks;
      EXPECT_TRUE(smooth_out_of_core(path("in.h5"), path("run.h5"), params, options).finished);
      expect_identical(path("run.h5"), ref);
      std::filesystem::remove(path("run.h5"));
    }
  }
  std::vector<std::string> left;
  for (const auto& e : std::filesystem::directory_iterator(dir_)) left.push_back(e.path().filename().string());
  EXPECT_EQ(left, std::vector<std::string>{"in.h5"});
}

// Plain streamed steps run as blocks of one step only where the block scratch fits in the
// budget; in the window of budgets where it does not but the halo scratch does, the steps
// stream with their halos from the halo scratch, to the same bits.
TEST_F(TiledSmoothTest, WithoutRoomForTheBlockScratchSingleStepsStreamAsBefore) {
  const io::PointTable cloud = test::noisy_cube(3000, 23);
  write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 40}, 64));
  SmoothParams params = few_steps(3);
  params.shrink_compensation = 0.0;
  params.neighbors.k = 16;
  params.lambda_every_step = true;  // the lambda sample takes room too
  const InCore ref = run_in_core(cloud, params);
  std::uint64_t found = 0;
  for (std::uint64_t budget = std::uint64_t{256} << 10; budget <= std::uint64_t{900} << 10 && found == 0;
       budget += std::uint64_t{8} << 10) {
    OutOfCoreOptions options;
    options.memory_budget = budget;
    OutOfCoreReport r;
    try {
      r = smooth_out_of_core(path("in.h5"), path("run.h5"), params, options);
    } catch (const BudgetError&) {
      std::filesystem::remove(path("run.h5.partial"));
      continue;
    }
    if (r.halo_scratch && !r.step_blocks && !r.neighbors_cached) {
      found = budget;
      expect_identical(path("run.h5"), ref);
    }
    std::filesystem::remove(path("run.h5"));
    if (r.neighbors_cached || r.positions_held) break;  // larger budgets keep the lists
  }
  EXPECT_GT(found, 0u) << "no budget between 256 and 900 KiB kept the halo scratch but refused the block scratch";
}

// --rebuild-every: the lists are built again from the current positions (eps resolved again,
// halos around the tiles' current bounds), to the in-core bits, for every lambda policy; a
// run interrupted around a rebuild resumes to the same bits.
TEST_F(TiledSmoothTest, RebuildsNeighbourhoodsLikeInCore) {
  const io::PointTable cloud = test::noisy_cube(2500, 19, 0.02);
  struct Rebuild {
    const char* name;
    double eps, lambda;
    bool every_step;
    int interval;
  };
  const Rebuild cases[] = {{"auto eps, lambda every step", 0.0, 0.0, true, 2},
                           {"auto eps, lambda once per rebuild", 0.0, 0.0, false, 3},
                           {"fixed eps and lambda, every step", 0.1, 12.0, true, 1},
                           {"eps inf", std::numeric_limits<double>::infinity(), 0.0, true, 2}};
  write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 300}, 256));
  for (const Rebuild& c : cases) {
    SCOPED_TRACE(c.name);
    SmoothParams params = few_steps(5);
    params.stop_lambda_ratio = 0.0;
    params.neighbors.eps = c.eps;
    params.flow.lambda = c.lambda;
    params.lambda_every_step = c.every_step;
    params.rebuild_interval = c.interval;
    const InCore ref = run_in_core(cloud, params);
    ASSERT_GT(ref.report.rebuilds, 0);
    const OutOfCoreReport r = smooth_out_of_core(path("in.h5"), path("run.h5"), params);
    EXPECT_EQ(r.rebuilds, ref.report.rebuilds);
    EXPECT_EQ(r.eps, ref.report.eps);
    EXPECT_EQ(r.lambda, ref.report.lambda);
    expect_identical(path("run.h5"), ref);
    std::filesystem::remove(path("run.h5"));
    // Interrupted after each step in turn (before and after rebuilds), then resumed.
    for (const int stop : {2, 4}) {
      OutOfCoreOptions first;
      first.stop_after_steps = stop;
      EXPECT_FALSE(smooth_out_of_core(path("in.h5"), path("resumed.h5"), params, first).finished);
      OutOfCoreOptions resume;
      resume.resume = true;
      EXPECT_TRUE(smooth_out_of_core(path("in.h5"), path("resumed.h5"), params, resume).finished);
      expect_identical(path("resumed.h5"), ref);
      std::filesystem::remove(path("resumed.h5"));
    }
  }
}

// Plain steps with every tile's lists cached keep the positions in memory between steps
// (the run file still gets every step): the same bits as in core, across rebuilds (which
// change the halos) and when stopped after any step and resumed.
TEST_F(TiledSmoothTest, PositionsHeldInMemoryGiveTheSameBits) {
  const io::PointTable cloud = test::noisy_cube(2500, 23, 0.02);
  SmoothParams params = few_steps(5);
  params.shrink_compensation = 0.0;
  params.stop_lambda_ratio = 0.0;
  params.stop_plateau = 0.0;
  params.rebuild_interval = 2;
  const InCore ref = run_in_core(cloud, params);
  ASSERT_GT(ref.report.rebuilds, 0);
  write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 300}, 256));
  const OutOfCoreReport r = smooth_out_of_core(path("in.h5"), path("run.h5"), params);
  EXPECT_TRUE(r.positions_held) << "not the case this test is for";
  EXPECT_GT(r.tiles, 4u);
  EXPECT_EQ(r.rebuilds, ref.report.rebuilds);
  EXPECT_EQ(r.lambda, ref.report.lambda);
  EXPECT_LE(r.peak_accounted_bytes, OutOfCoreOptions{}.memory_budget);
  expect_identical(path("run.h5"), ref);
  for (const int stop : {1, 2, 3}) {
    SCOPED_TRACE(testing::Message() << "stopped after " << stop << " steps");
    OutOfCoreOptions first;
    first.stop_after_steps = stop;
    const OutOfCoreReport stopped = smooth_out_of_core(path("in.h5"), path("resumed.h5"), params, first);
    EXPECT_FALSE(stopped.finished);
    EXPECT_EQ(stopped.steps, stop);
    EXPECT_TRUE(stopped.positions_held);
    OutOfCoreOptions resume;
    resume.resume = true;
    const OutOfCoreReport resumed = smooth_out_of_core(path("in.h5"), path("resumed.h5"), params, resume);
    EXPECT_EQ(resumed.resumed_from, stop);
    EXPECT_TRUE(resumed.finished);
    expect_identical(path("resumed.h5"), ref);
    std::filesystem::remove(path("resumed.h5"));
  }
}

// While positions are held, the steps write each tile's rows in the order of its lists and
// only the last step (or an automatic stop, or --resume) brings them back into row order.
// Here the anisotropic flow with its lambda measured every step and the automatic stop: the
// same bits and the same stop as smooth(), whole and when stopped in list order and resumed.
TEST_F(TiledSmoothTest, StepsWrittenInListOrderStopAndResumeToTheSameBits) {
  const io::PointTable cloud = test::noisy_cube(3000, 25, 0.02);
  SmoothParams params;
  params.finish.reset();  // the flow alone
  params.steps = 60;
  params.shrink_compensation = 0.0;
  const InCore ref = run_in_core(cloud, params);
  ASSERT_TRUE(ref.report.stopped_early) << "not the case this test is for";
  ASSERT_GT(ref.report.steps, 3);
  write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 400}));
  const OutOfCoreReport whole = smooth_out_of_core(path("in.h5"), path("run.h5"), params);
  EXPECT_TRUE(whole.positions_held) << "not the case this test is for";
  EXPECT_EQ(whole.steps, ref.report.steps);
  EXPECT_EQ(whole.lambda, ref.report.lambda);
  expect_identical(path("run.h5"), ref);
  for (const int stop : {1, ref.report.steps - 1}) {
    SCOPED_TRACE(testing::Message() << "stopped after " << stop << " steps");
    OutOfCoreOptions first;
    first.stop_after_steps = stop;
    EXPECT_FALSE(smooth_out_of_core(path("in.h5"), path("resumed.h5"), params, first).finished);
    {
      // The commit record's step buffer (slot 5): 3 or 4, a buffer in list order.
      const auto state =
          h5::File::open(partial_name(path("resumed.h5")), false).dataset(layout::run_state).read_all<std::int64_t>();
      ASSERT_EQ(state.size(), 6u);
      EXPECT_GE(state[5], 3) << "the stopped run's positions are not in list order";
    }
    expect_resumes_to(params, ref);
    std::filesystem::remove(path("resumed.h5"));
  }
}

// --neighbors-from: the first lists built from a reference cloud (here the same samples
// without noise), given as a point file or as a container with other tiles; copied into the
// run in one pass or several; the same bits as smooth() with SmoothOptions::neighbor_reference.
TEST_F(TiledSmoothTest, NeighbourhoodsFromAReferenceLikeInCore) {
  const io::PointTable cloud = test::noisy_cube(6000, 22, 0.02);
  const io::PointTable clean = test::noisy_cube(6000, 22, 0.0);
  SmoothParams params = few_steps(3);
  params.rebuild_interval = 2;  // the rebuild uses the current positions again
  InCore ref;
  ref.positions = cloud.positions;
  SmoothOptions in_core;
  in_core.neighbor_reference = clean.positions;
  ref.report = smooth(ref.positions, params, in_core);
  ref.attributes = compute_attributes(ref.positions, ref.report.neighborhoods, params.flow, ref.report.lambda);
  // Not what the input's own lists give.
  ASSERT_NE(ref.positions, run_in_core(cloud, params).positions);
  write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 250}, 256));
  io::write_points(path("clean.ply"), clean);
  write_container(path("clean.h5"), clean, test::tiled({.max_tile_points = 700}));
  for (const char* reference : {"clean.ply", "clean.h5"}) {
    for (const std::uint64_t budget : {std::uint64_t{64} << 20, std::uint64_t{900} << 10}) {
      SCOPED_TRACE(testing::Message() << reference << ", budget " << budget);
      OutOfCoreOptions options;
      options.neighbor_reference = path(reference);
      options.memory_budget = budget;  // 900K: blocks of 4800 points, two passes
      const OutOfCoreReport r = smooth_out_of_core(path("in.h5"), path("run.h5"), params, options);
      EXPECT_EQ(r.lambda, ref.report.lambda);
      expect_identical(path("run.h5"), ref);
      std::filesystem::remove(path("run.h5"));
    }
  }
  // A reference of another size is refused, naming it.
  write_container(path("short.h5"), test::noisy_cube(5999, 22, 0.0));
  OutOfCoreOptions options;
  options.neighbor_reference = path("short.h5");
  EXPECT_THROW(smooth_out_of_core(path("in.h5"), path("run.h5"), params, options), ParamError);
}

// Temporal blocks of h = 2 and 3 steps per load (a tile with the h-ring closure of its lists):
// the same bits, fewer position rows read per step; blocks end at rebuilds; a run stopped
// after a block resumes to the same bits; an automatic lambda of every step is refused.
TEST_F(TiledSmoothTest, TemporalBlocksGiveTheSameBits) {
  const io::PointTable cloud = test::noisy_cube(2500, 23);
  write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 250}, 256));
  set_thread_count(2);
  // A fixed lambda without rebuilds; lambda measured once and after rebuilds every 4 steps.
  for (const auto& [lambda, rebuild] : {std::pair{12.0, 0}, std::pair{0.0, 4}}) {
    {
      SCOPED_TRACE(testing::Message() << "lambda " << lambda << ", rebuild every " << rebuild);
      SmoothParams params = few_steps(7);
      params.flow.lambda = lambda;
      params.lambda_every_step = false;
      params.rebuild_interval = rebuild;
      const InCore ref = run_in_core(cloud, params);
      // One step a load, in a budget too small to hold the positions (held, a run reads them
      // once): each step loads every tile with its 2-ring closure.
      OutOfCoreOptions streamed;
      streamed.memory_budget = std::uint64_t{800} << 10;
      const OutOfCoreReport one = smooth_out_of_core(path("in.h5"), path("one.h5"), params, streamed);
      EXPECT_FALSE(one.positions_held) << "not the case this test is for";
      expect_identical(path("one.h5"), ref);
      for (const int h : {2, 3}) {
        SCOPED_TRACE(testing::Message() << "h = " << h);
        OutOfCoreOptions options;
        options.temporal_block = h;
        const OutOfCoreReport r = smooth_out_of_core(path("in.h5"), path("run.h5"), params, options);
        EXPECT_EQ(r.steps, 7);
        EXPECT_EQ(r.lambda, ref.report.lambda);
        EXPECT_EQ(r.degenerate, ref.report.degenerate);
        expect_identical(path("run.h5"), ref);
        if (rebuild == 0) {
          // Full blocks read fewer positions than single steps. (A shorter last block, as the
          // one step after 3 + 3, reads the rings of the scratch's whole closure: one read,
          // cheaper than building a shallower closure from the run file's lists.)
          SmoothParams six = params;
          six.steps = 6;
          const OutOfCoreReport single = smooth_out_of_core(path("in.h5"), path("six1.h5"), six, streamed);
          const OutOfCoreReport blocked = smooth_out_of_core(path("in.h5"), path("six.h5"), six, options);
          EXPECT_LT(blocked.position_rows_read, single.position_rows_read);
          std::filesystem::remove(path("six1.h5"));
          std::filesystem::remove(path("six.h5"));
        }
        // The blocks' lists and rings' positions from their scratch files (the ring scratch
        // is read from the second block of a depth on).
        EXPECT_TRUE(r.halo_scratch);
        EXPECT_FALSE(r.neighbors_cached) << "blocks read their lists from the scratch, not the cache";
        std::filesystem::remove(path("run.h5"));
        // Stopped after the first block, resumed (with the other block length).
        expect_stopped_and_resumed_identical(params, options, 5 - h, ref);
        // Without the scratch: every block built from the run file's lists, the same bits.
        options.halo_scratch = false;
        const OutOfCoreReport plain = smooth_out_of_core(path("in.h5"), path("run.h5"), params, options);
        EXPECT_FALSE(plain.halo_scratch);
        expect_identical(path("run.h5"), ref);
        std::filesystem::remove(path("run.h5"));
      }
      std::filesystem::remove(path("one.h5"));
    }
  }
  OutOfCoreOptions options;
  options.temporal_block = 2;
  EXPECT_THROW(smooth_out_of_core(path("in.h5"), path("x.h5"), few_steps(2), options), ParamError);
}

TEST_F(TiledSmoothTest, ZeroStepsAndTinyClouds) {
  for (const std::size_t n : {0u, 1u, 2u, 5u, 40u}) {
    SCOPED_TRACE(n);
    const io::PointTable cloud = test::noisy_cube(n, 14);
    for (const int steps : {0, 2}) {
      const SmoothParams params = few_steps(steps);
      const InCore ref = run_in_core(cloud, params);
      write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 3}));
      const OutOfCoreReport r = smooth_out_of_core(path("in.h5"), path("run.h5"), params);
      EXPECT_EQ(r.lambda, ref.report.lambda);
      expect_identical(path("run.h5"), ref);
      std::filesystem::remove(path("run.h5"));
    }
  }
}

TEST_F(TiledSmoothTest, ResumesToTheSameBits) {
  const io::PointTable cloud = test::noisy_cube(4000, 15);
  const SmoothParams params = few_steps(5);
  const InCore ref = run_in_core(cloud, params);
  write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 500}));
  const auto run = path("run.h5");
  OutOfCoreOptions stop;
  stop.stop_after_steps = 2;
  const OutOfCoreReport first = smooth_out_of_core(path("in.h5"), run, params, stop);
  EXPECT_FALSE(first.finished);
  EXPECT_EQ(first.steps, 2);
  // An interrupted run never looks finished: no output, and the partial file says so.
  EXPECT_FALSE(std::filesystem::exists(run));
  ASSERT_TRUE(std::filesystem::exists(partial_name(run)));
  EXPECT_FALSE(has_finished_run(h5::File::open(partial_name(run), false)));
  EXPECT_THROW(read_container(partial_name(run)), io::IoError);
  EXPECT_EQ(read_container(partial_name(run), {.original_order = true, .result_positions = false}).positions,
            cloud.positions);
  // Without --resume the partial run is not thrown away silently.
  EXPECT_THROW(smooth_out_of_core(path("in.h5"), run, params), io::IoError);
  // Other parameters cannot continue it.
  OutOfCoreOptions resume;
  resume.resume = true;
  SmoothParams other = params;
  other.flow.tau = 0.25;
  EXPECT_THROW(smooth_out_of_core(path("in.h5"), run, other, resume), ParamError);
  resume.stop_after_steps = 1;
  const OutOfCoreReport second = smooth_out_of_core(path("in.h5"), run, params, resume);
  EXPECT_EQ(second.resumed_from, 2);
  EXPECT_EQ(second.steps, 3);
  resume.stop_after_steps = -1;
  const OutOfCoreReport third = smooth_out_of_core(path("in.h5"), run, params, resume);
  EXPECT_EQ(third.resumed_from, 3);
  EXPECT_TRUE(third.finished);
  EXPECT_FALSE(std::filesystem::exists(partial_name(run)));
  expect_identical(run, ref);
  EXPECT_EQ(third.lambda, ref.report.lambda);
}

// With the default automatic stop, the out-of-core run stops at the same step as smooth(),
// also when it is interrupted and resumed on either side of that step.
TEST_F(TiledSmoothTest, AutomaticStopMatchesInCore) {
  const io::PointTable cloud = test::noisy_cube(4000, 21);
  SmoothParams params;  // defaults: stop when lambda falls to stop_lambda_ratio of the input's
  params.steps = 60;
  const InCore ref = run_in_core(cloud, params);
  ASSERT_TRUE(ref.report.stopped_early);
  ASSERT_GT(ref.report.steps, 2);
  write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 700}));
  const OutOfCoreReport whole = smooth_out_of_core(path("in.h5"), path("run.h5"), params);
  EXPECT_TRUE(whole.finished);
  EXPECT_EQ(whole.steps, ref.report.steps);
  EXPECT_EQ(whole.lambda, ref.report.lambda);
  expect_identical(path("run.h5"), ref);
  // Interrupted two steps before the stop, then resumed.
  OutOfCoreOptions stop;
  stop.stop_after_steps = ref.report.steps - 2;
  EXPECT_FALSE(smooth_out_of_core(path("in.h5"), path("resumed.h5"), params, stop).finished);
  expect_resumes_to(params, ref);
}

// --shrink-compensation: with the positions held in memory, a step is two passes over the
// tiles (plain updates, then the compensation from them and their halos); otherwise each tile
// is loaded with the 2-ring closure of its lists (the plain updates of its halo need the
// halo's neighbours). The same bits as smooth() for any tiling,
// lambda policy, pipeline depth and budget, with temporal blocks (2 h rings) and rebuilds, and
// after a stop and --resume (also with another block length).
TEST_F(TiledSmoothTest, ShrinkCompensationLikeInCore) {
  const io::PointTable cloud = test::noisy_cube(3000, 24);
  struct Compensated {
    const char* name;
    TilingParams tiling;
    double beta, lambda;
    bool every_step;
    int rebuild;
  };
  const Compensated cases[] = {
      {"kd 400, lambda every step", {.max_tile_points = 400}, 1.0, 0.0, true, 0},
      {"kd 7, beta 0.5", {.max_tile_points = 7}, 0.5, 0.0, true, 0},
      {"grid with empty tiles, lambda once, rebuilds", {.cell_size = 0.3}, 1.0, 0.0, false, 2},
      {"kd 300, fixed lambda, rebuild every step", {.max_tile_points = 300}, 1.0, 12.0, true, 1},
  };
  set_thread_count(2);
  for (const Compensated& c : cases) {
    SCOPED_TRACE(c.name);
    SmoothParams params = few_steps(4);
    params.stop_lambda_ratio = 0.0;
    params.shrink_compensation = c.beta;
    params.flow.lambda = c.lambda;
    params.lambda_every_step = c.every_step;
    params.rebuild_interval = c.rebuild;
    const InCore ref = run_in_core(cloud, params);
    SmoothParams plain = params;
    plain.shrink_compensation = 0.0;
    ASSERT_NE(ref.positions, run_in_core(cloud, plain).positions) << "the compensation changes nothing here";
    write_container(path("in.h5"), cloud, test::tiled(c.tiling, 256));
    const OutOfCoreReport r = smooth_out_of_core(path("in.h5"), path("run.h5"), params);
    EXPECT_TRUE(r.finished);
    // Lists and positions fit the default budget: each step is two passes over the tiles
    // held in memory.
    EXPECT_TRUE(r.positions_held) << "not the case this test is for";
    EXPECT_EQ(r.steps, 4);
    EXPECT_EQ(r.lambda, ref.report.lambda);
    EXPECT_EQ(r.degenerate, ref.report.degenerate);
    EXPECT_EQ(r.rebuilds, ref.report.rebuilds);
    expect_identical(path("run.h5"), ref);
    std::filesystem::remove(path("run.h5"));
    // Stopped after a step, then resumed.
    OutOfCoreOptions first;
    first.stop_after_steps = 3;
    EXPECT_FALSE(smooth_out_of_core(path("in.h5"), path("run.h5"), params, first).finished);
    OutOfCoreOptions resume;
    resume.resume = true;
    EXPECT_TRUE(smooth_out_of_core(path("in.h5"), path("run.h5"), params, resume).finished);
    expect_identical(path("run.h5"), ref);
    std::filesystem::remove(path("run.h5"));
  }
  // Tiny tiles, several in flight, the budget tight or not; temporal blocks of 2 and 3 steps
  // (4 and 6 rings) with a lambda measured once.
  SmoothParams params = few_steps(5);
  params.shrink_compensation = 1.0;
  params.lambda_every_step = false;
  const InCore ref = run_in_core(cloud, params);
  write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 40}, 64));
  for (const std::uint64_t budget : {std::uint64_t{64} << 20, std::uint64_t{1} << 20}) {
    for (const int h : {1, 2, 3}) {
      SCOPED_TRACE(testing::Message() << "budget " << budget << ", h = " << h);
      OutOfCoreOptions options;
      options.memory_budget = budget;
      options.tiles_in_flight = 3;
      options.temporal_block = h;
      const OutOfCoreReport r = smooth_out_of_core(path("in.h5"), path("run.h5"), params, options);
      EXPECT_EQ(r.steps, 5);
      // Held when single steps fit (two passes), else blocks of 2 h rings.
      EXPECT_EQ(r.positions_held, h == 1 && budget > (1u << 20)) << "not the case this test is for";
      EXPECT_LE(r.peak_accounted_bytes, budget);
      EXPECT_EQ(r.lambda, ref.report.lambda);
      expect_identical(path("run.h5"), ref);
      std::filesystem::remove(path("run.h5"));
      expect_stopped_and_resumed_identical(params, options, 4 - h, ref);
    }
  }
  // A resume with another beta (or none) is refused.
  OutOfCoreOptions stop;
  stop.stop_after_steps = 1;
  EXPECT_FALSE(smooth_out_of_core(path("in.h5"), path("run.h5"), params, stop).finished);
  OutOfCoreOptions resume;
  resume.resume = true;
  for (const double beta : {0.0, 0.5}) {
    SmoothParams other = params;
    other.shrink_compensation = beta;
    EXPECT_THROW(smooth_out_of_core(path("in.h5"), path("run.h5"), other, resume), ParamError) << beta;
  }
}

// --stop-plateau: the out-of-core run stops at the step smooth() stops at, also when it is
// stopped before the stop (with fewer than the 8 steps of history the plateau needs, and
// after) and resumed: the lambdas of the earlier steps come from the step log. A resume with
// another plateau is refused.
TEST_F(TiledSmoothTest, PlateauStopMatchesInCore) {
  const io::PointTable cloud = test::noisy_cube(4000, 25);
  SmoothParams params;
  params.finish.reset();  // the flow alone
  params.steps = 60;
  params.stop_lambda_ratio = 0.0;
  params.stop_plateau = kPlateau;
  params.shrink_compensation = 1.0;
  const InCore ref = run_in_core(cloud, params);
  ASSERT_TRUE(ref.report.stopped_early);
  ASSERT_GT(ref.report.steps, 10);
  ASSERT_LT(ref.report.steps, params.steps);
  write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 700}));
  const OutOfCoreReport whole = smooth_out_of_core(path("in.h5"), path("run.h5"), params);
  EXPECT_TRUE(whole.finished);
  EXPECT_EQ(whole.steps, ref.report.steps);
  EXPECT_EQ(whole.lambda, ref.report.lambda);
  expect_identical(path("run.h5"), ref);
  for (const int before : {ref.report.steps - 5, 3, ref.report.steps - 1}) {
    SCOPED_TRACE(testing::Message() << "stopped after " << before << " steps");
    OutOfCoreOptions stop;
    stop.stop_after_steps = before;
    EXPECT_FALSE(smooth_out_of_core(path("in.h5"), path("resumed.h5"), params, stop).finished);
    OutOfCoreOptions resume;
    resume.resume = true;
    SmoothParams other = params;
    other.stop_plateau = 0.0;
    EXPECT_THROW(smooth_out_of_core(path("in.h5"), path("resumed.h5"), other, resume), ParamError);
    other.stop_plateau = kPlateau / 2;
    EXPECT_THROW(smooth_out_of_core(path("in.h5"), path("resumed.h5"), other, resume), ParamError);
    const OutOfCoreReport resumed = smooth_out_of_core(path("in.h5"), path("resumed.h5"), params, resume);
    EXPECT_TRUE(resumed.finished);
    EXPECT_EQ(resumed.resumed_from, before);
    EXPECT_EQ(resumed.steps, ref.report.steps);
    EXPECT_EQ(resumed.lambda, ref.report.lambda);
    expect_identical(path("resumed.h5"), ref);
    std::filesystem::remove(path("resumed.h5"));
  }
}

TEST_F(TiledSmoothTest, MemoryAccountingStaysInTheBudget) {
  const io::PointTable cloud = test::noisy_cube(20000, 16);
  write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 2000}));
  OutOfCoreOptions options;
  options.memory_budget = 8u << 20;  // the neighbour lists (1.3 MiB) fit: they are cached
  const OutOfCoreReport cached = smooth_out_of_core(path("in.h5"), path("a.h5"), few_steps(1), options);
  EXPECT_TRUE(cached.neighbors_cached);
  EXPECT_LE(cached.peak_accounted_bytes, options.memory_budget);
  options.memory_budget = 2u << 20;  // too small to cache them: lists are re-read every step
  const OutOfCoreReport streamed = smooth_out_of_core(path("in.h5"), path("b.h5"), few_steps(1), options);
  EXPECT_FALSE(streamed.neighbors_cached);
  EXPECT_LE(streamed.peak_accounted_bytes, options.memory_budget);
  EXPECT_GT(streamed.peak_accounted_bytes, 0u);
  const io::PointTable a = read_container(path("a.h5")), b = read_container(path("b.h5"));
  EXPECT_EQ(a.positions, b.positions);
  options.memory_budget = 64u << 10;  // smaller than one tile
  try {
    smooth_out_of_core(path("in.h5"), path("c.h5"), few_steps(1), options);
    ADD_FAILURE() << "a budget smaller than a tile was taken";
  } catch (const BudgetError& e) {
    EXPECT_EQ(e.budget, options.memory_budget);
    EXPECT_GT(e.needed, e.budget);
    EXPECT_NE(std::string(e.what()).find("the memory budget of 64 KiB is too small"), std::string::npos) << e.what();
  }
}

TEST_F(TiledSmoothTest, RefusesWhatItCannotDoExactly) {
  const io::PointTable cloud = test::noisy_cube(100, 17);
  write_container(path("in.h5"), cloud);
  EXPECT_THROW(smooth_out_of_core(path("in.h5"), path("in.h5"), few_steps()), io::IoError);
  // The input is never modified.
  const auto before = std::filesystem::last_write_time(path("in.h5"));
  smooth_out_of_core(path("in.h5"), path("run.h5"), few_steps(1));
  EXPECT_EQ(std::filesystem::last_write_time(path("in.h5")), before);
}

}  // namespace

namespace {

class TiledHaloTest : public test::TempDirTest {};

// The recorded halo of each tile (what the MPI ranks balance by) is the number of distinct
// neighbours outside the tile, and the report sums it.
TEST_F(TiledHaloTest, HaloCountsAreTheDistinctNeighboursOutsideEachTile) {
  write_container(path("in.h5"), test::noisy_cube(6000, 41), test::tiled({.max_tile_points = 800}));
  const OutOfCoreReport report = smooth_out_of_core(path("in.h5"), path("out.h5"), few_steps(1));
  const h5::File f = h5::File::open(path("out.h5"), false);
  const TileTable tiles = read_tile_table(f);
  const auto halo = f.dataset(layout::neighbor_halo_counts).read_all<std::uint64_t>();
  const auto rows = f.dataset(layout::neighbor_rows).read_all<std::uint32_t>();
  const auto counts = f.dataset(layout::neighbor_counts).read_all<std::uint16_t>();
  ASSERT_EQ(halo.size(), tiles.size());
  ASSERT_GT(tiles.size(), 4u);
  std::uint64_t total = 0;
  for (std::size_t t = 0; t < tiles.size(); ++t) {
    std::vector<std::uint32_t> outside;
    for (std::uint64_t r = tiles.offsets[t]; r < tiles.offsets[t + 1]; ++r)
      for (std::size_t j = 0; j < counts[r]; ++j) {
        const std::uint32_t g = rows[r * 16 + j];
        if (g < tiles.offsets[t] || g >= tiles.offsets[t + 1]) outside.push_back(g);
      }
    std::sort(outside.begin(), outside.end());
    outside.erase(std::unique(outside.begin(), outside.end()), outside.end());
    EXPECT_EQ(halo[t], outside.size()) << "tile " << t;
    EXPECT_GT(halo[t], 0u) << "tile " << t;  // tiles of a closed surface touch others
    total += halo[t];
  }
  EXPECT_EQ(report.halo_points, total);
}

}  // namespace
