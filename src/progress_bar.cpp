#include "progress_bar.hpp"

#include <unistd.h>

#include <cstdio>
#include <utility>

namespace sid::app {

ProgressBar::ProgressBar(std::string app, std::string unit, bool enabled)
    : app_(std::move(app)), unit_(std::move(unit)), enabled_(enabled), start_(Clock::now()) {}

void ProgressBar::update(int done, int total) {
  if (!enabled_) return;
  const auto now = Clock::now();
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  if (elapsed < 1.0) return;
  if (drawn_ && done < total && std::chrono::duration<double>(now - last_).count() < 0.1) return;
  last_ = now;
  drawn_ = true;
  constexpr int kWidth = 40;
  const int filled =
      total > 0 ? static_cast<int>(static_cast<long long>(kWidth) * done / total) : kWidth;
  std::string bar(static_cast<std::size_t>(filled), '#');
  bar += std::string(static_cast<std::size_t>(kWidth - filled), '.');
  const double left = done > 0 ? elapsed * (total - done) / done : 0.0;
  std::fprintf(stderr, "\r%s: [%s] %d/%d %s, %.0f s, about %.0f s left ", app_.c_str(), bar.c_str(),
               done, total, unit_.c_str(), elapsed, left);
  std::fflush(stderr);
}

void ProgressBar::finish() {
  if (!drawn_) return;
  std::fprintf(stderr, "\r%s\r", std::string(100, ' ').c_str());
  std::fflush(stderr);
  drawn_ = false;
}

bool stderr_is_terminal() { return ::isatty(2) != 0; }

}  // namespace sid::app
