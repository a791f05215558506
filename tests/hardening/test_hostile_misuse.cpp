// Misuse of the pointfair executable: a --resume beside a run that still works or naming
// another input, a user's files where the run keeps its own, outputs and inputs that are not
// regular files (named pipes, devices), and a file-size limit with SIGXFSZ at its default.
// Always: a one-line error naming the file, a non-zero exit, nothing of the user's touched,
// nothing half-written left behind.
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "cli_child.hpp"
#include "pointfair/io/file_lock.hpp"
#include "pointfair/io/point_file.hpp"
#include "pointfair/shapes/shapes.hpp"

namespace fs = std::filesystem;
using namespace pointfair;
using namespace pointfair::testing_cli;

namespace {

class HostileMisuse : public CliTest {
 protected:
  // A container of `points` sphere points in tiles of 500, from `name`.ply; `shift` moves
  // every point (same size, other coordinates).
  fs::path write_scan(const std::string& name, std::size_t points, double shift = 0.0) {
    io::PointTable t;
    t.positions = sample_sphere(points, 1.0, 3).points;
    add_noise(t.positions, 0.01, 4);
    for (auto& p : t.positions) p.x() += shift;
    const fs::path ply = dir_ / (name + ".ply");
    io::write_points(ply, t);
    const fs::path scan = dir_ / (name + ".h5");
    EXPECT_EQ(run({"import", ply.string(), scan.string(), "--tile-points", "500", "--quiet"}).exit_code, 0);
    fs::remove(ply);
    return scan;
  }
  static std::vector<std::string> smooth(const fs::path& in, const fs::path& out, std::vector<std::string> extra = {}) {
    std::vector<std::string> args = {"smooth", in.string(), out.string(), "--steps", "4", "--quiet"};
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  }
  static bool is_fifo(const fs::path& p) { return fs::is_fifo(fs::symlink_status(p)); }
};

// --- (1) resume misuse and the run file's lock -------------------------------------------

TEST_F(HostileMisuse, FileLockIsExclusiveAndTravelsWithARename) {
  const fs::path p = dir_ / "run.partial";
  {
    io::FileLock lock(p);
    EXPECT_TRUE(lock.created());
    EXPECT_THROW(io::FileLock{p}, io::IoError);
    try {
      io::FileLock second(p);
    } catch (const io::IoError& e) {
      EXPECT_NE(std::string(e.what()).find("run.partial: in use by another process"), std::string::npos) << e.what();
    }
    // Renamed while locked (a run that finishes): the name is free again, the file is not.
    fs::rename(p, dir_ / "done");
    io::FileLock fresh(p);
    EXPECT_TRUE(fresh.created());
    EXPECT_THROW(io::FileLock{dir_ / "done"}, io::IoError);
  }
  io::FileLock again(dir_ / "done");
  EXPECT_FALSE(again.created());
}

TEST_F(HostileMisuse, ARunFileHeldByAnotherProcessIsRefused) {
  const fs::path scan = write_scan("scan", 2000);
  const fs::path out = dir_ / "out.h5";
  for (const bool resume : {false, true}) {
    SCOPED_TRACE(resume ? "--resume" : "a new run");
    // This process holds the run file as a running run would.
    io::FileLock held(dir_ / "out.h5.partial");
    const Result r = run(smooth(scan, out, resume ? std::vector<std::string>{"--resume"} : std::vector<std::string>{}));
    EXPECT_EQ(r.exit_code, 3) << r.err;
    expect_one_line_naming(r, "out.h5.partial: in use by another process");
    EXPECT_FALSE(fs::exists(out));
    fs::remove(dir_ / "out.h5.partial");
  }
}

TEST_F(HostileMisuse, AResumeStartedWhileTheRunStillRunsIsRefusedAndTheResultStaysFinished) {
  const fs::path scan = write_scan("scan", 3000);
  const fs::path out = dir_ / "out.h5";
  const std::vector<std::string> method = {"--steps", "150", "--quiet"};
  std::vector<std::string> first = {"smooth", scan.string(), out.string()};
  first.insert(first.end(), method.begin(), method.end());
  const Child c = start(first);
  for (int i = 0; i < 200000 && !fs::exists(dir_ / "out.h5.partial") && !fs::exists(out); ++i)
    std::this_thread::sleep_for(std::chrono::microseconds(50));
  std::vector<std::string> second = first;
  second.push_back("--resume");
  const Result r = run(second);
  const Result done = wait_for(c);
  ASSERT_EQ(done.exit_code, 0) << done.err;
  if (r.exit_code == 0) GTEST_SKIP() << "the first run finished before the second started";
  EXPECT_EQ(r.exit_code, 3) << r.err;
  expect_one_line_naming(r, "in use by another process");
  // The first run's result is a finished run: it exports.
  EXPECT_EQ(run({"export", out.string(), (dir_ / "out.ply").string(), "--quiet"}).exit_code, 0);
  EXPECT_FALSE(fs::exists(dir_ / "out.h5.partial"));
}

TEST_F(HostileMisuse, AResumeWithAnotherContainerOfTheSameSizeIsRefused) {
  const fs::path scan = write_scan("scana", 3000);
  const fs::path other = write_scan("scanb", 3000, 1e-3);
  ASSERT_EQ(fs::file_size(scan), fs::file_size(other));
  const fs::path out = dir_ / "out.h5";
  // A run stopped by a disk that fails to sync keeps its partial file.
  ASSERT_EQ(run(smooth(scan, out), {}, failing_fsync(3)).exit_code, 3);
  ASSERT_TRUE(fs::exists(dir_ / "out.h5.partial"));
  const Result r = run(smooth(other, out, {"--resume"}));
  EXPECT_EQ(r.exit_code, 3) << r.err;
  expect_one_line_naming(r, "belongs to another input than " + other.string());
  EXPECT_FALSE(fs::exists(out));
  ASSERT_TRUE(fs::exists(dir_ / "out.h5.partial"));
  EXPECT_EQ(run(smooth(scan, out, {"--resume"})).exit_code, 0);
  EXPECT_TRUE(fs::exists(out));
}

TEST_F(HostileMisuse, AResumeOfAPointFileRunWithAnotherPointFileIsRefused) {
  const fs::path in = write_cloud("in.ply", 3000);
  // Same point count, same size, other coordinates.
  io::PointTable t = io::read_points(in);
  for (auto& p : t.positions) p.y() += 1e-3;
  const fs::path other = dir_ / "other.ply";
  io::write_points(other, t);
  const fs::path out = dir_ / "out.ply";
  const std::vector<std::string> budget = {"--memory-budget", "1M"};
  const Result failed = run(smooth(in, out, budget), {}, failing_fsync(3));
  ASSERT_EQ(failed.exit_code, 3) << failed.err;
  EXPECT_NE(failed.err.find("kept in .out.ply.pointfair-run"), std::string::npos) << failed.err;
  std::vector<std::string> resume = budget;
  resume.push_back("--resume");
  const fs::path kept = dir_ / ".out.ply.pointfair-run" / "run.h5.partial";
  ASSERT_TRUE(fs::exists(kept));
  const Result r = run(smooth(other, out, resume));
  EXPECT_EQ(r.exit_code, 3) << r.err;
  expect_one_line_naming(r, other.string() + ": the interrupted run in");
  EXPECT_FALSE(fs::exists(out));
  // The refused resume loses nothing: the interrupted run is still there, and continues.
  ASSERT_TRUE(fs::exists(kept));
  std::vector<std::string> resume_json = resume;
  resume_json.push_back("--json");
  const Result resumed = run(smooth(in, out, resume_json));
  EXPECT_EQ(resumed.exit_code, 0) << resumed.err;
  EXPECT_NE(resumed.out.find("\"resumed_from\""), std::string::npos) << resumed.out;
  EXPECT_TRUE(fs::exists(out));
  EXPECT_EQ(joined(other_files({"in.ply", "other.ply", "out.ply"})), "");
}

// --- (2) the user's files, temporaries, outputs that are not regular files ----------------

TEST_F(HostileMisuse, AnOutOfCoreRunOfAPointFileNeverTouchesTheUsersFiles) {
  const fs::path in = write_cloud("in.ply", 3000);
  // Files of the names earlier versions used beside OUT, and one of the run folder's names.
  const std::vector<std::string> mine = {"out.ply.run.h5", "out.ply.input.h5", "out.ply.run.h5.partial",
                                         "out.ply.partial", ".out.ply.tmp-1-2"};
  for (const auto& name : mine) std::ofstream(dir_ / name) << "the user's " << name;
  const Result r = run(smooth(in, dir_ / "out.ply", {"--memory-budget", "1M"}));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const auto& name : mine) EXPECT_EQ(slurp(dir_ / name), "the user's " + name);
  EXPECT_EQ(joined(other_files({"in.ply", "out.ply", "out.ply.run.h5", "out.ply.input.h5", "out.ply.run.h5.partial",
                                "out.ply.partial", ".out.ply.tmp-1-2"})),
            "");
}

