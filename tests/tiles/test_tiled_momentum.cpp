// Momentum out of core (SmoothParams::momentum): every step strategy (positions held, tiles
// streamed with their halos, blocks of one step, compensated blocks) gives smooth()'s bits,
// whole and stopped and resumed another way; the restarts and the gate follow smooth()'s
// rules from the lambdas the run measures and logs.
#include <gtest/gtest.h>

#include <filesystem>
#include <vector>

#include "pointfair/common/parallel.hpp"
#include "pointfair/common/params_error.hpp"
#include "pointfair/tiles/container.hpp"
#include "pointfair/tiles/tiled_smooth.hpp"
#include "tiles_test_util.hpp"

using namespace pointfair;
using namespace pointfair::tiles;

namespace {

using test::expect_identical;
using test::InCore;
using test::run_in_core;

using TiledMomentumTest = test::ThreadsTempDirTest;

struct Strategy {
  const char* name;
  double beta;             // SmoothParams::shrink_compensation
  std::uint64_t budget;    // OutOfCoreOptions::memory_budget
  bool step_blocks;        // OutOfCoreOptions::step_blocks
  int temporal_block;      // asked for; momentum runs one step a block
  bool held;               // what the run is expected to do
  std::uint64_t resumed_budget;  // the budget of the resumed call (another strategy)
};

constexpr std::uint64_t kLarge = std::uint64_t{64} << 20, kSmall = std::uint64_t{600} << 10;

TEST_F(TiledMomentumTest, EveryStrategyGivesTheInCoreBits) {
  const io::PointTable cloud = test::noisy_cube(3000, 31, 0.02);
  write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 60}, 64));
  const Strategy strategies[] = {
      {"held, compensated", 1.0, kLarge, false, 1, true, kSmall},
      {"held, plain", 0.0, kLarge, false, 1, true, kSmall},
      {"streamed with the halo scratch, plain", 0.0, kSmall, false, 1, false, kLarge},
      {"blocks of one step, plain", 0.0, kSmall, true, 1, false, kLarge},
      {"compensated blocks, temporal blocks asked for", 1.0, kSmall, false, 3, false, kLarge},
  };
  set_thread_count(2);
  for (const Strategy& s : strategies) {
    SCOPED_TRACE(s.name);
    SmoothParams params = test::few_steps(6);
    params.stop_lambda_ratio = 0.0;
    params.stop_plateau = 0.0;
    params.shrink_compensation = s.beta;
    params.lambda_every_step = s.temporal_block == 1;
    params.rebuild_interval = 4;  // none on the rebuild's step, as in smooth()
    params.momentum = 0.6;
    params.momentum_gate = 0.0;  // the gate: GatedRunsAndRestartsFollowSmooth
    const InCore ref = run_in_core(cloud, params);
    SmoothParams plain = params;
    plain.momentum = 0.0;
    ASSERT_NE(ref.positions, run_in_core(cloud, plain).positions) << "the momentum changes nothing here";
    OutOfCoreOptions options;
    options.memory_budget = s.budget;
    options.step_blocks = s.step_blocks;
    options.temporal_block = s.temporal_block;
    const OutOfCoreReport r = smooth_out_of_core(path("in.h5"), path("run.h5"), params, options);
    EXPECT_TRUE(r.finished);
    EXPECT_EQ(r.positions_held, s.held) << "not the case this test is for";
    EXPECT_EQ(r.step_blocks, s.step_blocks) << "not the case this test is for";
    EXPECT_EQ(r.rebuilds, 1);
    EXPECT_LE(r.peak_accounted_bytes, s.budget);
    EXPECT_EQ(r.lambda, ref.report.lambda);
    expect_identical(path("run.h5"), ref);
    std::filesystem::remove(path("run.h5"));
    // Stopped after each of the first steps (the moves of step 1 are the first read), then
    // resumed under the other budget: the other strategy reads the moves this one wrote.
    for (const int stop : {1, 2, 5}) {
      SCOPED_TRACE(testing::Message() << "stopped after " << stop << " steps");
      OutOfCoreOptions first = options;
      first.stop_after_steps = stop;
      EXPECT_FALSE(smooth_out_of_core(path("in.h5"), path("run.h5"), params, first).finished);
      OutOfCoreOptions resume;
      resume.resume = true;
      resume.memory_budget = s.resumed_budget;
      const OutOfCoreReport resumed = smooth_out_of_core(path("in.h5"), path("run.h5"), params, resume);
      EXPECT_TRUE(resumed.finished);
      EXPECT_EQ(resumed.resumed_from, stop);
      expect_identical(path("run.h5"), ref);
      std::filesystem::remove(path("run.h5"));
    }
  }
}

