#pragma once
// Progress on stderr for runs that take over a second: silent before that, then one line
// updated in place (a terminal) or a line every 10% (a log file).
#include <chrono>
#include <functional>
#include <string>
#include <string_view>

namespace pointfair::cli {

class Progress {
 public:
  Progress(std::string label, bool enabled);
  ~Progress();
  void update(long long done, long long total);
  void finish();

 private:
  std::string label_;
  bool enabled_;
  bool tty_;
  bool shown_ = false;
  int last_decile_ = -1;
  std::chrono::steady_clock::time_point start_, last_print_;
};

/// A run's one-line notes (PointFileSmooth::note, OutOfCoreFileSmooth::note) on stderr, unless
/// quiet.
std::function<void(std::string_view)> stderr_notes(bool quiet);

}  // namespace pointfair::cli
