#include "interrupt.hpp"

#include <csignal>

#include "pointfair/common/parallel.hpp"

#include <atomic>
#include <string>

namespace pointfair::cli {
namespace {

// Lock-free, so reading and writing it in a signal handler is well defined.
std::atomic<int> g_signal{0};
static_assert(std::atomic<int>::is_always_lock_free);

extern "C" void on_interrupt(int signal_number) {
  int expected = 0;
  if (!g_signal.compare_exchange_strong(expected, signal_number)) {
    // A second signal: the user insists. Default action (async-signal-safe calls only).
    std::signal(signal_number, SIG_DFL);
    std::raise(signal_number);
  }
}

std::string signal_name(int signal_number) {
  if (signal_number == SIGINT) return "SIGINT";
  if (signal_number == SIGTERM) return "SIGTERM";
  return "signal " + std::to_string(signal_number);
}

}  // namespace

Interrupted::Interrupted(int signal_number, const std::string& consequence)
    : std::runtime_error("interrupted by " + signal_name(signal_number) +
                         (consequence.empty() ? std::string() : "; " + consequence)),
      signal_(signal_number) {}

void install_interrupt_handlers() {
  std::signal(SIGINT, on_interrupt);
  std::signal(SIGTERM, on_interrupt);
}

int interrupt_signal() { return g_signal.load(); }

StopOnInterrupt::StopOnInterrupt() { set_stop_flag(&g_signal); }
StopOnInterrupt::~StopOnInterrupt() { set_stop_flag(nullptr); }

void throw_if_interrupted(const std::string& consequence) {
  if (const int s = g_signal.load(); s != 0) throw Interrupted(s, consequence);
}

}  // namespace pointfair::cli
