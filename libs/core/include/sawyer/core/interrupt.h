// Clean exits on SIGINT, SIGTERM and SIGHUP: the temporary outputs being written are removed
// before the process ends, so an interrupted run leaves nothing behind.
//
//   int main(...) {
//     sawyer::install_interrupt_cleanup();   // once, before any thread starts
//     ...
//   }
//   // Writers track what they create under a temporary name while it exists:
//   sawyer::TrackedTemp guard(tmp_dir);      // removed if a signal arrives meanwhile
//
// The signal handler only sets a flag and writes one byte to a pipe (both async-signal-safe); a
// watcher thread reads the pipe, runs the cleanup hooks, parks every other thread, removes every
// tracked path (allocation-free) and ends the process with 128 + the signal number (130 for
// Ctrl-C, 143 for SIGTERM). Without
// install_interrupt_cleanup() (tests, other programs using the libraries) tracking costs a mutex
// and does nothing else.
#pragma once

#include <filesystem>
#include <functional>

namespace sawyer {

// Exit codes of the command line (README, "Exit codes").
inline constexpr int kExitOk = 0;
inline constexpr int kExitBadInput = 1;       // bad input or options, nothing written
inline constexpr int kExitPartial = 2;        // batch: some logs failed, the others are done
inline constexpr int kExitWarnings = 3;       // done, but a result is marked as not to be trusted
inline constexpr int kExitNotSawn = 4;        // run: scan, run.json and report written, but the
                                              // pattern cannot be sawn from the log
inline constexpr int kExitInterrupted = 128;  // + the signal number (SIGINT 130, SIGTERM 143)

void install_interrupt_cleanup();

// True once SIGINT/SIGTERM/SIGHUP has arrived (and cleanup is under way).
bool interrupted();

// Paths (files or folders) to remove if the process is interrupted.
void track_temp_path(const std::filesystem::path& p);
void untrack_temp_path(const std::filesystem::path& p);

// Tracks `p` for its lifetime. Does not remove it on destruction (its owner does that).
class TrackedTemp {
 public:
  explicit TrackedTemp(std::filesystem::path p) : p_(std::move(p)) { track_temp_path(p_); }
  ~TrackedTemp() { untrack_temp_path(p_); }
  TrackedTemp(const TrackedTemp&) = delete;
  TrackedTemp& operator=(const TrackedTemp&) = delete;

 private:
  std::filesystem::path p_;
};

// Runs `hook` on the watcher thread before the tracked paths are removed (e.g. the batch stops
// its children). Returns an id for remove_interrupt_hook.
int add_interrupt_hook(std::function<void()> hook);
void remove_interrupt_hook(int id);

}  // namespace sawyer