TEST_F(HostileMisuse, AUsersFileWhereARunKeepsItsOwnIsLeftAlone) {
  const fs::path scan = write_scan("scan", 2000);
  // A container run's partial file that is not a run (with and without --resume).
  std::ofstream(dir_ / "out.h5.partial") << "notes";
  for (const bool resume : {false, true}) {
    const Result r = run(smooth(scan, dir_ / "out.h5", resume ? std::vector<std::string>{"--resume"}
                                                              : std::vector<std::string>{}));
    EXPECT_EQ(r.exit_code, 3) << r.err;
    expect_one_line_naming(r, "out.h5.partial");
    EXPECT_EQ(slurp(dir_ / "out.h5.partial"), "notes");
  }
  // A file where a point-file run keeps its folder.
  const fs::path in = write_cloud("in.ply", 500);
  std::ofstream(dir_ / ".out.ply.pointfair-run") << "notes";
  const Result r = run(smooth(in, dir_ / "out.ply", {"--memory-budget", "1K", "--resume"}));
  EXPECT_EQ(r.exit_code, 3) << r.err;
  expect_one_line_naming(r, ".out.ply.pointfair-run");
  EXPECT_EQ(slurp(dir_ / ".out.ply.pointfair-run"), "notes");
  EXPECT_FALSE(fs::exists(dir_ / "out.ply"));
}