// The automatic lambda of every step with the automatic stop: the steps where the gauge rose
// have no momentum (restarts), the stop comes where smooth()'s does, also when resumed after
// the first restart (the lambdas before it from the step log). With the gate, a run whose
// first step took the noise fast has none: the bits of the run without momentum.
TEST_F(TiledMomentumTest, GatedRunsAndRestartsFollowSmooth) {
  const io::PointTable cloud = test::noisy_cube(3000, 32, 0.03);
  write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 300}, 64));
  SmoothParams params = test::few_steps(40);
  params.momentum = 0.8;
  params.momentum_gate = 0.0;
  const InCore ref = run_in_core(cloud, params);
  ASSERT_GT(ref.report.momentum_restarts, 0) << "not the case this test is for";
  for (const std::uint64_t budget : {kLarge, kSmall}) {
    SCOPED_TRACE(testing::Message() << "budget " << budget);
    OutOfCoreOptions options;
    options.memory_budget = budget;
    const OutOfCoreReport r = smooth_out_of_core(path("in.h5"), path("run.h5"), params, options);
    EXPECT_EQ(r.steps, ref.report.steps);
    EXPECT_EQ(r.momentum_restarts, ref.report.momentum_restarts);
    EXPECT_EQ(r.stop_reason, ref.report.stop_reason);
    expect_identical(path("run.h5"), ref);
    std::filesystem::remove(path("run.h5"));
  }
  // Resumed after every step up to the stop: the same steps and bits, and the restarts of the
  // two calls add up to smooth()'s.
  for (int stop = 1; stop < ref.report.steps; stop += 3) {
    SCOPED_TRACE(testing::Message() << "stopped after " << stop << " steps");
    OutOfCoreOptions first;
    first.stop_after_steps = stop;
    const OutOfCoreReport before = smooth_out_of_core(path("in.h5"), path("run.h5"), params, first);
    OutOfCoreOptions resume;
    resume.resume = true;
    const OutOfCoreReport after = smooth_out_of_core(path("in.h5"), path("run.h5"), params, resume);
    EXPECT_EQ(after.steps, ref.report.steps);
    EXPECT_EQ(before.momentum_restarts + after.momentum_restarts, ref.report.momentum_restarts);
    expect_identical(path("run.h5"), ref);
    std::filesystem::remove(path("run.h5"));
  }
  // Light noise loses much of its gauge in the first step: the gate (at 1, whatever the
  // cloud) leaves the run without momentum, out of core too.
  SmoothParams gated = params;
  gated.momentum_gate = 1.0;
  SmoothParams none = params;
  none.momentum = 0.0;
  const InCore without = run_in_core(cloud, none);
  ASSERT_EQ(run_in_core(cloud, gated).positions, without.positions) << "not the case this test is for";
  smooth_out_of_core(path("in.h5"), path("run.h5"), gated);
  expect_identical(path("run.h5"), without);
  std::filesystem::remove(path("run.h5"));
  // A resume with another momentum or gate (or none) is refused: the steps done had theirs.
  OutOfCoreOptions stop;
  stop.stop_after_steps = 2;
  EXPECT_FALSE(smooth_out_of_core(path("in.h5"), path("run.h5"), params, stop).finished);
  OutOfCoreOptions resume;
  resume.resume = true;
  SmoothParams other_m = params, other_gate = params, none_at_all = params;
  other_m.momentum = 0.5;
  other_gate.momentum_gate = 0.5;
  none_at_all.momentum = 0.0;
  for (const SmoothParams& other : {other_m, other_gate, none_at_all})
    EXPECT_THROW(smooth_out_of_core(path("in.h5"), path("run.h5"), other, resume), ParamError);
  EXPECT_TRUE(smooth_out_of_core(path("in.h5"), path("run.h5"), params, resume).finished);
  expect_identical(path("run.h5"), ref);
}

}  // namespace
