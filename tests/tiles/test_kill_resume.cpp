// A run of the command-line tool killed with SIGKILL at several moments and started again
// with --resume ends bit-identical to an uninterrupted run.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <thread>

#include "pointfair/tiles/container.hpp"
#include "pointfair/tiles/tiled_smooth.hpp"
#include "tiles_test_util.hpp"

using namespace pointfair;
using namespace pointfair::tiles;

namespace {

class KillResumeTest : public test::TempDirTest {
 protected:
  // Starts `pointfair smooth IN OUT ...`; returns the child's pid.
  pid_t start(const std::vector<std::string>& args) {
    const pid_t pid = fork();
    if (pid == 0) {
      std::vector<char*> argv;
      static std::string exe = POINTFAIR_EXE;
      argv.push_back(exe.data());
      std::vector<std::string> copy = args;
      for (auto& a : copy) argv.push_back(a.data());
      argv.push_back(nullptr);
      freopen("/dev/null", "w", stdout);
      freopen("/dev/null", "w", stderr);
      execv(exe.c_str(), argv.data());
      _exit(127);
    }
    return pid;
  }
  // Waits for the child; returns its exit code, or -signal if a signal ended it.
  static int wait_for(pid_t pid) {
    int status = 0;
    waitpid(pid, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
  }

  // Runs `pointfair smooth in.h5 ref.h5 <options>` once, then the same into out.h5 killed
  // with SIGKILL at growing moments (setup, neighbourhoods, steps, commits, attributes) and
  // resumed each time until it finishes; out.h5 must equal ref.h5 to the bit.
  void kill_and_resume(const std::vector<std::string>& options) {
    auto args = [&](const std::string& out, bool resume) {
      std::vector<std::string> a{"smooth", path("in.h5").string(), path(out).string()};
      a.insert(a.end(), options.begin(), options.end());
      if (resume) a.push_back("--resume");
      return a;
    };
    const auto t0 = std::chrono::steady_clock::now();
    ASSERT_EQ(wait_for(start(args("ref.h5", false))), 0);
    const double full = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

    int kills = 0;
    for (const double fraction : {0.03, 0.1, 0.2, 0.35, 0.5, 0.7, 0.9}) {
      const pid_t pid = start(args("out.h5", true));
      std::this_thread::sleep_for(std::chrono::duration<double>(fraction * full));
      kill(pid, SIGKILL);
      kills += wait_for(pid) == -SIGKILL;
      if (std::filesystem::exists(path("out.h5"))) break;  // it finished before the kill
      // Whatever is on disk now never looks like a finished run.
      EXPECT_FALSE(std::filesystem::exists(path("out.h5")));
    }
    EXPECT_GT(kills, 0);
    if (!std::filesystem::exists(path("out.h5"))) {
      ASSERT_EQ(wait_for(start(args("out.h5", true))), 0);
    }
    ASSERT_TRUE(std::filesystem::exists(path("out.h5")));
    EXPECT_FALSE(std::filesystem::exists(partial_name(path("out.h5"))));

    const io::PointTable ref = read_container(path("ref.h5")), out = read_container(path("out.h5"));
    EXPECT_EQ(ref.positions, out.positions);
    const PointAttributes ra = read_run_attributes(path("ref.h5")), oa = read_run_attributes(path("out.h5"));
    EXPECT_EQ(ra.k1, oa.k1);
    EXPECT_EQ(ra.laplacian_norm, oa.laplacian_norm);
    EXPECT_EQ(ra.normal, oa.normal);
  }
};

TEST_F(KillResumeTest, SigkillAtSeveralMomentsThenResumeIsBitIdentical) {
  write_container(path("in.h5"), test::noisy_cube(20000, 21), test::tiled({.max_tile_points = 2500}));
  kill_and_resume({"--steps", "12", "--threads", "2", "--quiet"});
}

// The plain flow holds the positions in memory and writes the steps in the order of each
// tile's lists, back into row order at the end: killed in either, the same bits.
TEST_F(KillResumeTest, StepsWrittenInListOrderKilledAndResumedAreBitIdentical) {
  write_container(path("in.h5"), test::noisy_cube(20000, 23), test::tiled({.max_tile_points = 2500}));
  kill_and_resume({"--steps", "20", "--shrink-compensation", "0", "--stop-lambda-ratio", "0", "--stop-plateau", "0",
                   "--threads", "2", "--quiet"});
}

// Streamed plain steps (a budget that keeps neither the lists nor the positions) run as
// blocks of one step, which write each tile in the order of its lists: killed in them, the
// same bits.
TEST_F(KillResumeTest, StreamedStepsAsBlocksKilledAndResumedAreBitIdentical) {
  write_container(path("in.h5"), test::noisy_cube(20000, 25), test::tiled({.max_tile_points = 2500}));
  {  // the case this test is for
    SmoothParams params;
    params.finish.reset();  // the flow alone
    params.steps = 2;
    params.shrink_compensation = 0.0;
    params.lambda_every_step = false;
    OutOfCoreOptions options;
    options.memory_budget = std::uint64_t{3} << 20;
    const OutOfCoreReport r = smooth_out_of_core(path("in.h5"), path("probe.h5"), params, options);
    ASSERT_TRUE(r.step_blocks && !r.positions_held && !r.neighbors_cached);
  }
  kill_and_resume({"--steps", "20", "--shrink-compensation", "0", "--stop-lambda-ratio", "0", "--stop-plateau", "0",
                   "--lambda-schedule", "once", "--no-quadric-finish", "--memory-budget", "3M", "--threads", "2",
                   "--quiet"});
}

// The quadric finish after the steps, two passes committed like steps: killed in the steps,
// in either pass or in the attributes, the same bits.
TEST_F(KillResumeTest, QuadricFinishKilledAndResumedIsBitIdentical) {
  write_container(path("in.h5"), test::noisy_cube(8000, 24), test::tiled({.max_tile_points = 1500}));
  kill_and_resume({"--steps", "4", "--quadric-finish", "--quadric-k", "40", "--quadric-passes", "2", "--threads",
                   "2", "--quiet"});
}

// The same with the shrinkage compensation and the plateau stop, which the command line
// passes to the out-of-core run: its result is smooth()'s, stopped at the same step.
TEST_F(KillResumeTest, CompensatedRunWithPlateauStopKilledAndResumedIsBitIdentical) {
  const io::PointTable cloud = test::noisy_cube(12000, 22);
  write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 2000}));
  kill_and_resume({"--steps", "40", "--shrink-compensation", "1", "--stop-plateau", "0.1", "--stop-lambda-ratio",
                   "0", "--no-quadric-finish", "--threads", "2", "--quiet"});
  SmoothParams params = test::few_steps(40);  // the flow alone
  params.shrink_compensation = 1.0;
  params.stop_plateau = 0.1;
  params.stop_lambda_ratio = 0.0;
  const test::InCore in_core = test::run_in_core(cloud, params);
  ASSERT_TRUE(in_core.report.stopped_early);
  ASSERT_GT(in_core.report.steps, 8);
  test::expect_identical(path("ref.h5"), in_core);
}

