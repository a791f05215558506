// pointfair_mpi under mpirun (MpiRanks, mpi_ranks.hpp): the run on 2, 3 and 4 ranks is
// bit-identical to the single-process smooth_out_of_core; a failing rank ends the job with a
// message naming it, and the run resumes with another number of ranks, still bit-identical.
#include <sys/wait.h>

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <optional>
#include <sstream>

#include "pointfair/neighbors/neighborhood_size.hpp"
#include "pointfair/tiles/container.hpp"
#include "pointfair/tiles/tiled_smooth.hpp"
#include "tiles_test_util.hpp"

using namespace pointfair;
using namespace pointfair::tiles;

namespace {

constexpr int kSteps = 4;

class MpiRunTest : public test::TempDirTest {
 protected:
  void SetUp() override {
    TempDirTest::SetUp();
    write_container(path("in.h5"), test::noisy_cube(8000, 31), test::tiled({.max_tile_points = 1000}));
  }

  // The single-process run of the same parameters, into `out`.
  void run_serial(const std::string& out, bool resume = false) {
    OutOfCoreOptions options;
    options.resume = resume;
    SmoothParams params = params_;
    params.finish = finish_;
    smooth_out_of_core(path("in.h5"), path(out), params, options);
  }

  // mpirun -np `ranks` pointfair_mpi smooth in.h5 `out` ...; returns the exit code (124 or
  // 137 when it hung for a minute) and keeps stderr in `log_`.
  int run_mpi(int ranks, const std::string& out, const std::string& env = "", bool resume = false) {
    // As root, OpenMPI wants the two ALLOW variables; containers often forbid the
    // cross-memory attach of its shared-memory transport, hence single_copy_mechanism=none.
    std::ostringstream cmd;
    cmd << "env OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1 "
        << "OMPI_MCA_btl_vader_single_copy_mechanism=none "
        << env << " timeout -k 5 60 " << POINTFAIR_MPIEXEC << " --oversubscribe -np " << ranks << " " << POINTFAIR_MPI_EXE
        << " smooth " << path("in.h5") << " " << path(out) << " --steps " << params_.steps << method_
        << (finish_ ? "" : " --no-quadric-finish") << " --threads 1"
        << (resume ? " --resume" : "") << " > " << path("log.txt") << " 2>&1";
    const auto t0 = std::chrono::steady_clock::now();
    const int status = std::system(cmd.str().c_str());
    seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::ifstream in(path("log.txt"));
    std::stringstream text;
    text << in.rdbuf();
    log_ = text.str();
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }

  // The summary counts collective transfers over the ranks: some, none made independently.
  void expect_collective_writes() const {
    const std::string tail = " collective HDF5 transfers over the ranks, 0 made independently";
    const std::size_t at = log_.find(tail);
    ASSERT_NE(at, std::string::npos) << log_;
    const std::size_t start = log_.rfind("pointfair_mpi: ", at) + std::strlen("pointfair_mpi: ");
    EXPECT_GT(std::stoull(log_.substr(start, at - start)), 0u) << log_;
  }

