// Progress of a long command on stderr, one bar per stage: on a terminal the bar is redrawn in
// place; into a file or a pipe (a batch log, CI) a line is written every 10 % instead, so logs
// stay readable.
//
//   StageBar bar(quiet);
//   bar.update("scan", done, total, "slices");   // as often as you like
//   bar.done("scan", seconds, "793 slices, 108 knots");
#pragma once

#include <chrono>
#include <string>

namespace sawyer::app {

class StageBar {
 public:
  explicit StageBar(bool quiet);
  void update(const std::string& stage, int done, int total, const std::string& unit);
  // Ends the stage's bar with its wall time and a note.
  void done(const std::string& stage, double seconds, const std::string& note);

 private:
  bool quiet_, tty_;
  std::string stage_;
  int last_decile_ = -1;
  std::chrono::steady_clock::time_point last_draw_{};
};

}  // namespace sawyer::app