// Momentum with compensated steps streamed as blocks (a budget that holds neither lists nor
// positions): killed between a step's moves and its commit, or in either, the step is done
// again from the moves it read; the result is smooth()'s.
TEST_F(KillResumeTest, MomentumKilledAndResumedIsBitIdentical) {
  const io::PointTable cloud = test::noisy_cube(12000, 26);
  write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 2000}));
  kill_and_resume({"--steps", "16", "--momentum", "0.6", "--momentum-gate", "0", "--stop-lambda-ratio", "0",
                   "--stop-plateau", "0", "--no-quadric-finish", "--memory-budget", "3M", "--threads", "2", "--quiet"});
  SmoothParams params = test::few_steps(16);  // the flow alone
  params.momentum = 0.6;
  params.momentum_gate = 0.0;
  params.stop_lambda_ratio = 0.0;
  params.stop_plateau = 0.0;
  test::expect_identical(path("ref.h5"), test::run_in_core(cloud, params));
}

// The coarse level: killed in its stages (the sample, its own run, the moves) or in the run
// after it, resumed from what its work folder holds: smooth()'s bits, and no folder left.
TEST_F(KillResumeTest, CoarseLevelKilledAndResumedIsBitIdentical) {
  io::PointTable cloud;
  cloud.positions = sample_sphere(12000, 1.0, 41).points;
  add_noise(cloud.positions, 0.07, 42);  // 1.58 sample spacings
  write_container(path("in.h5"), cloud, test::tiled({.max_tile_points = 1500}));
  kill_and_resume({"--coarse-min-noise", "1.5", "--threads", "2", "--quiet"});
  // A kill after the output was renamed into place and before the folder went leaves the
  // folder: a resume (every stage done, no partial run) makes the output again and removes it.
  if (std::filesystem::exists(coarse_folder_name(path("out.h5")))) {
    ASSERT_EQ(wait_for(start({"smooth", path("in.h5").string(), path("out.h5").string(), "--coarse-min-noise", "1.5",
                              "--threads", "2", "--quiet", "--resume"})),
              0);
  }
  EXPECT_FALSE(std::filesystem::exists(coarse_folder_name(path("out.h5"))));
  SmoothParams params;
  params.coarse->min_noise_ratio = 1.5;
  const test::InCore ref = test::run_in_core(cloud, params);
  ASSERT_FALSE(ref.report.coarse_levels.empty());
  test::expect_identical(path("out.h5"), ref);
}

}  // namespace