  // Every dataset and attribute of the run, compared to the bit, but for the step buffers: a
  // single process holding its positions in memory writes the steps in the order of each
  // tile's lists and the last one back in row order, into the other buffer than ranks that
  // stream them do. Compared there: the result (the buffer /run's result_positions names) and
  // the commit record but for the buffer it names.
  void expect_same_run(const std::string& a, const std::string& b) {
    const h5::File fa = h5::File::open(path(a), false), fb = h5::File::open(path(b), false);
    const auto result = [](const h5::File& f) {
      return f.dataset(f.string_attribute("/run", "result_positions")).read_all<double>();
    };
    const std::vector<double> ra = result(fa), rb = result(fb);
    ASSERT_EQ(ra.size(), rb.size());
    EXPECT_EQ(0, std::memcmp(ra.data(), rb.data(), ra.size() * sizeof(double))) << "result positions";
    std::vector<std::int64_t> sa = fa.dataset("/run/state").read_all<std::int64_t>(),
                              sb = fb.dataset("/run/state").read_all<std::int64_t>();
    // Six slots, seven with the quadric finish (its passes).
    ASSERT_EQ(sa.size(), finish_ ? 7u : 6u);
    ASSERT_EQ(sb.size(), sa.size());
    sa[5] = sb[5] = 0;  // the step buffer
    EXPECT_EQ(sa, sb) << "/run/state";
    std::vector<std::string> datasets = {"/run/neighbors/rows",
                                         "/run/neighbors/counts",  "/run/neighbors/local", "/run/neighbors/local_order",
                                         "/run/neighbors/halo_counts", "/run/step_log", "/run/eps"};
    for (const std::string& m : fa.members("/run/attributes")) datasets.push_back("/run/attributes/" + m);
    EXPECT_EQ(fa.members("/run/attributes"), fb.members("/run/attributes"));
    for (const std::string& d : datasets) {
      const h5::Dataset da = fa.dataset(d), db = fb.dataset(d);
      ASSERT_EQ(da.type(), db.type()) << d;
      if (da.type() == h5::Type::Float64) {
        const auto va = da.read_all<double>(), vb = db.read_all<double>();
        ASSERT_EQ(va.size(), vb.size()) << d;
        EXPECT_EQ(0, std::memcmp(va.data(), vb.data(), va.size() * sizeof(double))) << d;
      } else {
        EXPECT_EQ(da.read_all<std::uint64_t>(), db.read_all<std::uint64_t>()) << d;
      }
    }
    EXPECT_EQ(fa.double_attribute("/run", "eps"), fb.double_attribute("/run", "eps"));
    EXPECT_EQ(fa.double_attribute("/run/attributes", "lambda"), fb.double_attribute("/run/attributes", "lambda"));
    EXPECT_EQ(fa.int_attribute("/run/attributes", "degenerate"), fb.int_attribute("/run/attributes", "degenerate"));
    EXPECT_EQ(read_container(path(a)).positions, read_container(path(b)).positions);
  }

