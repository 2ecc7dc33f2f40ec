// Stage progress bars on stderr (see progress.h).
#include "progress.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>

namespace sawyer::app {

namespace {
constexpr int kBarWidth = 28;
}

StageBar::StageBar(bool quiet) : quiet_(quiet), tty_(isatty(STDERR_FILENO) != 0) {}

void StageBar::update(const std::string& stage, int done, int total, const std::string& unit) {
  if (quiet_ || total <= 0) return;
  if (stage != stage_) {
    stage_ = stage;
    last_decile_ = -1;
  }
  const double f = std::clamp(static_cast<double>(done) / total, 0.0, 1.0);
  if (!tty_) {
    const int decile = static_cast<int>(f * 10);
    if (decile == last_decile_) return;
    last_decile_ = decile;
    std::fprintf(stderr, "%-7s %3d%%  %d/%d %s\n", stage.c_str(), decile * 10, done, total,
                 unit.c_str());
    return;
  }
  // A terminal redraws at most ~20 times a second; the last update always shows.
  const auto now = std::chrono::steady_clock::now();
  if (done < total && now - last_draw_ < std::chrono::milliseconds(50)) return;
  last_draw_ = now;
  const int filled = static_cast<int>(f * kBarWidth + 0.5);
  std::string bar(static_cast<size_t>(filled), '#');
  bar.append(static_cast<size_t>(kBarWidth - filled), '.');
  std::fprintf(stderr, "\r%-7s [%s] %3.0f%%  %d/%d %s\033[K", stage.c_str(), bar.c_str(), 100 * f,
               done, total, unit.c_str());
  std::fflush(stderr);
}

void StageBar::done(const std::string& stage, double seconds, const std::string& note) {
  if (quiet_) return;
  if (tty_) {
    const std::string bar(kBarWidth, '#');
    std::fprintf(stderr, "\r%-7s [%s] done in %.2f s  %s\033[K\n", stage.c_str(), bar.c_str(),
                 seconds, note.c_str());
  } else {
    std::fprintf(stderr, "%-7s done in %.2f s  %s\n", stage.c_str(), seconds, note.c_str());
  }
  stage_.clear();
}

}  // namespace sawyer::app
