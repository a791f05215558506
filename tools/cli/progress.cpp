#include "progress.hpp"

#include <cstdio>
#include <unistd.h>

namespace pointfair::cli {

Progress::Progress(std::string label, bool enabled)
    : label_(std::move(label)),
      enabled_(enabled),
      tty_(isatty(STDERR_FILENO) == 1),
      start_(std::chrono::steady_clock::now()),
      last_print_(start_) {}

Progress::~Progress() { finish(); }

void Progress::update(long long done, long long total) {
  if (!enabled_ || total <= 0) return;
  const auto now = std::chrono::steady_clock::now();
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  if (elapsed < 1.0) return;
  const double fraction = static_cast<double>(done) / static_cast<double>(total);
  const double eta = fraction > 0 ? elapsed * (1.0 - fraction) / fraction : 0.0;
  if (tty_) {
    if (std::chrono::duration<double>(now - last_print_).count() < 0.2 && done < total) return;
    std::fprintf(stderr, "\r%s %lld/%lld (%3.0f%%) %.1f s elapsed, ~%.1f s left   ", label_.c_str(),
                 done, total, 100.0 * fraction, elapsed, eta);
  } else {
    const int decile = static_cast<int>(fraction * 10.0);
    if (decile == last_decile_) return;
    last_decile_ = decile;
    std::fprintf(stderr, "%s %lld/%lld (%3.0f%%) %.1f s elapsed\n", label_.c_str(), done, total,
                 100.0 * fraction, elapsed);
  }
  std::fflush(stderr);
  shown_ = true;
  last_print_ = now;
}

void Progress::finish() {
  if (shown_ && tty_) std::fputc('\n', stderr);
  shown_ = false;
}

std::function<void(std::string_view)> stderr_notes(bool quiet) {
  return [quiet](std::string_view text) {
    if (!quiet) std::fprintf(stderr, "%.*s\n", static_cast<int>(text.size()), text.data());
  };
}

}  // namespace pointfair::cli
