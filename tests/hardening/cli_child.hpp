#pragma once
// The pointfair executable run as a child process by the hardening tests: its exit code,
// stdout and stderr, under a file-size limit, with an added environment, or ended after a
// time limit (a child that would hang is killed, and the test fails instead of hanging).
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "pointfair/io/point_file.hpp"
#include "pointfair/shapes/shapes.hpp"

namespace pointfair::testing_cli {

namespace fs = std::filesystem;

inline std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

struct Child {
  pid_t pid = -1;
  fs::path out, err;
};

struct Result {
  int exit_code = -1;  // -signal when a signal ended the process
  std::string out, err;
  bool timed_out = false;  // killed by wait_for's time limit
};

class CliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::random_device rd;
    dir_ = fs::temp_directory_path() / ("pointfair_cli_" + std::to_string(rd()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Starts the executable with `args`; stdout/stderr go to files. `file_size_limit` (bytes)
  // sets RLIMIT_FSIZE in the child with SIGXFSZ ignored, so writes past it fail with EFBIG
  // as on a full disk (sigxfsz_default: as `ulimit -f` in a shell, the signal left at its
  // default, which pointfair ignores itself). `environment`: "NAME=value" entries added to the
  // child's.
  Child start(const std::vector<std::string>& args, std::optional<rlim_t> file_size_limit = {},
              std::vector<std::string> environment = {}, bool sigxfsz_default = false) {
    Child c;
    c.out = dir_ / ("stdout_" + std::to_string(serial_));
    c.err = dir_ / ("stderr_" + std::to_string(serial_++));
    const pid_t pid = fork();
    if (pid == 0) {
      if (file_size_limit) {
        signal(SIGXFSZ, sigxfsz_default ? SIG_DFL : SIG_IGN);
        const rlimit limit{*file_size_limit, *file_size_limit};
        setrlimit(RLIMIT_FSIZE, &limit);
      }
      for (std::string& entry : environment) putenv(entry.data());
      if (!freopen(c.out.c_str(), "w", stdout) || !freopen(c.err.c_str(), "w", stderr)) _exit(126);
      std::vector<std::string> copy = args;
      std::string exe = POINTFAIR_EXE;
      std::vector<char*> argv{exe.data()};
      for (auto& a : copy) argv.push_back(a.data());
      argv.push_back(nullptr);
      execv(exe.c_str(), argv.data());
      _exit(127);
    }
    c.pid = pid;
    return c;
  }

  // Waits for the child; after `limit` it is killed (SIGKILL) and the result says timed_out.
  static Result wait_for(const Child& c, std::chrono::seconds limit = std::chrono::seconds(300)) {
    int status = 0;
    const auto deadline = std::chrono::steady_clock::now() + limit;
    bool timed_out = false;
    while (waitpid(c.pid, &status, WNOHANG) == 0) {
      if (std::chrono::steady_clock::now() > deadline) {
        kill(c.pid, SIGKILL);
        waitpid(c.pid, &status, 0);
        timed_out = true;
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    Result r;
    r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
    r.timed_out = timed_out;
    r.out = slurp(c.out);
    r.err = slurp(c.err);
    fs::remove(c.out);
    fs::remove(c.err);
    return r;
  }

  Result run(const std::vector<std::string>& args, std::optional<rlim_t> file_size_limit = {},
             const std::vector<std::string>& environment = {}) {
    return wait_for(start(args, file_size_limit, environment));
  }
  // `args` under `ulimit -f` (bytes), SIGXFSZ at its default.
  Result run_limited(const std::vector<std::string>& args, rlim_t file_size_limit) {
    return wait_for(start(args, file_size_limit, {}, true));
  }
  // `args`, killed after `limit` (a command that must not hang).
  Result run_within(const std::vector<std::string>& args, std::chrono::seconds limit) {
    return wait_for(start(args), limit);
  }

#ifdef POINTFAIR_FAILING_FSYNC
  // The environment in which the child's fsync fails with EIO from its call `from` on
  // (failing_fsync.cpp, preloaded; a target that builds it defines its path).
  static std::vector<std::string> failing_fsync(int from) {
    // The sanitizers' runtime would refuse to start behind a preloaded library.
    const char* asan = std::getenv("ASAN_OPTIONS");
    return {std::string("LD_PRELOAD=") + POINTFAIR_FAILING_FSYNC,
            "ASAN_OPTIONS=" + std::string(asan != nullptr ? asan : "") + ":verify_asan_link_order=0",
            "POINTFAIR_TEST_FSYNC_FAILS_FROM=" + std::to_string(from)};
  }
#endif

  // True once the child catches both SIGINT and SIGTERM (its handlers are installed), false
  // if it exited first. Reads the signal mask in /proc; no time limit.
  static bool wait_for_handlers(pid_t pid) {
    const unsigned long long wanted = (1ull << (SIGINT - 1)) | (1ull << (SIGTERM - 1));
    for (;;) {
      std::ifstream status("/proc/" + std::to_string(pid) + "/status");
      std::string line;
      bool zombie = !status;
      while (std::getline(status, line)) {
        if (line.starts_with("State:") && line.find('Z') != std::string::npos) zombie = true;
        if (line.starts_with("SigCgt:")) {
          const unsigned long long caught = std::stoull(line.substr(7), nullptr, 16);
          if ((caught & wanted) == wanted) return true;
        }
      }
      if (zombie) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  }

  fs::path write_cloud(const std::string& name, std::size_t n) {
    io::PointTable t;
    t.positions = sample_sphere(n, 1.0, 3).points;
    add_noise(t.positions, 0.01, 4);
    const fs::path p = dir_ / name;
    io::write_points(p, t);
    return p;
  }

  // Files in the test folder other than `keep` (stdout/stderr captures excluded).
  std::vector<std::string> other_files(std::initializer_list<std::string> keep) const {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir_)) {
      const std::string name = e.path().filename().string();
      if (name.starts_with("stdout_") || name.starts_with("stderr_")) continue;
      if (std::find(keep.begin(), keep.end(), name) == keep.end()) names.push_back(name);
    }
    return names;
  }

  fs::path dir_;
  int serial_ = 0;
};

inline std::string joined(const std::vector<std::string>& names) {
  std::string s;
  for (const auto& n : names) s += n + " ";
  return s;
}

// One line on stderr naming `name`.
inline void expect_one_line_naming(const Result& r, const std::string& name) {
  ASSERT_FALSE(r.err.empty());
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "expected one line, got: " << r.err;
  EXPECT_NE(r.err.find(name), std::string::npos) << r.err;
}

}  // namespace pointfair::testing_cli