TEST_F(HostileMisuse, OutputsThatAreNotRegularFilesAreRefused) {
  const fs::path in = write_cloud("in.ply", 500);
  const fs::path scan = write_scan("scan", 1000);
  ASSERT_EQ(::mkfifo((dir_ / "pipe.ply").c_str(), 0600), 0);
  ASSERT_EQ(::mkfifo((dir_ / "pipe.h5").c_str(), 0600), 0);
  const std::vector<std::vector<std::string>> commands = {
      {"smooth", in.string(), (dir_ / "pipe.ply").string(), "--steps", "1"},
      {"smooth", in.string(), (dir_ / "pipe.ply").string(), "--steps", "1", "--memory-budget", "1K"},
      {"smooth", scan.string(), (dir_ / "pipe.h5").string(), "--steps", "1"},
      {"smooth", scan.string(), (dir_ / "pipe.ply").string(), "--steps", "1"},
      {"curvature", in.string(), (dir_ / "pipe.ply").string()},
      {"import", in.string(), (dir_ / "pipe.h5").string()},
      {"export", scan.string(), (dir_ / "pipe.ply").string()},
      {"generate", "sphere", (dir_ / "pipe.ply").string()},
      {"smooth", in.string(), "/dev/null", "--steps", "1"},
      {"smooth", in.string(), "/dev/null", "--steps", "1", "--memory-budget", "1K"},
      {"smooth", scan.string(), "/dev/null", "--steps", "1"},
  };
  for (auto args : commands) {
    SCOPED_TRACE(args[0] + " -> " + args[2]);
    if (args[0] != "generate") args.push_back("--quiet");
    const Result r = run_within(args, std::chrono::seconds(60));
    EXPECT_FALSE(r.timed_out);
    EXPECT_EQ(r.exit_code, 3) << r.err;
    // /dev/null has no point-file extension either: refused for that or for what it is.
    if (args[2] == "/dev/null") expect_one_line_naming(r, "/dev/null");
    else expect_one_line_naming(r, fs::path(args[2]).filename().string() + ": exists and is not a regular file");
  }
  EXPECT_TRUE(is_fifo(dir_ / "pipe.ply"));
  EXPECT_TRUE(is_fifo(dir_ / "pipe.h5"));
  EXPECT_TRUE(fs::is_character_file("/dev/null"));
  EXPECT_EQ(joined(other_files({"in.ply", "scan.h5", "pipe.ply", "pipe.h5"})), "");
}

// --- (3) inputs that are not regular files ------------------------------------------------

