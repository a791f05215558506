// The pointfair executable in a hostile environment: an unwritable output, an output that is
// the input under another name, a full disk (a file-size limit), SIGINT/SIGTERM in the middle
// of a run. Always: a clear one-line message, a non-zero exit code, the input untouched, and
// no output that looks complete when it is not.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "cli_child.hpp"
#include "pointfair/io/point_file.hpp"
#include "pointfair/shapes/shapes.hpp"

namespace fs = std::filesystem;
using namespace pointfair;
using namespace pointfair::testing_cli;

namespace {

class HostileEnvironment : public testing_cli::CliTest {};

}  // namespace

TEST_F(HostileEnvironment, UnwritableOutputPathsFailCleanly) {
  const fs::path in = write_cloud("in.ply", 500);
  const std::string before = slurp(in);
  std::ofstream(dir_ / "plain_file") << "x";
  const std::vector<fs::path> outputs = {
      dir_ / "plain_file" / "out.ply",  // a path through a regular file
      dir_ / "missing" / "out.ply",     // a folder that does not exist
      dir_,                             // a folder
      "/proc/pointfair_out.ply",        // a file system that takes no new files
  };
  for (const std::string command : {"smooth", "curvature"}) {
    for (const fs::path& out : outputs) {
      SCOPED_TRACE(command + " " + out.string());
      const Result r = run({command, in.string(), out.string(), "--steps", "1", "--quiet"});
      EXPECT_EQ(r.exit_code, 3) << r.err;
      expect_one_line_naming(r, out.filename().string());
      EXPECT_EQ(slurp(in), before);
    }
  }
  EXPECT_EQ(joined(other_files({"in.ply", "plain_file"})), "");
}

TEST_F(HostileEnvironment, OutputThatIsTheInputUnderAnotherNameIsRefused) {
  const fs::path in = write_cloud("in.ply", 500);
  const std::string before = slurp(in);
  fs::create_directories(dir_ / "sub");
  fs::create_symlink(in, dir_ / "link.ply");
  fs::create_hard_link(in, dir_ / "hard.ply");
  const std::vector<std::string> same = {
      in.string(), (dir_ / "sub" / ".." / "in.ply").string(), (dir_ / "." / "in.ply").string(),
      (dir_ / "link.ply").string(), (dir_ / "hard.ply").string()};
  for (const auto& out : same) {
    for (const std::vector<std::string>& extra :
         {std::vector<std::string>{"smooth"}, {"curvature"}, {"smooth", "--memory-budget", "1K"}}) {
      SCOPED_TRACE(extra.back() + " -> " + out);
      std::vector<std::string> args = {extra[0], in.string(), out, "--steps", "1", "--quiet"};
      args.insert(args.end(), extra.begin() + 1, extra.end());
      const Result r = run(args);
      EXPECT_EQ(r.exit_code, 3) << r.err;
      EXPECT_NE(r.err.find("overwrite the input"), std::string::npos) << r.err;
      EXPECT_EQ(slurp(in), before);
    }
  }
  EXPECT_EQ(joined(other_files({"in.ply", "sub", "link.ply", "hard.ply"})), "");
}

TEST_F(HostileEnvironment, FullDiskWhileWritingLeavesNoOutput) {
  // The output of 5,000 points is over 150 KB (~400 KB with attributes); the limit allows
  // 64 KiB per file.
  const fs::path in = write_cloud("in.ply", 5000);
  const std::string before = slurp(in);
  for (const std::string out : {"out.ply", "out.xyz", "out.csv"}) {
    for (const std::string command : {"smooth", "curvature"}) {
      SCOPED_TRACE(command + " " + out);
      std::vector<std::string> args = {command, in.string(), (dir_ / out).string(), "--quiet"};
      if (command == "smooth") args.insert(args.end(), {"--steps", "2", "--attributes"});
      const Result r = run(args, rlim_t{64} << 10);
      EXPECT_EQ(r.exit_code, 3) << r.err;
      expect_one_line_naming(r, out);
      EXPECT_NE(r.err.find("File too large"), std::string::npos) << r.err;
      EXPECT_EQ(slurp(in), before);
      EXPECT_EQ(joined(other_files({"in.ply"})), "");
    }
  }
}

TEST_F(HostileEnvironment, FullDiskDuringAnOutOfCoreRunFailsCleanly) {
  const fs::path in = write_cloud("in.ply", 20000);
  const std::string before = slurp(in);
  const Result r = run({"smooth", in.string(), (dir_ / "out.ply").string(), "--memory-budget", "1M",
                        "--steps", "2", "--quiet"},
                       rlim_t{256} << 10);
  // Was: the error line, then a crash inside libhdf5's exit-time cleanup (SIGSEGV).
  EXPECT_EQ(r.exit_code, 3) << r.err;
  EXPECT_EQ(r.err.find("error: "), 0u) << r.err;
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << r.err;
  // The system's reason, from the innermost entry of libhdf5's error stack.
  EXPECT_NE(r.err.find("File too large"), std::string::npos) << r.err;
  EXPECT_EQ(slurp(in), before);
  EXPECT_EQ(joined(other_files({"in.ply"})), "");
}

