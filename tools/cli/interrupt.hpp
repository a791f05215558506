#pragma once
// SIGINT and SIGTERM as a clean error: the handlers only set a flag; the commands check it
// between steps (and between other long phases) and throw Interrupted, which unwinds like
// any other error, so temporary output files are removed and nothing that looks complete is
// left behind. A second signal of either kind ends the process at once (default action).
#include <stdexcept>
#include <string>

namespace pointfair::cli {

/// Thrown by throw_if_interrupted(). what() names the signal ("interrupted by SIGINT").
class Interrupted : public std::runtime_error {
 public:
  /// what(): "interrupted by SIGINT; <consequence>" (the consequence omitted when empty).
  Interrupted(int signal_number, const std::string& consequence);
  int signal_number() const { return signal_; }
  /// The shell's convention: 128 + signal (130 for SIGINT, 143 for SIGTERM).
  int exit_code() const { return 128 + signal_; }

 private:
  int signal_;
};

/// Installs the SIGINT and SIGTERM handlers. Call once, early in main().
void install_interrupt_handlers();

/// The first signal received (SIGINT or SIGTERM), or 0.
int interrupt_signal();

/// While one lives, the signal flag is the parallel facade's stop flag (set_stop_flag): a
/// signal ends the running parallel loop within a fraction of a second with Stopped, which
/// the command turns into Interrupted (rethrow_stopped_as_interrupted).
class StopOnInterrupt {
 public:
  StopOnInterrupt();
  ~StopOnInterrupt();
  StopOnInterrupt(const StopOnInterrupt&) = delete;
  StopOnInterrupt& operator=(const StopOnInterrupt&) = delete;
};

/// Throws Interrupted(signal, consequence) when a signal has arrived. `consequence` tells the
/// user what was (not) kept, e.g. "no output written".
void throw_if_interrupted(const std::string& consequence = "no output written");

}  // namespace pointfair::cli