  // The parameters of the runs: those of run_serial, and the same as options of run_mpi.
  SmoothParams params_ = [] {
    SmoothParams p;
    p.finish.reset();  // the flow alone
    p.steps = kSteps;
    return p;
  }();
  std::optional<QuadricProjectionParams> finish_;
  std::string method_;
  std::string log_;
  double seconds_ = 0.0;  // of the last run_mpi
};

TEST_F(MpiRunTest, TwoRanksBitIdenticalToOneProcess) {
  run_serial("ref.h5");
  ASSERT_EQ(run_mpi(2, "out.h5"), 0) << log_;
  EXPECT_NE(log_.find("on 2 ranks"), std::string::npos) << log_;
  expect_collective_writes();
  EXPECT_FALSE(std::filesystem::exists(partial_name(path("out.h5"))));
  expect_same_run("ref.h5", "out.h5");
}

TEST_F(MpiRunTest, ThreeRanksBitIdenticalToOneProcess) {
  run_serial("ref.h5");
  ASSERT_EQ(run_mpi(3, "out.h5"), 0) << log_;
  expect_collective_writes();
  expect_same_run("ref.h5", "out.h5");
}

TEST_F(MpiRunTest, FourRanksBitIdenticalToOneProcess) {
  run_serial("ref.h5");
  ASSERT_EQ(run_mpi(4, "out.h5"), 0) << log_;
  expect_same_run("ref.h5", "out.h5");
}

TEST_F(MpiRunTest, MoreRanksThanTilesLeavesRanksIdleAndTheSameBits) {
  write_container(path("in.h5"), test::noisy_cube(8000, 31), test::tiled({.max_tile_points = 6000}));
  ASSERT_EQ(read_tile_table(h5::File::open(path("in.h5"), false)).size(), 2u);
  run_serial("ref.h5");
  ASSERT_EQ(run_mpi(3, "out.h5"), 0) << log_;
  expect_collective_writes();  // the idle rank takes part with empty selections
  expect_same_run("ref.h5", "out.h5");
}

// Fewer tiles than ranks, where the run ends by its automatic stop (or its last step) with
// the positions held in the order of the lists: the ranks without a tile used to count their
// collective writes while the rank with the tile was inside its first one, and the job never
// ended. Now it ends, on 2 and 3 ranks, with the single process's bits.
TEST_F(MpiRunTest, OneTileOnTwoAndThreeRanksEndsWithTheSingleProcessBits) {
  write_container(path("in.h5"), test::noisy_cube(3000, 37), test::tiled({.max_tile_points = 100000}));
  ASSERT_EQ(read_tile_table(h5::File::open(path("in.h5"), false)).size(), 1u);
  params_.steps = 40;  // the automatic stop ends the flow before
  run_serial("ref.h5");
  EXPECT_LT(h5::File::open(path("ref.h5"), false).dataset("/run/state").read_all<std::int64_t>()[2], 40);
  for (const int ranks : {2, 3}) {
    SCOPED_TRACE(std::to_string(ranks) + " ranks");
    const std::string out = "out" + std::to_string(ranks) + ".h5";
    ASSERT_EQ(run_mpi(ranks, out), 0) << log_;
    EXPECT_LT(seconds_, 50.0) << log_;
    expect_same_run("ref.h5", out);
  }
  // With the quadric finish too.
  finish_ = QuadricProjectionParams{};
  run_serial("ref_finish.h5");
  ASSERT_EQ(run_mpi(2, "out_finish.h5"), 0) << log_;
  expect_same_run("ref_finish.h5", "out_finish.h5");
}

TEST_F(MpiRunTest, OneRankUnderMpirunBitIdenticalToOneProcess) {
  run_serial("ref.h5");
  ASSERT_EQ(run_mpi(1, "out.h5"), 0) << log_;
  expect_same_run("ref.h5", "out.h5");
}

TEST_F(MpiRunTest, FailingRankStopsTheJobAndTheRunResumesOnOtherRankCounts) {
  run_serial("ref.h5");
  // Rank 1 of 2 fails after step 2 was committed, while rank 0 already works on step 3.
  EXPECT_NE(run_mpi(2, "out.h5", "POINTFAIR_MPI_FAIL_AT=1:2"), 0);
  EXPECT_NE(log_.find("pointfair_mpi: rank 1 of 2:"), std::string::npos) << log_;
  EXPECT_NE(log_.find("failure injected"), std::string::npos) << log_;
  EXPECT_FALSE(std::filesystem::exists(path("out.h5")));
  ASSERT_TRUE(std::filesystem::exists(partial_name(path("out.h5"))));
  {
    const h5::File partial = h5::File::open(partial_name(path("out.h5")), false);
    EXPECT_EQ(partial.dataset("/run/state").read_all<std::int64_t>()[2], 2);  // completed steps
  }
  // Without --resume the partial run is in the way.
  EXPECT_NE(run_mpi(3, "out.h5"), 0);
  EXPECT_NE(log_.find("--resume"), std::string::npos) << log_;
  // Resumed on 3 ranks.
  ASSERT_EQ(run_mpi(3, "out.h5", "", true), 0) << log_;
  EXPECT_NE(log_.find("(2 resumed)"), std::string::npos) << log_;
  expect_same_run("ref.h5", "out.h5");
}

TEST_F(MpiRunTest, RankKilledBySignalEndsTheJobAndTheRunResumesOnThreeRanks) {
  run_serial("ref.h5");
  // Rank 0 of 2 dies by SIGKILL after step 1 was committed (no message, no MPI_Abort), while
  // rank 1 is in step 2's collective writes or its commit: mpirun must end the job.
  const int code = run_mpi(2, "out.h5", "POINTFAIR_MPI_KILL_AT=0:1");
  EXPECT_NE(code, 0) << log_;
  EXPECT_LT(seconds_, 50.0) << "mpirun hung until the timeout: " << log_;
  EXPECT_NE(log_.find("signal 9"), std::string::npos) << log_;
  EXPECT_FALSE(std::filesystem::exists(path("out.h5")));
  ASSERT_TRUE(std::filesystem::exists(partial_name(path("out.h5"))));
  {
    const h5::File partial = h5::File::open(partial_name(path("out.h5")), false);
    EXPECT_EQ(partial.dataset("/run/state").read_all<std::int64_t>()[2], 1);  // rank 0 commits
  }
  ASSERT_EQ(run_mpi(3, "out.h5", "", true), 0) << log_;
  expect_same_run("ref.h5", "out.h5");
}

TEST_F(MpiRunTest, StoppedOnThreeRanksResumedByOneProcessAndViceVersa) {
  run_serial("ref.h5");
  ASSERT_EQ(run_mpi(3, "a.h5", "POINTFAIR_MPI_STOP_AFTER_STEPS=1"), 0) << log_;
  ASSERT_FALSE(std::filesystem::exists(path("a.h5")));
  run_serial("a.h5", true);
  expect_same_run("ref.h5", "a.h5");

  OutOfCoreOptions options;
  options.stop_after_steps = 3;
  EXPECT_FALSE(smooth_out_of_core(path("in.h5"), path("b.h5"), params_, options).finished);
  ASSERT_EQ(run_mpi(2, "b.h5", "", true), 0) << log_;
  expect_same_run("ref.h5", "b.h5");
}

// The compensated flow (2-ring closures of the tiles) with the plateau stop: 3 ranks give the
// single process's run to the bit, stopped at the same step; a run stopped on 2 ranks before
// the stop resumes on 3 (the lambdas so far from the step log) and one stopped by a single
// process resumes on 2, still to the bit.
TEST_F(MpiRunTest, CompensationAndPlateauStopOnRanksAndResumedOnOthers) {
  params_.steps = 40;
  params_.stop_lambda_ratio = 0.0;
  params_.stop_plateau = 0.03;
  params_.shrink_compensation = 1.0;
  // Three reweightings of the robust plane: on this small cloud the plateau then comes well
  // within the 40 steps (with one it comes later).
  params_.flow.robust.iterations = 3;
  method_ = " --stop-lambda-ratio 0 --stop-plateau 0.03 --shrink-compensation 1 --robust-iterations 3";
  run_serial("ref.h5");
  const int stopped_at = [&] {  // the steps done
    const h5::File ref = h5::File::open(path("ref.h5"), false);
    return static_cast<int>(ref.dataset("/run/state").read_all<std::int64_t>()[2]);
  }();
  ASSERT_GT(stopped_at, 9);
  ASSERT_LT(stopped_at, params_.steps) << "the plateau should stop the run";
  ASSERT_EQ(run_mpi(3, "out.h5"), 0) << log_;
  expect_collective_writes();
  expect_same_run("ref.h5", "out.h5");

  ASSERT_EQ(run_mpi(2, "a.h5", "POINTFAIR_MPI_STOP_AFTER_STEPS=" + std::to_string(stopped_at - 3)), 0) << log_;
  ASSERT_FALSE(std::filesystem::exists(path("a.h5")));
  ASSERT_EQ(run_mpi(3, "a.h5", "", true), 0) << log_;
  expect_same_run("ref.h5", "a.h5");

  OutOfCoreOptions options;
  options.stop_after_steps = 5;
  EXPECT_FALSE(smooth_out_of_core(path("in.h5"), path("b.h5"), params_, options).finished);
  ASSERT_EQ(run_mpi(2, "b.h5", "", true), 0) << log_;
  expect_same_run("ref.h5", "b.h5");
}

// Momentum: each rank reads and writes its tiles' last moves (collective writes, as many per
// rank as the rank with the most tiles): the single process's run to the bit, also resumed
// on 2 ranks after 3 steps on 3.
TEST_F(MpiRunTest, MomentumOnRanksAndResumedOnOthers) {
  params_.steps = 12;
  params_.stop_lambda_ratio = 0.0;
  params_.stop_plateau = 0.0;
  params_.momentum = 0.6;
  params_.momentum_gate = 0.0;
  method_ = " --stop-lambda-ratio 0 --stop-plateau 0 --momentum 0.6 --momentum-gate 0";
  run_serial("ref.h5");
  ASSERT_EQ(run_mpi(3, "out.h5"), 0) << log_;
  expect_collective_writes();
  expect_same_run("ref.h5", "out.h5");
  ASSERT_EQ(run_mpi(3, "a.h5", "POINTFAIR_MPI_STOP_AFTER_STEPS=3"), 0) << log_;
  ASSERT_EQ(run_mpi(2, "a.h5", "", true), 0) << log_;
  expect_same_run("ref.h5", "a.h5");
}

// The quadric finish: each rank finishes its tiles, every pass committed once all ranks
// wrote it: the single process's run to the bit; one stopped by a single process after the
// first pass resumes on 2 ranks, still to the bit.
TEST_F(MpiRunTest, QuadricFinishOnTwoRanksBitIdenticalToOneProcess) {
  QuadricProjectionParams q;
  q.k = 30;
  q.passes = 2;
  finish_ = q;
  method_ = " --quadric-finish --quadric-k 30 --quadric-passes 2";
  run_serial("ref.h5");
  ASSERT_EQ(run_mpi(2, "out.h5"), 0) << log_;
  expect_collective_writes();
  expect_same_run("ref.h5", "out.h5");

  OutOfCoreOptions options;
  options.stop_after_finish_passes = 1;
  SmoothParams params = params_;
  params.finish = q;
  EXPECT_FALSE(smooth_out_of_core(path("in.h5"), path("b.h5"), params, options).finished);
  ASSERT_EQ(run_mpi(2, "b.h5", "", true), 0) << log_;
  expect_same_run("ref.h5", "b.h5");
}

// The coarse level (--coarse-level): its stages on rank 0, its runs on every rank; the single
// process's run to the bit, and one stopped in the coarse sample's run resumes on 3 ranks.
TEST_F(MpiRunTest, CoarseLevelOnRanksBitIdenticalToOneProcess) {
  io::PointTable heavy;
  heavy.positions = sample_sphere(12000, 1.0, 41).points;
  add_noise(heavy.positions, 0.07, 42);
  std::filesystem::remove(path("in.h5"));
  write_container(path("in.h5"), heavy, test::tiled({.max_tile_points = 1500}));
  ASSERT_GE(estimate_noise(heavy.positions).ratio, 1.5);
  params_.coarse = CoarseLevelParams{.min_noise_ratio = 1.5};  // this sphere's noise: 1.58 spacings
  method_ = " --coarse-min-noise 1.5";
  run_serial("ref.h5");
  ASSERT_EQ(run_mpi(2, "out.h5"), 0) << log_;
  expect_same_run("ref.h5", "out.h5");
  EXPECT_FALSE(std::filesystem::exists(path("out.h5.partial.coarse"))) << "the work folder is left behind";

  OutOfCoreOptions options;
  options.stop_after_steps = 2;
  EXPECT_FALSE(smooth_out_of_core(path("in.h5"), path("b.h5"), params_, options).finished);
  ASSERT_TRUE(std::filesystem::is_directory(path("b.h5.partial.coarse")));
  ASSERT_EQ(run_mpi(3, "b.h5", "", true), 0) << log_;
  expect_same_run("ref.h5", "b.h5");
}

TEST_F(MpiRunTest, MissingInputEndsEveryRankWithTheFileNamed) {
  std::filesystem::remove(path("in.h5"));
  const int code = run_mpi(2, "out.h5");
  EXPECT_NE(code, 0);
  EXPECT_NE(log_.find("in.h5: cannot open"), std::string::npos) << log_;
  // The first rank to fail aborts the job, which may end the other before it prints: one
  // rank's message, naming its rank, is what is certain.
  EXPECT_TRUE(log_.find("rank 0 of 2: ") != std::string::npos || log_.find("rank 1 of 2: ") != std::string::npos)
      << log_;
  EXPECT_FALSE(std::filesystem::exists(path("out.h5")));
}

}  // namespace