// A disk that cannot write back what the run wrote: fsync fails with EIO from its Nth call on
// (failing_fsync.cpp, preloaded). The run stops with one line naming the file and the reason,
// commits no step after the failure, never makes the output, and --resume (on a disk that
// works again) finishes it with the bits of a run never interrupted.
TEST_F(HostileEnvironment, FailedSyncDuringAnOutOfCoreRunKeepsAResumableFile) {
  const fs::path in = write_cloud("in.ply", 3000);
  const fs::path scan = dir_ / "scan.h5";
  ASSERT_EQ(run({"import", in.string(), scan.string(), "--tile-points", "500", "--quiet"}).exit_code, 0);
  const std::string scan_before = slurp(scan);
  auto smooth = [&](const fs::path& out, std::vector<std::string> extra = {}) {
    std::vector<std::string> args = {"smooth", scan.string(), out.string(), "--steps", "6", "--quiet"};
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  };
  const fs::path whole = dir_ / "whole.h5", expected = dir_ / "expected.ply";
  ASSERT_EQ(run(smooth(whole)).exit_code, 0);
  ASSERT_EQ(run({"export", whole.string(), expected.string(), "--quiet"}).exit_code, 0);
  for (const int failing_from : {0, 3, 8}) {
    SCOPED_TRACE("fsync fails from call " + std::to_string(failing_from));
    const fs::path out = dir_ / "run.h5", partial = dir_ / "run.h5.partial";
    const Result r = run(smooth(out), {},
                         failing_fsync(failing_from));
    EXPECT_EQ(r.exit_code, 3) << r.err;
    EXPECT_EQ(r.err.find("error: "), 0u) << r.err;
    EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << r.err;
    EXPECT_NE(r.err.find("run.h5.partial: write failed: Input/output error"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("kept in run.h5.partial: once the cause is fixed, run the same command with --resume"),
              std::string::npos)
        << r.err;
    EXPECT_FALSE(fs::exists(out));
    EXPECT_EQ(slurp(scan), scan_before);
    ASSERT_TRUE(fs::exists(partial));
    const Result resumed = run(smooth(out, {"--resume"}));
    ASSERT_EQ(resumed.exit_code, 0) << resumed.err;
    const fs::path result = dir_ / "result.ply";
    ASSERT_EQ(run({"export", out.string(), result.string(), "--quiet"}).exit_code, 0);
    EXPECT_EQ(slurp(result), slurp(expected));
    fs::remove(out);
    fs::remove(result);
  }
}

// The same disk during an import (the container is written under a temporary name and
// synced before it is renamed into place): the error names the container asked for, not the
// temporary, and nothing is left behind.
TEST_F(HostileEnvironment, FailedSyncDuringAnImportNamesTheContainerAndLeavesNothing) {
  const fs::path in = write_cloud("in.ply", 3000);
  for (const std::string deflate : {"0", "4"}) {
    SCOPED_TRACE("deflate " + deflate);
    const fs::path scan = dir_ / "scan.h5";
    const Result r = run({"import", in.string(), scan.string(), "--tile-points", "500", "--deflate", deflate,
                          "--quiet"},
                         {},
                         failing_fsync(0));
    EXPECT_EQ(r.exit_code, 3) << r.err;
    EXPECT_EQ(r.err, "error: " + scan.string() + ": write failed: Input/output error\n");
    EXPECT_EQ(joined(other_files({"in.ply"})), "");
  }
}

TEST_F(HostileEnvironment, SigintAndSigtermStopASmoothRunCleanly) {
  const fs::path in = write_cloud("in.ply", 20000);
  const std::string before = slurp(in);
  for (const int sig : {SIGINT, SIGTERM}) {
    SCOPED_TRACE(sig);
    // A million steps without the automatic stop: the run is always interrupted.
    const Child c = start({"smooth", in.string(), (dir_ / "out.ply").string(), "--steps", "1000000",
                           "--stop-lambda-ratio", "0"});
    ASSERT_TRUE(wait_for_handlers(c.pid));
    kill(c.pid, sig);
    const Result r = wait_for(c);
    EXPECT_EQ(r.exit_code, 128 + sig) << r.err;
    const std::string name = sig == SIGINT ? "SIGINT" : "SIGTERM";
    EXPECT_NE(r.err.find("error: interrupted by " + name + "; no output written"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir_ / "out.ply"));
    EXPECT_EQ(slurp(in), before);
    EXPECT_EQ(joined(other_files({"in.ply"})), "");
  }
}

TEST_F(HostileEnvironment, SignalDuringAnImportLeavesNoContainer) {
  // The import checks for a signal after every chunk of its three passes; 200,000 points are
  // several chunks per pass.
  const fs::path in = write_cloud("in.ply", 200000);
  const std::string before = slurp(in);
  for (const int sig : {SIGINT, SIGTERM}) {
    SCOPED_TRACE(sig);
    const Child c = start({"import", in.string(), (dir_ / "scan.h5").string()});
    ASSERT_TRUE(wait_for_handlers(c.pid));
    kill(c.pid, sig);
    const Result r = wait_for(c);
    // Interrupted, or finished before the signal arrived: then the container is complete.
    if (r.exit_code == 128 + sig) {
      EXPECT_NE(r.err.find("interrupted by SIG"), std::string::npos) << r.err;
      EXPECT_FALSE(fs::exists(dir_ / "scan.h5"));
    } else {
      EXPECT_EQ(r.exit_code, 0) << r.err;
      EXPECT_TRUE(fs::exists(dir_ / "scan.h5"));
      fs::remove(dir_ / "scan.h5");
    }
    EXPECT_EQ(slurp(in), before);
    EXPECT_EQ(joined(other_files({"in.ply"})), "");
  }
}

TEST_F(HostileEnvironment, SignalDuringCurvatureOrDemoLeavesOnlyCompleteFiles) {
  const fs::path in = write_cloud("in.ply", 20000);
  const std::string before = slurp(in);
  const Child c = start({"curvature", in.string(), (dir_ / "out.ply").string(), "--quiet"});
  ASSERT_TRUE(wait_for_handlers(c.pid));
  kill(c.pid, SIGINT);
  const Result r = wait_for(c);
  // Interrupted, or finished before the signal arrived: then the output is complete.
  if (r.exit_code == 130) {
    EXPECT_FALSE(fs::exists(dir_ / "out.ply"));
  } else {
    EXPECT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(io::read_points(dir_ / "out.ply").size(), 20000u);
  }
  EXPECT_EQ(slurp(in), before);

  const Child d = start({"demo", "--out", (dir_ / "demo").string(), "--level", "5", "--steps", "1000000",
                         "--stop-lambda-ratio", "0"});
  ASSERT_TRUE(wait_for_handlers(d.pid));
  kill(d.pid, SIGTERM);
  const Result rd = wait_for(d);
  EXPECT_EQ(rd.exit_code, 143) << rd.err;
  EXPECT_NE(rd.err.find("interrupted by SIGTERM; summary.json not written"), std::string::npos) << rd.err;
  EXPECT_FALSE(fs::exists(dir_ / "demo" / "summary.json"));
  EXPECT_FALSE(fs::exists(dir_ / "demo" / "octahedron_aniso.ply"));
  if (fs::exists(dir_ / "demo")) {
    for (const auto& e : fs::directory_iterator(dir_ / "demo"))
      EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
  }
}

TEST_F(HostileEnvironment, SigintDuringAnOutOfCoreRunKeepsAResumableFile) {
  const fs::path in = write_cloud("in.ply", 3000);
  const fs::path scan = dir_ / "scan.h5";
  ASSERT_EQ(run({"import", in.string(), scan.string(), "--tile-points", "500", "--quiet"}).exit_code, 0);
  const std::string scan_before = slurp(scan);
  const std::vector<std::string> method = {"--steps", "150", "--quiet"};
  auto with = [&](std::vector<std::string> head, const std::vector<std::string>& tail) {
    head.insert(head.end(), tail.begin(), tail.end());
    return head;
  };
  const fs::path out = dir_ / "run.h5";
  const Child c = start(with({"smooth", scan.string(), out.string()}, method));
  ASSERT_TRUE(wait_for_handlers(c.pid));
  // Wait for the partial file, so that the signal arrives after the run has started.
  while (!fs::exists(dir_ / "run.h5.partial") && !fs::exists(out)) std::this_thread::yield();
  kill(c.pid, SIGINT);
  const Result r = wait_for(c);
  EXPECT_EQ(slurp(scan), scan_before);
  if (r.exit_code == 0) GTEST_SKIP() << "the run finished before the signal arrived";
  EXPECT_EQ(r.exit_code, 130) << r.err;
  EXPECT_NE(r.err.find("interrupted by SIGINT; the run so far is kept in run.h5.partial"), std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(out));
  ASSERT_TRUE(fs::exists(dir_ / "run.h5.partial"));

  const Result resumed = run(with({"smooth", scan.string(), out.string(), "--resume"}, method));
  ASSERT_EQ(resumed.exit_code, 0) << resumed.err;
  const Result whole = run(with({"smooth", scan.string(), (dir_ / "whole.h5").string()}, method));
  ASSERT_EQ(whole.exit_code, 0) << whole.err;
  const fs::path a = dir_ / "a.ply", b = dir_ / "b.ply";
  ASSERT_EQ(run({"export", out.string(), a.string(), "--quiet"}).exit_code, 0);
  ASSERT_EQ(run({"export", (dir_ / "whole.h5").string(), b.string(), "--quiet"}).exit_code, 0);
  EXPECT_EQ(slurp(a), slurp(b));
}