TEST_F(HostileMisuse, InputsThatAreNotRegularFilesAreRefusedWithoutBlocking) {
  const fs::path scan = write_scan("scan", 1000);
  const fs::path cloud = write_cloud("cloud.ply", 500);
  // Named pipes with no writer (an open for reading would block forever) and /dev/zero under
  // point-file names (endless zeros: no line break, no end).
  for (const char* name : {"pipe.xyz", "pipe.ply", "pipe.las", "pipe.h5", "pipe.off", "pipe.truth"})
    ASSERT_EQ(::mkfifo((dir_ / name).c_str(), 0600), 0);
  fs::create_symlink("/dev/zero", dir_ / "zero.xyz");
  fs::create_symlink("/dev/zero", dir_ / "zero.ply");
  const fs::path out = dir_ / "out.ply";
  const std::vector<std::vector<std::string>> commands = {
      {"smooth", (dir_ / "pipe.xyz").string(), out.string()},
      {"smooth", (dir_ / "pipe.ply").string(), out.string(), "--memory-budget", "1K"},
      {"smooth", (dir_ / "pipe.las").string(), out.string()},
      {"smooth", (dir_ / "pipe.h5").string(), out.string()},
      {"smooth", (dir_ / "zero.xyz").string(), out.string()},
      {"smooth", (dir_ / "zero.xyz").string(), out.string(), "--memory-budget", "1K"},
      {"curvature", (dir_ / "zero.ply").string(), out.string()},
      {"import", (dir_ / "zero.xyz").string(), (dir_ / "out.h5").string()},
      {"export", (dir_ / "pipe.h5").string(), out.string()},
      {"eval", cloud.string(), "--truth", (dir_ / "pipe.truth").string()},
      {"eval", cloud.string(), "--truth", (dir_ / "pipe.off").string()},
      {"eval", (dir_ / "pipe.ply").string(), "--truth", "sphere"},
  };
  for (auto args : commands) {
    const std::string input = args[0] == "eval" && args[3] != "sphere" ? args[3] : args[1];
    SCOPED_TRACE(args[0] + " " + input);
    if (args[0] != "eval") args.push_back("--quiet");
    const Result r = run_within(args, std::chrono::seconds(60));
    EXPECT_FALSE(r.timed_out) << "the command hung";
    EXPECT_EQ(r.exit_code, 3) << r.err;
    expect_one_line_naming(r, fs::path(input).filename().string() + ": is a");
    EXPECT_NE(r.err.find("not a regular file"), std::string::npos) << r.err;
  }
  EXPECT_EQ(joined(other_files({"scan.h5", "cloud.ply", "pipe.xyz", "pipe.ply", "pipe.las", "pipe.h5", "pipe.off", "pipe.truth",
                                "zero.xyz", "zero.ply"})),
            "");
}

TEST_F(HostileMisuse, AnEndlessLineInATextFileIsBounded) {
  // A regular file of 17 MiB without a line break under a text name: refused at 16 MiB.
  const fs::path p = dir_ / "zeros.xyz";
  {
    std::ofstream f(p, std::ios::binary);
    const std::string block(1 << 20, '7');
    for (int i = 0; i < 17; ++i) f << block;
  }
  const Result r = run_within({"smooth", p.string(), (dir_ / "out.ply").string(), "--quiet"}, std::chrono::seconds(120));
  EXPECT_EQ(r.exit_code, 3) << r.err;
  expect_one_line_naming(r, "zeros.xyz: line 1 is longer than 16 MiB");
}

// --- (4) a file-size limit (ulimit -f) with SIGXFSZ at its default ------------------------

TEST_F(HostileMisuse, AFileSizeLimitIsAClearErrorNotASignal) {
  const fs::path in = write_cloud("in.ply", 20000);
  const fs::path scan = write_scan("scan", 20000);
  const std::string before = slurp(in);
  const std::vector<std::vector<std::string>> commands = {
      {"smooth", in.string(), (dir_ / "out.ply").string(), "--steps", "1"},
      {"smooth", in.string(), (dir_ / "out.ply").string(), "--steps", "1", "--memory-budget", "1M"},
      {"smooth", scan.string(), (dir_ / "out.h5").string(), "--steps", "1"},
      {"import", in.string(), (dir_ / "out.h5").string()},
      {"export", scan.string(), (dir_ / "out.ply").string()},
      {"curvature", in.string(), (dir_ / "out.ply").string()},
  };
  for (auto args : commands) {
    SCOPED_TRACE(args[0] + " -> " + args[2]);
    args.push_back("--quiet");
    const Result r = run_limited(args, rlim_t{200} << 10);
    EXPECT_EQ(r.exit_code, 3) << r.err;
    EXPECT_EQ(r.err.find("error: "), 0u) << r.err;
    EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << r.err;
    EXPECT_NE(r.err.find("File too large"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(fs::path(args[2]).filename().string()), std::string::npos) << r.err;
    EXPECT_EQ(slurp(in), before);
    // A container run keeps its partial file for --resume (it says so); nothing else stays.
    if (fs::exists(dir_ / "out.h5.partial")) {
      EXPECT_NE(r.err.find("--resume"), std::string::npos) << r.err;
      fs::remove(dir_ / "out.h5.partial");
    }
    EXPECT_EQ(joined(other_files({"in.ply", "scan.h5"})), "");
  }
}

}  // namespace

// --- (7) extreme magnitudes through the commands -----------------------------------------

namespace {

TEST_F(HostileMisuse, ExtremeMagnitudesGiveAResultOrAClearError) {
  // The octahedron's truth (a mesh: the mesh distance) and the sphere's (analytic); clouds at
  // 1e40, 1e150 and 1e200.
  ASSERT_EQ(run({"generate", "octahedron", (dir_ / "o.xyz").string(), "--points", "600", "--truth-out",
                 (dir_ / "o.truth").string()})
                .exit_code,
            0);
  const io::PointTable o = io::read_points(dir_ / "o.xyz");
  for (const double scale : {1e40, 1e150, 1e200}) {
    SCOPED_TRACE(scale);
    io::PointTable t;
    t.positions = o.positions;
    for (Vec3& p : t.positions) p *= scale;
    const fs::path big = dir_ / "big.xyz";
    io::write_points(big, t);
    for (const std::string& truth : {(dir_ / "o.truth").string(), std::string("sphere")}) {
      const Result r = run_within({"eval", big.string(), "--truth", truth}, std::chrono::seconds(120));
      EXPECT_FALSE(r.timed_out);
      if (scale > 1e100) {
        EXPECT_EQ(r.exit_code, 3) << r.err;
        expect_one_line_naming(r, "big.xyz: point 0 has a coordinate beyond 1e100");
      } else {
        EXPECT_EQ(r.exit_code, 0) << r.err;
      }
    }
    for (const std::string command : {"smooth", "curvature"}) {
      std::vector<std::string> args = {command, big.string(), (dir_ / "out.ply").string(), "--quiet"};
      if (command == "smooth") args.insert(args.end(), {"--steps", "1", "--attributes"});
      const Result r = run_within(args, std::chrono::seconds(120));
      EXPECT_EQ(r.exit_code, 0) << command << ": " << r.err;
      // A result: finite, with unit normals where the points are not counted degenerate.
      const io::PointTable out = io::read_points(dir_ / "out.ply");
      const io::Attribute* nx = out.find("nx");
      ASSERT_NE(nx, nullptr);
      if (scale < 1e100) {
        std::size_t zero = 0;
        for (std::size_t i = 0; i < out.size(); ++i)
          zero += nx->values[i] == 0 && out.find("ny")->values[i] == 0 && out.find("nz")->values[i] == 0;
        EXPECT_EQ(zero, 0u) << command;
      }
    }
  }
}

}  // namespace

// --- (9) every error names the file --------------------------------------------------------

namespace {

TEST_F(HostileMisuse, EvalGenerateAndReferenceErrorsNameTheirFile) {
  const fs::path in = write_cloud("in.ply", 500);
  std::ofstream(dir_ / "one.xyz") << "0 0 0\n";
  std::ofstream(dir_ / "flat.xyz") << "1 1 1\n1 1 1\n";
  std::ofstream(dir_ / "empty.ply") << "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\n"
                                       "property float z\nend_header\n";
  std::ofstream(dir_ / "flat.off") << "OFF\n3 1 0\n0 0 0\n1 1 1\n2 2 2\n3 0 1 2\n";
  const std::string one = (dir_ / "one.xyz").string();
  const struct {
    std::vector<std::string> args;
    std::string named;
  } cases[] = {
      {{"eval", (dir_ / "empty.ply").string(), "--truth", "sphere"}, "empty.ply"},
      {{"eval", in.string(), "--truth", "sphere", "--input", one}, "one.xyz"},
      {{"eval", in.string(), "--truth", "sphere", "--clean", (dir_ / "flat.xyz").string()}, "flat.xyz"},
      {{"eval", in.string(), "--truth", (dir_ / "empty.ply").string()}, "empty.ply"},
      {{"generate", "mesh", (dir_ / "g.ply").string(), "--mesh", (dir_ / "flat.off").string()}, "flat.off"},
      {{"smooth", in.string(), (dir_ / "o.ply").string(), "--neighbors-from", one, "--quiet"}, "one.xyz"},
      {{"smooth", in.string(), (dir_ / "o.ply").string(), "--neighbors-from", one, "--memory-budget", "1M", "--quiet"},
       "one.xyz"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.args[0] + " " + c.args[1] + " ... " + c.named);
    const Result r = run_within(c.args, std::chrono::seconds(60));
    EXPECT_NE(r.exit_code, 0);
    EXPECT_NE(r.exit_code, 1) << "an unexpected failure: " << r.err;
    expect_one_line_naming(r, c.named + ": ");
  }
  EXPECT_FALSE(fs::exists(dir_ / "o.ply"));
  EXPECT_FALSE(fs::exists(dir_ / "g.ply"));
}

}  // namespace
